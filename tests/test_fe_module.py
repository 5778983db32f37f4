"""FE modules: cells in series in one mesh (bending module), mounted at one end."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("felupe")
pytest.importorskip("contique")

from multimorph.errors import SpecError
from multimorph.fe import FESettings, cell_mesh, chamber_volume, simulate_cell
from multimorph.geometry import CellGeometry
from multimorph.materials import Material

MU = 1.0e5


def _cell() -> CellGeometry:
    return CellGeometry(20e-3, 10e-3, 8e-3, 1e-3, 2e-3, 2e-3, 2e-3,
                        material=Material("gent", {"mu": MU, "jm": 30.0}),
                        bottom_material=Material("gent", {"mu": 10 * MU, "jm": 30.0}))


@pytest.mark.parametrize("half", [True, False])
def test_module_mesh_repeats_the_cell(half: bool) -> None:
    g = _cell()
    one = cell_mesh(g, "coarse", half=half)
    three = cell_mesh(g, "coarse", half=half, n_cells=3)
    assert three.ncells == 3 * one.ncells
    assert len(three.chamber_faces) == 3 * len(one.chamber_faces)
    assert np.bincount(three.region).tolist() == (3 * np.bincount(one.region)).tolist()
    assert three.length == pytest.approx(3 * g.length)
    # the chambers enclose exactly three reference chambers (divergence theorem, exact)
    mirror = g.width / 2 if half else None
    v1 = chamber_volume(one.points, one.chamber_faces, mirror_x=mirror)
    v3 = chamber_volume(three.points, three.chamber_faces, mirror_x=mirror)
    assert v1 == pytest.approx(g.wc * g.hc * g.dc, rel=1e-12)
    assert v3 == pytest.approx(3 * v1, rel=1e-12)
    # mounted at y = 0, free end face at y = 3d, one bottom edge line along the module
    assert np.allclose(three.points[three.end_face, 1], 3 * g.length)
    assert three.points[three.bend_line, 1].max() == pytest.approx(3 * g.length)
    with pytest.raises(SpecError, match="n_cells"):
        cell_mesh(g, "coarse", n_cells=0)


@pytest.mark.slow
def test_cells_of_a_module_bend_alike() -> None:
    """Below the ballooning, each cell of a two-cell module turns its end by the angle a
    single mounted cell turns (the shared partition is pressed from both sides and stays
    put); the module's circle fit then matches its end rotation (uniform curvature)."""
    g = _cell()
    s = FESettings(mesh="coarse", p_max=0.25 * MU)
    one = simulate_cell(g, s)
    two = simulate_cell(g, s, n_cells=2)
    assert two.stats["n_cells"] == 2 and two.response.length == pytest.approx(2 * g.length)
    for P in (0.15 * MU, 0.25 * MU):
        a1 = np.interp(P, one.response.loading.pressure, one.response.loading.extra["bend_angle"])
        a2 = np.interp(P, two.response.loading.pressure, two.response.loading.extra["bend_angle"])
        # the clamp stiffens the first cell a little: measured 0.94-0.96 on this mesh (0.2
        # and 0.3 μ)
        assert 0.85 < a2 / (2 * a1) < 1.05
        k2 = np.interp(P, two.response.loading.pressure, two.response.loading.curvature)
        assert k2 == pytest.approx(a2 / (2 * g.length), rel=0.15)
    # the chambers' volume is that of both cells
    assert two.response.path.volume[0] == pytest.approx(2 * g.wc * g.hc * g.dc, rel=1e-9)


def test_cli_fem_refuses_a_module_without_cells(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from multimorph.cli._app import _register, app

    _register()
    spec = Path(__file__).resolve().parents[1] / "examples" / "fe_cell.toml"
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["fem", str(spec), "--cells", "0", "--out", str(out),
                                   "--json"])
    assert res.exit_code != 0
    assert "--cells" in res.output
    assert not out.exists()  # nothing half-written


def test_cli_errors_keep_square_brackets(tmp_path: Path) -> None:
    """Error messages are plain text: a TOML table name like "[cell]" is printed as written,
    not swallowed as rich markup."""
    from typer.testing import CliRunner

    from multimorph.cli._app import _register, app

    _register()
    spec = tmp_path / "empty.toml"
    spec.write_text('[other]\nx = 1\n')
    res = CliRunner().invoke(app, ["fem", str(spec), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2
    assert "missing [cell] table" in res.output
