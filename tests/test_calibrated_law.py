"""How a wall of another law is placed in the Gent-calibrated model (``calibrated._law``)."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from multimorph.calibrated._law import (
    SEARCH_JM,
    SEARCH_MU_FACTOR,
    effective_cell,
    effective_material,
    law_shape,
    membrane_limit_point,
    wall_activates,
)
from multimorph.calibrated._law_fit import fit_law_map
from multimorph.geometry import CellGeometry
from multimorph.materials import Material

MAP = {"shape_range": [0.005, 0.2], "log_mu_factor": [0.3, 0.05], "log_jm": [2.0, -0.3]}


def _cell(wall: Material, bottom: Material | None = None) -> CellGeometry:
    bottom = bottom or Material("gent", {"mu": 1e6, "jm": 30.0})
    return CellGeometry(20e-3, 10e-3, 8e-3, 1e-3, 2e-3, 2e-3, 2e-3, material=wall,
                        bottom_material=bottom)


def test_law_shape_is_a_yeoh_walls_own_c20_over_c10_and_reads_any_law() -> None:
    assert law_shape(Material("yeoh", {"c10": 5e4, "c20": 2e3, "c30": 0.0})) == 0.04
    # with a small c30 the nearest two-term Yeoh curve is a little stiffer
    k = law_shape(Material("yeoh", {"c10": 5e4, "c20": 2e3, "c30": 10.0}))
    assert 0.04 < k < 0.045
    # the closed-form least squares reads a two-term Yeoh law given through another name
    # exactly: the reduced polynomial of order 6 with only c10, c20
    rp = Material("reduced-polynomial-6", {"c10": 5e4, "c20": 3e3, "c30": 0.0, "c40": 0.0,
                                           "c50": 0.0, "c60": 0.0})
    assert law_shape(rp) == pytest.approx(0.06, rel=1e-9)
    # neo-Hooke does not harden; a Gent wall hardens faster the smaller its Jm
    assert law_shape(Material("neo-hooke", {"mu": 1e5})) == pytest.approx(0.0, abs=1e-12)
    assert (law_shape(Material("gent", {"mu": 1e5, "jm": 15.0}))
            > law_shape(Material("gent", {"mu": 1e5, "jm": 40.0})) > 0)


def test_a_gent_wall_is_itself_and_a_yeoh_wall_its_mapped_gent_wall() -> None:
    gent = Material("gent", {"mu": 1e5, "jm": 30.0})
    cell = _cell(gent)
    assert effective_cell(cell, MAP) == (cell, None)
    yeoh = Material("yeoh", {"c10": 5e4, "c20": 2e3, "c30": 0.0}, break_stretch=6.0)
    eff, info = effective_material(yeoh, MAP)
    s = math.exp(0.3 + 0.05 * math.log(0.04))
    jm = math.exp(2.0 - 0.3 * math.log(0.04))
    assert eff.model == "gent" and eff.break_stretch == 6.0
    assert eff.params["mu"] == pytest.approx(1e5 * s) and eff.params["jm"] == pytest.approx(jm)
    assert info["mu_factor"] == pytest.approx(s) and info["shape_c20_c10"] == 0.04
    # one elastomer stays one elastomer (μb/μ = 1 after the mapping too)
    placed, both = effective_cell(_cell(yeoh, yeoh), MAP)
    assert placed.bottom_material == placed.material and set(both) == {"wall", "bottom"}
    # outside the map's range of shapes (neo-Hooke: k = 0) or without a map: not placed
    assert effective_material(Material("neo-hooke", {"mu": 1e5}), MAP) == (
        Material("neo-hooke", {"mu": 1e5}), None)
    assert effective_material(yeoh, None)[1] is None


#: The synthetic law map of the fit tests: ln s, ln Jm_eff linear in ln k.
TRUE_LINE = (0.15, 0.04, 2.6, -0.35)


def _true_wall(k: float) -> tuple[float, float]:
    """(ln s, ln Jm_eff) of :data:`TRUE_LINE` at shape ``k``."""
    return (TRUE_LINE[0] + TRUE_LINE[1] * math.log(k),
            TRUE_LINE[2] + TRUE_LINE[3] * math.log(k))


def test_fit_law_map_finds_the_line_through_the_designs_cost_minima() -> None:
    """Synthetic costs: each design's cost is a bowl around the wall the true line gives
    its shape; the fit recovers the line."""
    ls, lj = np.log(SEARCH_MU_FACTOR), np.log(SEARCH_JM)
    shapes = np.geomspace(0.006, 0.18, 12)
    true = TRUE_LINE
    cost = []
    for k in shapes:
        a, b = _true_wall(k)
        cost.append(np.abs(ls[:, None] - a) * 3 + np.abs(lj[None, :] - b))
    fit = fit_law_map({"design": np.arange(12), "shape": shapes, "cost": np.array(cost)})
    assert fit["log_mu_factor"] == pytest.approx(true[:2], abs=0.02)
    assert fit["log_jm"] == pytest.approx(true[2:], abs=0.03)
    assert fit["shape_range"] == pytest.approx([0.006, 0.18])
    # the costs are read off the grid by bilinear interpolation: within a grid step of 0
    assert fit["cost"]["median"] < 3 * np.diff(ls)[0] + np.diff(lj)[0]


@pytest.mark.parametrize("seed", [0, 1, 5])
def test_fit_law_map_crosses_a_ridge_of_mu_against_jm_to_the_best_line(seed: int) -> None:
    """Synthetic costs flat along a ridge (a stiffer μ traded for a lower Jm, as on the real
    designs) with one narrow distractor well per design, so the line through the designs'
    own best walls starts far off: the fit's mean cost is no worse than the true line's
    (the three starts of stops 49–51 stopped above it on these seeds; stop 52's refit on
    the real designs stopped at 0.2865 where 0.2815 was)."""
    from scipy.interpolate import RegularGridInterpolator

    rng = np.random.default_rng(seed)
    ls, lj = np.log(SEARCH_MU_FACTOR), np.log(SEARCH_JM)
    shapes = np.geomspace(0.006, 0.18, 16)
    cost = []
    for k in shapes:
        a, b = _true_wall(k)
        ridge = (ls[:, None] - a) - 0.3 * (lj[None, :] - b)
        c = 3 * np.abs(ridge) + 0.15 * np.abs(lj[None, :] - b)
        c[rng.integers(len(ls)), rng.integers(len(lj))] -= 0.5 + 0.5 * rng.random()
        cost.append(c)
    fit = fit_law_map({"design": np.arange(16), "shape": shapes, "cost": np.array(cost)})
    at_true = np.mean([RegularGridInterpolator((ls, lj), c)(
        (np.clip(_true_wall(k)[0], ls[0], ls[-1]), np.clip(_true_wall(k)[1], lj[0], lj[-1])))
        for c, k in zip(cost, shapes, strict=True)])
    assert fit["cost"]["mean"] <= at_true + 1e-3

# ------------------------------------------------ whether a placed stretching cell activates
def _yeoh_sphere_snaps(k: float) -> bool:
    """Closed form, independent of the library: a thin Yeoh sphere (c30 = 0) has
    P ∝ (λ⁻¹ − λ⁻⁷)(1 + 2k(I1 − 3)), I1 = 2λ² + λ⁻⁴; does it pass a maximum by V = 25 V0?"""
    lam = np.linspace(1.0, 25.0 ** (1 / 3), 20001)[1:]
    p = (1 / lam - lam ** -7) * (1 + 2 * k * (2 * lam ** 2 + lam ** -4 - 3))
    return bool(np.any(np.diff(p) < 0))


def test_a_yeoh_membrane_loses_its_limit_point_where_the_closed_form_does() -> None:
    """Oracle: the threshold of c20/c10 above which a Yeoh balloon no longer snaps
    (0.0424 by the closed form, bisected here), read by ``membrane_limit_point`` on the
    law's own equibiaxial stress; neo-Hooke always snaps, Gent only above Jm ≈ 17.7, and a
    Gent wall that locks within the range is not read (None)."""
    lo, hi = 0.01, 0.1
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _yeoh_sphere_snaps(mid) else (lo, mid)
    assert 0.040 < lo < 0.045
    yeoh = [Material("yeoh", {"c10": 5e4, "c20": f * lo * 5e4, "c30": 0.0})
            for f in (0.98, 1.02)]
    assert membrane_limit_point(yeoh[0]) is True
    assert membrane_limit_point(yeoh[1]) is False
    assert membrane_limit_point(Material("neo-hooke", {"mu": 1e5})) is True
    assert membrane_limit_point(Material("gent", {"mu": 1e5, "jm": 40.0})) is True
    assert membrane_limit_point(Material("gent", {"mu": 1e5, "jm": 16.0})) is False
    assert membrane_limit_point(Material("gent", {"mu": 1e5, "jm": 9.0})) is None
    # the classic neo-Hookean balloon: its pressure peaks at λ = 7^(1/6) = 1.383
    from multimorph.calibrated._law import membrane_summary

    nh = membrane_summary(Material("neo-hooke", {"mu": 1e5}))
    assert nh["limit_stretch"] == pytest.approx(7 ** (1 / 6), abs=0.005)
    assert nh["cells_activate"] is True


def test_wall_activates_only_fails_a_stiffening_law_without_a_limit_point() -> None:
    assert wall_activates(Material("yeoh", {"c10": 5e4, "c20": 1e3, "c30": 0.0}))
    assert not wall_activates(Material("yeoh", {"c10": 5e4, "c20": 5e3, "c30": 0.0}))
    # the model learned Gent walls (all activate in FE, by a knee where they lock)
    assert wall_activates(Material("gent", {"mu": 1e5, "jm": 12.0}))
    assert wall_activates(Material("neo-hooke", {"mu": 1e5}))
    # a softening law (Mooney-Rivlin, no Yeoh shape): nothing FE has told about
    assert wall_activates(Material("mooney-rivlin", {"c10": 4e4, "c01": 2e4}))


def test_the_rule_agrees_with_fe_on_every_yeoh_stretching_cell() -> None:
    """Physics: in FE a Yeoh-walled stretching cell has a Pc up to c20/c10 = 0.036 and none
    from 0.043 (``yeoh_stretching_mirror``, 30 cells over the box): the membrane's rule
    says which on every one of them, whatever the geometry."""
    from multimorph.calibrated._fit import fe_training_data
    from multimorph.calibrated._validate import fe_response

    data = fe_training_data("stretching", set_names=("yeoh_stretching_mirror",), ritz=False)
    assert len(data.cells) >= 25
    has = [fe_response(p, c, "stretching").characteristic.critical is not None
           for p, c in zip(data.paths, data.cells, strict=True)]
    assert 0 < sum(has) < len(has)
    assert [wall_activates(c.material) for c in data.cells] == has


def test_the_rule_agrees_with_fe_on_most_yeoh_tilted_cells_and_the_model_follows_it() -> None:
    """Physics: tilted cells with Yeoh walls (``yeoh_twisting``, 28 over the box) twist
    without a knee in FE above the membrane's threshold on 9 of 12 (a weak max-slope knee on
    3), and have a Pc below it on 15 of 16: the rule agrees with FE on 24 of 28, where
    "every cell activates" (the effective Gent wall's answer) agreed on 18. The shipped
    model reports no Pc exactly where the rule says so."""
    from multimorph.calibrated._fit import fe_training_data
    from multimorph.calibrated._validate import fe_response
    from multimorph.calibrated.validate import requested_pressure

    model = _shipped()
    data = fe_training_data("twisting", set_names=("yeoh_twisting",), ritz=False)
    assert len(data.cells) >= 25
    has = np.array([fe_response(p, c, "twisting").characteristic.critical is not None
                    for p, c in zip(data.paths, data.cells, strict=True)])
    rule = np.array([wall_activates(c.cell.material) for c in data.cells])
    assert np.mean(rule == has) >= 0.85 and np.mean(rule == has) > np.mean(has) + 0.15
    for r in np.flatnonzero(~rule)[:3]:
        p = requested_pressure("yeoh_twisting", int(data.design[r]), data.paths[r])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            got = model.responses([data.cells[r]], p, fast=True)[0]
        assert got.meta["model"] == "calibrated-fast"
        assert got.characteristic.critical is None
        assert got.meta["calibration"]["activation"]["activates"] is False


# ---------------------------------------------------------------- the shipped law map
def _shipped():
    import multimorph.calibrated as mc

    model = mc.load_model()
    if not model.law_map:
        pytest.skip("the shipped model has no law map")
    return model


def test_the_shipped_model_answers_a_yeoh_wall_as_its_mapped_gent_wall() -> None:
    model = _shipped()
    yeoh = Material("yeoh", {"c10": 5e4, "c20": 2e3, "c30": 0.0}, break_stretch=6.0)
    cell = _cell(yeoh)
    eff, info = effective_material(yeoh, model.law_map)
    r = model.responses([cell], 80e3, fast=True)[0]
    ref = model.responses([_cell(eff)], 80e3, fast=True)[0]
    assert r.meta["model"] == "calibrated-fast"
    assert r.characteristic.critical == pytest.approx(ref.characteristic.critical, rel=1e-12)
    np.testing.assert_allclose(r.path.curvature, ref.path.curvature)
    assert r.shear_modulus == yeoh.shear_modulus           # reported against its own μ
    law = r.meta["calibration"]["law"]["wall"]
    assert law["rule"] == "yeoh-shape map" and law["effective_jm"] == pytest.approx(
        eff.params["jm"]) and law["mu_factor"] == pytest.approx(info["mu_factor"])
    # its band holds the map's own spread too (the GP's σ knows Gent walls only)
    sigma = model.law_map["spread"]["sigma_log_pc"]
    lo, hi = r.meta["calibration"]["critical_pressure_range"]
    lo0, hi0 = ref.meta["calibration"]["critical_pressure_range"]
    assert math.log(hi / lo) == pytest.approx(
        2 * math.hypot(0.5 * math.log(hi0 / lo0), sigma), rel=0.05)
    assert math.log(hi / lo) > math.log(hi0 / lo0) + sigma


def test_the_librarys_elastosil_is_inside_the_support_and_neo_hooke_is_not() -> None:
    """Elastosil M4601 (Yeoh, c20/c10 0.18) was placed at the closest Gent Jm 8.6, below
    the box (Ritz fallback, twice as stiff as FE) until stop 49; the law map places it.
    A wall that does not harden (neo-Hooke) has no Yeoh shape in the map's range: it keeps
    the closest-Gent placement, outside the box, and is answered by the Ritz model."""
    from multimorph.calibrated import CalibrationWarning
    from multimorph.materials import get_material

    model = _shipped()
    el = _cell(get_material("elastosil-m4601"))
    assert model.support(el)["inside"]
    r = model.responses([el], 150e3, fast=True)[0]
    assert r.meta["model"] == "calibrated-fast"
    nh = _cell(Material("neo-hooke", {"mu": 1e5}))
    assert not model.support(nh)["inside"]
    with pytest.warns(CalibrationWarning):
        assert model.responses([nh], 50e3, fast=True)[0].meta["model"] == "ritz"


def _held_out_errors(models: tuple[Any, ...], sets: tuple[str, ...], which: str,
                     keep: Any = None) -> list[np.ndarray]:
    """|Δ``which``|/``which`` ("pc_error", "ph_error") of each model against FE on the
    held-out Yeoh-walled bending cells of ``sets`` that ``keep(cell, fe)`` accepts (a
    missing value: a miss, 1.0)."""
    from multimorph.calibrated._fit import fe_training_data
    from multimorph.calibrated._validate import compare, fe_response
    from multimorph.calibrated.validate import requested_pressure

    err: list[list[float]] = [[] for _ in models]
    for name in sets:
        data = fe_training_data("bending", set_names=(name,), ritz=False)
        for r in np.flatnonzero(data.holdout):
            cell, fe = data.cells[r], fe_response(data.paths[r], data.cells[r], "bending")
            if keep is not None and not keep(cell, fe):
                continue
            p = requested_pressure(name, int(data.design[r]), data.paths[r])
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                got = [m.responses([cell], p, fast=True)[0] for m in models]
            for e, resp in zip(err, got, strict=True):
                v = getattr(compare(resp, fe, "bending"), which)
                e.append(v if math.isfinite(v) else 1.0)
    return [np.array(e) for e in err]


def test_the_law_map_places_held_out_yeoh_cells_closer_to_fe_than_the_closest_gent() -> None:
    """Physics: on the Yeoh-walled FE cells the map never saw (the held-out designs of
    `yeoh2_mirror` and all of `yeoh_mirror`), Pc within 5 % of FE at the median and closer
    than the closest-Gent placement on most; stop 49 measured 3.4-4.2 % median against
    5.6-10.9 % (docs/validation.md §3)."""
    import copy

    model = _shipped()
    closest = copy.copy(model)
    closest.law_map = None
    m, c = _held_out_errors((model, closest), ("yeoh2_mirror", "yeoh_mirror"), "pc_error")
    assert len(m) >= 20
    assert np.median(m) < 0.05
    assert np.median(m) < np.median(c) and np.mean(m < c) > 0.5


def test_a_stretching_cell_of_a_strongly_hardening_wall_reports_no_activation() -> None:
    """A stretching cell whose Yeoh wall has no membrane limit point: no Pc, no Ph (FE has
    none) and why, its curve the effective wall's; the same wall on a bending cell (which
    activates in FE, `yeoh2_mirror`) keeps its Pc."""
    model = _shipped()
    wall = Material("yeoh", {"c10": 5e4, "c20": 5e3, "c30": 0.0}, break_stretch=6.0)
    eff, _ = effective_material(wall, model.law_map)
    st = CellGeometry(20e-3, 10e-3, 8e-3, 1e-3, 1e-3, 2e-3, 2e-3, material=wall,
                      symmetric=True)
    r = model.responses([st], 60e3, fast=True)[0]
    ref = model.responses([replace(st, material=eff, bottom_material=eff)], 60e3,
                          fast=True)[0]
    assert r.meta["model"] == "calibrated-fast" and ref.characteristic.critical is not None
    assert r.characteristic.critical is None and r.characteristic.hardening is None
    cal = r.meta["calibration"]
    assert cal["activation"]["activates"] is False and "limit point" in cal["activation"][
        "reason"]
    assert cal["critical_pressure_range"] == [None, None]
    np.testing.assert_allclose(r.path.axial_stretch, ref.path.axial_stretch)
    bend = model.responses([_cell(wall)], 150e3, fast=True)[0]
    assert bend.meta["model"] == "calibrated-fast"
    assert bend.characteristic.critical is not None
    assert "activation" not in bend.meta["calibration"]


def test_simulate_says_which_module_does_not_activate() -> None:
    """The jar lifter with a strongly hardening Yeoh elastomer (c20/c10 0.08): its
    stretching module has no activation window and the summary's notes say why; its
    bending module keeps its Pc."""
    import tomllib
    from pathlib import Path

    from multimorph.device import device_from_spec, simulate_device

    _shipped()
    spec = tomllib.loads((Path(__file__).parents[1] / "examples" / "jar_lifter.toml")
                         .read_text())
    spec["materials"]["elastomer-III"] = {"model": "yeoh", "c10": "122.5 kPa",
                                          "c20": "10 kPa", "c30": "0 kPa",
                                          "break_stretch": 8.0}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate_device(device_from_spec(spec))
    assert res.sequence.windows["sealer"][0] is None
    assert res.sequence.windows["lifter"][0] is not None
    notes = res.to_dict()["notes"]
    assert any(n.startswith("sealer: no activation") and "limit point" in n for n in notes)


def test_a_calibrated_sweep_records_why_a_cell_does_not_activate() -> None:
    from multimorph.sweep._backends import CalibratedFastBackend

    _shipped()
    wall = Material("yeoh", {"c10": 5e4, "c20": 5e3, "c30": 0.0}, break_stretch=6.0)
    st = CellGeometry(20e-3, 10e-3, 8e-3, 1e-3, 1e-3, 2e-3, 2e-3, material=wall,
                      symmetric=True)
    rec = CalibratedFastBackend().evaluate_batch([st, _cell(wall)], 60e3,
                                                 ["characteristic"], {})
    assert rec[0]["meta"]["activation"]["activates"] is False
    assert "activation" not in rec[1]["meta"]


def test_a_bending_cell_of_a_wall_that_does_not_lock_hardens_later() -> None:
    """The law map's Ph factor (``law_map["ph_shift"]``, fitted on FE): a bending cell of a
    mapped wall whose membrane has no limit point reports Ph × e^shift of its effective
    wall's (its band moved with it); below the threshold nothing moves."""
    model = _shipped()
    shift = (model.law_map or {}).get("ph_shift") or {}
    if not shift.get("log_factor"):
        pytest.skip("the shipped law map has no Ph factor")
    assert 0.0 < shift["log_factor"] < 0.4 and shift["training_designs"] >= 3
    # c20/c10 0.04: a membrane with a limit point, below the threshold (the 0.02 of stop
    # 58's test runs away at its snap on stop 59's map, Jm 72: no Ph to compare)
    for c20, moves in ((5e3, True), (2e3, False)):
        wall = Material("yeoh", {"c10": 5e4, "c20": c20, "c30": 0.0}, break_stretch=6.0)
        eff, _ = effective_material(wall, model.law_map)
        r = model.responses([_cell(wall)], 200e3, fast=True)[0]
        ref = model.responses([_cell(eff)], 200e3, fast=True)[0]
        ph, ph0 = r.characteristic.hardening, ref.characteristic.hardening
        assert ph is not None and ph0 is not None
        f = math.exp(shift["log_factor"]) if moves else 1.0
        assert ph == pytest.approx(max(ph0 * f, r.characteristic.critical), rel=1e-9)
        assert ("ph_shift" in r.meta["calibration"]) is moves
        assert r.characteristic.critical == pytest.approx(ref.characteristic.critical)


