"""Sweeps of the three cell kinds, space-filling designs and the per-design FE options."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from multimorph.errors import SpecError
from multimorph.geometry import CellGeometry, TiltedCell
from multimorph.sweep import parse_sweep_spec, record_from_response
from multimorph.sweep._backends import FeBackend, tilted_shear

BASE = """
[cell]
length = "20 mm"
width = "10 mm"
height = "8 mm"
top_wall = "1 mm"
bottom_wall = "2 mm"
side_wall = "2 mm"
end_wall = "2 mm"

[cell.material]
model = "gent"
mu = "100 kPa"
jm = 30

[cell.bottom_material]
model = "gent"
mu = "1 MPa"
jm = 30

[sweep]
backend = "rom"
outputs = ["characteristic", "curves"]
pmax = "60 kPa"
"""

PARAMS = """
[sweep.parameters]
"ht/d" = { start = 0.03, stop = 0.09, scale = "log" }
"ws/d" = { start = 0.05, stop = 0.15 }
"""


def spec(extra: str) -> dict:
    return tomllib.loads(BASE + extra)


@pytest.mark.parametrize("combine", ["sobol", "lhs"])
def test_space_filling_designs_fill_each_range_and_are_reproducible(combine: str) -> None:
    s = parse_sweep_spec(spec(f'combine = "{combine}"\nsamples = 64\nseed = 3\n' + PARAMS))
    v = s.point_values()
    assert v.shape == (64, 2)
    assert np.all((v[:, 0] >= 0.03) & (v[:, 0] <= 0.09))
    # a log range: log-uniform, so the geometric mean splits the sample in halves
    below = np.mean(v[:, 0] < math.sqrt(0.03 * 0.09))
    assert 0.4 < below < 0.6
    # stratified in each coordinate: every eighth of the ws/d range holds 8 points (LHS)
    # or close to it (scrambled Sobol, a (t, m, s)-net: 8 exactly too for 64 points)
    counts = np.histogram(v[:, 1], bins=8, range=(0.05, 0.15))[0]
    assert counts.min() >= 7 and counts.max() <= 9
    np.testing.assert_array_equal(v, parse_sweep_spec(spec(
        f'combine = "{combine}"\nsamples = 64\nseed = 3\n' + PARAMS)).point_values())


def test_space_filling_designs_need_ranges_not_lists() -> None:
    with pytest.raises(SpecError, match="ranges"):
        parse_sweep_spec(spec('combine = "sobol"\nsamples = 8\n[sweep.parameters]\n'
                              '"ht/d" = [0.03, 0.05]\n'))


def test_stretching_sweep_builds_mirror_symmetric_cells() -> None:
    s = parse_sweep_spec(spec('kind = "stretching"\ncombine = "sobol"\nsamples = 8\n' + PARAMS))
    for c in s.design_table().cells:
        assert isinstance(c, CellGeometry) and c.symmetric
        assert c.bottom_wall == c.top_wall and c.bottom_material == c.material
    with pytest.raises(SpecError, match="stretching"):
        parse_sweep_spec(spec('kind = "stretching"\n[sweep.parameters]\n"hb/d" = [0.05]\n'))


def test_twisting_sweep_builds_tilted_cells_with_a_swept_or_fixed_tilt() -> None:
    s = parse_sweep_spec(spec('kind = "twisting"\n[sweep.parameters]\n'
                              '"tilt" = ["20 deg", "40 deg"]\n"ht/d" = [0.05]\n'))
    cells = s.design_table().cells
    assert all(isinstance(c, TiltedCell) for c in cells)
    assert [round(math.degrees(c.tilt)) for c in cells] == [20, 40]  # type: ignore[union-attr]
    s = parse_sweep_spec(spec('kind = "twisting"\ntilt = "30 deg"\n[sweep.parameters]\n'
                              '"ht/d" = [0.05]\n'))
    c = s.design_table().cells[0]
    assert isinstance(c, TiltedCell) and c.tilt == pytest.approx(math.radians(30))
    with pytest.raises(SpecError, match="tilt"):
        parse_sweep_spec(spec('kind = "twisting"\n[sweep.parameters]\n"ht/d" = [0.05]\n'))
    with pytest.raises(SpecError, match="twisting"):
        parse_sweep_spec(spec('[sweep.parameters]\n"tilt" = ["20 deg"]\n'))


def test_min_chamber_keeps_small_chambers_as_invalid_points_with_the_reason() -> None:
    s = parse_sweep_spec(spec('min_chamber = 0.2\n[sweep.parameters]\n'
                              '"ws/d" = [0.05, 0.2]\n'))
    t = s.design_table()
    assert t.cells[0] is not None and t.cells[1] is None  # wc = 10 - 8 = 2 mm < 4 mm
    assert "chamber width" in t.invalid[0].reason and "min_chamber" in t.invalid[0].reason


def test_tilted_cell_validates_its_tilt() -> None:
    cell = parse_sweep_spec(spec('[sweep.parameters]\n"ht/d" = [0.05]\n')).base
    for bad in (0.0, math.radians(85), float("nan")):
        with pytest.raises(SpecError, match="tilt"):
            TiltedCell(cell, bad)
    assert TiltedCell(cell, -0.5).ratios()["tilt"] == -0.5


def test_fe_backend_options_are_checked_before_any_run() -> None:
    be = FeBackend()
    be.validate(6e4, {"n_cells": 1, "end": "plate", "wall_elements": 2,
                      "length_fraction": 0.05, "pmax_rule": "rom", "pmax_factor": 1.1})
    for bad, field in (({"end": "glued"}, "end"), ({"n_cells": 0}, "n_cells"),
                       ({"wall_elements": 0}, "wall_elements"),
                       ({"length_fraction": 2.0}, "length_fraction"),
                       ({"pmax_rule": "guess"}, "pmax_rule"), ({"pmax_factor": -1}, "pmax_factor"),
                       ({"no_such_setting": 1}, "not an FE setting")):
        with pytest.raises(SpecError, match=field):
            be.validate(6e4, bad)
    be.validate(6e4, {"end": "mirror"})            # straight cells: mirror ends
    fe = be._api()
    with pytest.raises(SpecError, match=r"sweep\.options\.end: .*mirror.* straight cells"):
        be._settings(fe, 6e4, {"end": "mirror"}, tilted=True)


def test_tilted_shear_is_the_twisting_modules_rule() -> None:
    """γ = (λ_mid − 1) sin 2|β|, the rule of ``device`` twisting modules (on a synthetic path)."""
    from multimorph.response import EquilibriumPath, build_response

    cell = parse_sweep_spec(spec('[sweep.parameters]\n"ht/d" = [0.05]\n')).base
    n = 6
    path = EquilibriumPath(pressure=np.linspace(0, 5e4, n), curvature=np.linspace(0, 10, n),
                           twist_rate=np.zeros(n), axial_stretch=np.linspace(1, 1.05, n),
                           volume=np.linspace(1e-6, 2e-6, n), peak_stretch=np.ones(n),
                           stable=np.ones(n, bool))
    resp = build_response(path, length=cell.length, shear_modulus=cell.mu, backend="rom")
    lam = path.axial_stretch * (1 + path.curvature * cell.height / 2)
    np.testing.assert_allclose(tilted_shear(resp, cell, -math.radians(30)),
                               (lam - 1) * math.sin(math.radians(60)))
    rec = record_from_response(resp, ["curves"])
    assert set(rec) >= {"axial_stretch", "volume", "pressure", "stable"}


def test_a_limited_run_evaluates_the_first_pending_designs_and_a_rerun_the_rest(tmp_path) -> None:
    """``run_sweep(limit=)`` grows a sweep in passes (the FE reference data set does)."""
    from multimorph.sweep import open_results, run_sweep

    class Count:
        name, batch_size = "count", 2

        def evaluate_batch(self, designs, pmax, outputs, options):  # type: ignore[no-untyped-def]
            return [{"critical_pressure": float(c.top_wall)} for c in designs]

    s = parse_sweep_spec(spec('[sweep.parameters]\n"ht/d" = [0.03, 0.04, 0.05, 0.06, 0.07]\n'))
    first = run_sweep(s, tmp_path / "s", scheduler="sync", limit=2, backend=Count())
    assert first.n_run == 2 and first.n_ok == 2
    status = open_results(tmp_path / "s")["status"].values
    assert list(status) == ["ok", "ok", "pending", "pending", "pending"]
    second = run_sweep(s, tmp_path / "s", scheduler="sync", backend=Count())
    assert second.n_run == 3 and second.n_resumed == 2 and second.n_ok == 5


def test_a_tilted_cell_through_the_reduced_backend_gives_its_shear_record() -> None:
    """Every backend turns a tilted cell's response into a record read on the strip shear
    (the shared record builder; a tilted FE design failed there once, after its FE run)."""
    from multimorph.io import load_toml
    from multimorph.sweep import get_backend

    cell = CellGeometry.from_spec(load_toml(
        __import__("pathlib").Path(__file__).resolve().parents[1] / "examples" / "cell.toml")
        ["cell"])
    out = get_backend("rom").evaluate_batch([TiltedCell(cell, math.radians(30))],
                                            0.4 * cell.mu, ("characteristic", "curves"), {})
    rec = out[0]
    assert not isinstance(rec, BaseException), rec
    shear = np.asarray(rec["shear"])
    assert shear.shape == np.asarray(rec["pressure"]).shape
    assert np.all(np.isfinite(shear)) and shear[-1] > 0      # the strip shears with the tilt
    assert rec["meta"]["model"] == "ritz"


def test_a_run_of_chosen_designs_with_other_options_leaves_the_rest_pending(tmp_path) -> None:
    """``run_sweep(designs=, options=)`` runs a few designs again with other backend
    options (the data set's refinement does, with finer continuation steps)."""
    from multimorph.sweep import open_results, run_sweep

    class Scaled:
        name, batch_size = "scaled", 1

        def evaluate_batch(self, designs, pmax, outputs, options):  # type: ignore[no-untyped-def]
            return [{"critical_pressure": options.get("scale", 1.0) * c.top_wall}
                    for c in designs]

    s = parse_sweep_spec(spec('[sweep.parameters]\n"ht/d" = [0.03, 0.04, 0.05, 0.06]\n'
                              '[sweep.options]\nscale = 1.0\n'))
    out = run_sweep(s, tmp_path / "s", scheduler="sync", backend=Scaled(), designs=[3, 1],
                    options={"scale": 2.0})
    assert out.n_run == 2
    ds = open_results(tmp_path / "s")
    assert list(ds["status"].values) == ["pending", "ok", "pending", "ok"]
    top = [c.top_wall for c in s.design_table().cells]
    np.testing.assert_allclose(ds["critical_pressure"].values[[1, 3]],
                               [2 * top[1], 2 * top[3]])
    again = run_sweep(s, tmp_path / "s", scheduler="sync", backend=Scaled(), designs=[1])
    assert again.n_run == 0  # finished designs are not run again
    with pytest.raises(SpecError, match="designs: \\[7\\]"):
        run_sweep(s, tmp_path / "t", scheduler="sync", backend=Scaled(), designs=[7])
    assert not (tmp_path / "t").exists()  # refused before anything was created
