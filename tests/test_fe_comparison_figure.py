"""``comparison.png`` of ``multimorph fem --compare`` and the pressure as ParaView's time
(synthetic results, no FE run)."""

from __future__ import annotations

import re
from types import SimpleNamespace

import numpy as np
import pytest

from multimorph.fe.analyses import compare_responses
from multimorph.fe.report import comparison_curves, plot_comparison, write_comparison_figure
from multimorph.response import EquilibriumPath, build_response

MU = 60e3


def _response(scale: float, centre: float, backend: str, *, stretching: bool = False):
    """A cell whose signal (κ, or λ − 1 for a stretching cell) rises steepest at ``centre``
    (Pa)."""
    P = np.linspace(0.0, 60e3, 241)
    rise = scale * (np.tanh((P - centre) / 5e3) + np.tanh(centre / 5e3))
    z = np.zeros_like(P)
    path = EquilibriumPath(pressure=P, curvature=z if stretching else rise, twist_rate=z,
                           axial_stretch=1 + rise if stretching else z + 1, volume=1 + P,
                           peak_stretch=1 + P / MU, stable=np.ones_like(P, bool))
    return build_response(path, length=0.01, shear_modulus=MU, backend=backend,
                          signal="axial_stretch" if stretching else "curvature")


def _texts(ax) -> list[str]:
    return [t.get_text() for t in ax.get_legend().get_texts()]


def _markers(ax, marker: str, colour: str) -> list[float]:
    from matplotlib.colors import to_rgba

    return [float(line.get_xdata()[0]) for line in ax.get_lines()
            if line.get_marker() == marker and to_rgba(line.get_color()) == to_rgba(colour)]


def test_cell_figure_sets_the_model_against_fe_with_pc_marked(tmp_path) -> None:
    c = compare_responses(_response(40.0, 40e3, "rom"), _response(30.0, 25e3, "fe"))
    (curve,) = comparison_curves(c)  # a cell run's reduced model is the Ritz model
    assert (curve.quantity, curve.model) == ("curvature", "ritz")
    fig = plot_comparison([curve], tmp_path / "comparison.png")
    assert (tmp_path / "comparison.png").stat().st_size > 10_000
    (ax,) = fig.axes
    assert ax.get_xlabel() == "pressure P (kPa)" and ax.get_ylabel() == "curvature κ (1/m)"
    texts = _texts(ax)
    assert texts[0].startswith("3D FE: Pc 25") and texts[1].startswith("ritz model: Pc 40")
    # Pc of each on its own curve, in kPa
    assert _markers(ax, "o", "k") == pytest.approx([c.pc_fe / 1e3])
    assert _markers(ax, "o", "tab:blue") == pytest.approx([c.pc_rom / 1e3])
    assert c.pc_fe == pytest.approx(25e3, rel=0.02) and c.pc_rom == pytest.approx(40e3, rel=0.02)


def test_stretching_cell_compares_the_stretch() -> None:
    c = compare_responses(_response(0.1, 40e3, "rom", stretching=True),
                          _response(0.1, 25e3, "fe", stretching=True))
    (curve,) = comparison_curves(c, model="calibrated")
    assert curve.quantity == "axial_stretch" and curve.model == "calibrated"
    np.testing.assert_allclose(curve.value_fe, c.stretch_fe)


def _device_comparison() -> dict:
    P = np.linspace(0.0, 30e3, 7).tolist()
    return {
        "base": {"kind": "bending", "model": "calibrated", "pc_fe": 10e3, "ph_fe": 20e3,
                 "pc_rom": 15e3, "ph_rom": None,
                 "curves": {"quantity": "bend_angle_deg", "pressure_pa_fe": P,
                            "fe": [0, 5, 20, 60, 80, 85, 88], "pressure_pa_rom": P,
                            "rom": [0, 3, 10, 30, 60, 75, 80]}},
        "seal": {"kind": "stretching", "model": "ritz", "pc_fe": None, "ph_fe": None,
                 "pc_rom": None, "ph_rom": None,
                 "curves": {"quantity": "axial_stretch", "pressure_pa_fe": P,
                            "fe": [1, 1.01, 1.02, 1.04, 1.06, 1.08, 1.1],
                            "pressure_pa_rom": P, "rom": [1, 1, 1.01, 1.02, 1.03, 1.04, 1.05]}},
    }


def test_device_figure_has_a_panel_per_module_and_says_which_model(tmp_path) -> None:
    outcome = SimpleNamespace(job=SimpleNamespace(kind="device", device=SimpleNamespace(
        name="two"), module=None, n_cells=1, tilt=0.0), comparison=_device_comparison())
    write_comparison_figure(outcome, tmp_path / "comparison.png")
    assert (tmp_path / "comparison.png").is_file()
    fig = plot_comparison(comparison_curves(outcome.comparison), tmp_path / "again.png")
    titles = [ax.get_title() for ax in fig.axes]
    assert titles == ["base (bending)", "seal (stretching)"]
    base, seal = fig.axes
    assert base.get_ylabel() == "bend angle (deg)" and seal.get_ylabel() == "axial stretch λ (-)"
    assert _texts(base)[:2] == ["3D FE: Pc 10 kPa, Ph 20 kPa",
                                "calibrated model: Pc 15 kPa, Ph not reached"]
    assert _texts(seal)[1] == "ritz model: Pc not reached, Ph not reached"
    assert _markers(base, "s", "k") == [20.0] and _markers(base, "s", "tab:blue") == []


def test_twisting_module_figure_reads_the_twist_angles() -> None:
    cmp = {"module": "twister", "pressure_pa": [5e3, 10e3], "twist_deg_fe": [2.0, 8.0],
           "twist_deg_rom": [1.0, 4.0], "pc_fe": None, "pc_rom": None, "ph_fe": None,
           "ph_rom": None, "model": "ritz"}
    (curve,) = comparison_curves(cmp)
    assert curve.name == "twister" and curve.quantity == "twist_angle_deg"
    np.testing.assert_allclose(curve.value_model, [1.0, 4.0])


def test_vtu_series_time_is_the_pressure_in_kpa(tmp_path) -> None:
    pytest.importorskip("meshio")
    from multimorph.fe.report import write_hex_series

    points = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    cells = np.array([[0, 1, 3, 2, 4, 5, 7, 6]])
    pressures = [0.0, 12.5e3, 11e3]  # past a limit point the pressure falls back
    files = write_hex_series(tmp_path, "cell", points, cells, [0 * points] * 3,
                             [np.ones(1)] * 3, pressures, {"region": np.zeros(1)})
    assert files[0] == "cell.pvd" and len(files) == 4
    pvd = (tmp_path / "cell.pvd").read_text()
    steps = [float(t) for t in re.findall(r'timestep="([^"]+)"', pvd)]
    assert steps == [0.0, 12.5, 11.0]
    assert re.findall(r'name="([^"]+)"', pvd) == ["0000 P=0kPa", "0001 P=12.5kPa",
                                                  "0002 P=11kPa"]