def test_a_bottom_as_stiff_as_the_wall_stays_inside_the_box_when_the_wall_is_placed() -> None:
    """μb/μ = 1.1 with a Yeoh wall of c20/c10 0.1 (μ factor 1.27): the placed bottom would
    sit at μb/μ 0.87, below the box's edge, and the cell go to the Ritz model; it is held
    at the wall's effective μ and answered by the calibrated model (`yeoh2_mirror` #34:
    Pc −36 % by the Ritz fallback, +1.7 % so)."""
    model = _shipped()
    wall = Material("yeoh", {"c10": 5e4, "c20": 5e3, "c30": 0.0}, break_stretch=6.0)
    cell = _cell(wall, Material("gent", {"mu": 1.1e5, "jm": 30.0}))
    placed, info = model.placed(cell)
    assert info["bottom_clamped"]["mu_b_over_mu"] == pytest.approx(1.1)
    assert info["bottom_clamped"]["placed_mu_b_over_mu"] < 1.0
    assert placed.bottom_material.shear_modulus == pytest.approx(placed.material.shear_modulus)
    assert model.support(cell)["inside"]
    assert model.responses([cell], 150e3, fast=True)[0].meta["model"] == "calibrated-fast"


def test_the_ph_factor_brings_held_out_ph_closer_to_fe() -> None:
    """Physics: on the held-out Yeoh-walled bending cells whose wall's membrane does not
    snap (`yeoh2_mirror`'s held-out fifth; the factor was fitted on its training designs),
    Ph within 10 % of FE at the median with the factor and farther without it (stop 50:
    15 % → 5 % on the pooled held-out cells, docs/validation.md §4)."""
    import copy

    model = _shipped()
    if not ((model.law_map or {}).get("ph_shift") or {}).get("log_factor"):
        pytest.skip("the shipped law map has no Ph factor")
    plain = copy.copy(model)
    plain.law_map = {k: v for k, v in model.law_map.items() if k != "ph_shift"}
    s, p0 = _held_out_errors(
        (model, plain), ("yeoh2_mirror",), "ph_error",
        keep=lambda cell, fe: (membrane_limit_point(cell.material) is False
                               and fe.characteristic.hardening is not None))
    assert len(s) >= 5
    assert np.median(s) < 0.10 and np.median(s) < np.median(p0)
