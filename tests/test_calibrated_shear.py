"""The tilted cells' strip shear of the calibrated model (issue 22), fitted on the FE data
set's tilted cells (``calibrated._shear``): a factor on the Ritz rule γ = ε sin 2β, and
since stop 39 the volume law (ln(γ / sin 2β) linear in ln(V/V0 − 1) and the log groups),
the model's form where it beats the factor out of sample."""

import copy
import math
from pathlib import Path

import numpy as np
import pytest

from multimorph.calibrated import load_model
from multimorph.calibrated._box import cell_groups
from multimorph.calibrated._shear import (
    VOLUME_GROUPS,
    fit_shear_factor,
    plate_level,
    shear_factor,
    shear_of_volume,
)
from multimorph.geometry import CellGeometry, TiltedCell
from multimorph.io import load_toml

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_the_factor_is_held_at_the_edges_of_its_data_and_is_one_without_a_fit() -> None:
    fit = {"coefficients": [0.0, 1.0, 0.0], "tilt_range": [0.2, 1.0], "jm_range": [10, 80],
           "sigma_log": 0.2}
    c, s, inside = shear_factor(fit, 0.5, 30.0)
    assert c == pytest.approx(math.exp(0.5)) and s == 0.2 and inside
    hi, _, inside_hi = shear_factor(fit, 1.3, 30.0)          # 74°: beyond the data's 59°
    assert hi == pytest.approx(math.exp(1.0)) and not inside_hi
    assert shear_factor(None, 0.5, 30.0) == (1.0, 0.0, False)


def test_the_fit_recovers_a_known_factor_and_reports_its_errors() -> None:
    rng = np.random.default_rng(0)
    samples = []
    for i in range(30):
        tilt, jm = rng.uniform(0.2, 1.0), rng.uniform(10, 80)
        rule = rng.uniform(0.1, 1.0)
        fe = rule * math.exp(-0.5 + 0.4 * tilt - 0.1 * math.log(jm))
        samples.append({"design": i, "holdout": i % 5 == 0, "tilt": tilt, "jm": jm,
                        "pressure": 3e4, "fe": fe, "rule": rule})
    fit = fit_shear_factor(samples)
    assert np.allclose(fit["coefficients"], [-0.5, 0.4, -0.1], atol=1e-9)
    assert fit["leave_one_out_error"]["median"] < 1e-9
    assert fit["holdout_error"]["n"] == 6 and fit["training_designs"] == 24
    with pytest.raises(ValueError, match="at least 9"):
        fit_shear_factor(samples[:8])


def _tilted(deg: float) -> TiltedCell:
    cell = CellGeometry.from_spec(load_toml(EXAMPLES / "cell.toml")["cell"])
    return TiltedCell(cell, math.radians(deg))


def test_the_volume_law_recovers_a_known_law_from_paths() -> None:
    """Synthetic paths whose shear is a known law of their volume and groups: the fit finds
    its coefficients (the exponent from the paths' own shapes too), reports no error, and
    is the form used when asked for (it beats the factor, which cannot describe it); by
    default the factor stays the form."""
    rng = np.random.default_rng(1)
    true = np.array([-1.0, 0.8, -0.2, 0.8] + [0.1 * (k + 1) for k in range(len(VOLUME_GROUPS))])

    def law(groups, v):
        x = [1.0, groups["tilt"], math.log(groups["jm"]), math.log(v - 1.0)]
        x += [math.log(groups[g]) for g in VOLUME_GROUPS]
        return math.sin(2.0 * groups["tilt"]) * math.exp(float(np.dot(true, x)))

    samples = []
    for i in range(60):
        groups = {g: float(rng.uniform(0.1, 2.0)) for g in VOLUME_GROUPS}
        groups.update(tilt=float(rng.uniform(0.2, 1.0)), jm=float(rng.uniform(10, 80)))
        v = float(rng.uniform(3.0, 15.0))
        shape = [{"pressure": f * 3e4, "fe": law(groups, 1.0 + f * (v - 1.0)),
                  "volume": 1.0 + f * (v - 1.0)} for f in (0.3, 0.6)]
        samples.append({"design": i, "holdout": i % 5 == 0, "tilt": groups["tilt"],
                        "jm": groups["jm"], "pressure": 3e4, "fe": law(groups, v),
                        "rule": float(rng.uniform(0.1, 1.0)), "volume": v, "groups": groups,
                        "shape": shape})
    fit = fit_shear_factor(samples, "volume")
    vl = fit["volume_law"]
    assert np.allclose(vl["coefficients"], true, atol=1e-8)
    assert vl["leave_one_out_error"]["median"] < 1e-8 and vl["holdout_error"]["n"] == 12
    assert fit["form"] == "volume" and fit_shear_factor(samples)["form"] == "factor"
    groups = samples[0]["groups"]
    gamma, inside = shear_of_volume(vl, groups, np.array([1.0, 2.0, 5.0]))
    assert inside and gamma[0] == 0.0
    assert gamma[1:] == pytest.approx([law(groups, 2.0), law(groups, 5.0)])


def test_the_shipped_factor_scales_the_shear_and_leaves_pc_ph_alone() -> None:
    model = load_model()
    fit = model.twisting_shear
    assert fit is not None, "the shipped model has no twist shear factor (fit twist-shear)"
    # FE shears less than the rule: the factor is below 1 over the data, and it beats the
    # rule out of sample (leave-one-out, and the far tail on the held-out tilted cells). On
    # the 202 training designs of stop 39 (twisting_narrow joined; the rule is closer on
    # its narrow cells) the factor's gain is mostly in the tail: leave-one-out median 0.29
    # against the rule's 0.35, p90 0.77 against 1.56 (on 119 designs: 0.27 / 0.43 and
    # 0.88 / 1.62)
    assert fit["leave_one_out_error"]["median"] < 0.9 * fit["rule_error"]["median"]
    assert fit["leave_one_out_error"]["p90"] < 0.7 * fit["rule_error"]["p90"]
    assert fit["holdout_error"]["median"] <= fit["holdout_rule_error"]["median"]
    assert fit["holdout_error"]["p90"] < 0.8 * fit["holdout_rule_error"]["p90"]
    # the volume law (stop 40) is the shipped form where it beats the factor in
    # leave-one-out, median and p90 (fit_twist_shear's rule), the factor otherwise; both
    # beat the bare rule out of sample by far. (Stops 40-44 shipped the volume law, which
    # then won on the held-out cells too; the bending pressure and path GPs refitted in
    # stop 45 moved the straight paths the rule reads, and the factor now wins the p90:
    # 0.48 against 0.53, held out 0.47 against 0.55; docs/validation.md §4.)
    vl = fit["volume_law"]
    assert vl["training_designs"] > 0 and {"median", "p90"} <= set(vl["holdout_error"])
    wins = (vl["leave_one_out_error"]["median"] < fit["leave_one_out_error"]["median"]
            and vl["leave_one_out_error"]["p90"] < fit["leave_one_out_error"]["p90"])
    assert fit.get("form") == ("volume" if wins else "factor")
    for err in (vl["holdout_error"], fit["holdout_error"]):
        assert err["median"] < 0.6 * fit["holdout_rule_error"]["median"]
        assert err["p90"] < 0.6 * fit["holdout_rule_error"]["p90"]
    model = copy.copy(model)
    model.twisting_shear = {**fit, "form": "factor"}
    bare = copy.copy(model)
    bare.twisting_shear = None
    cell = _tilted(30.0)
    r = model.tilted_by_straight([cell], 3e5)[0]
    r0 = bare.tilted_by_straight([cell], 3e5)[0]
    c = r.meta["calibration"]["shear_factor"]
    assert 0.2 < c < 1.0
    lo, hi = r.meta["calibration"]["shear_factor_range"]
    assert lo < c < hi
    assert np.allclose(r.path.extra["shear"], c * np.asarray(r0.path.extra["shear"]))
    assert r.characteristic.critical == pytest.approx(r0.characteristic.critical)
    assert r.characteristic.hardening == pytest.approx(r0.characteristic.hardening)
    assert "factor calibrated on" in r.meta["calibration"]["twisting"]


def test_the_volume_law_form_follows_the_chamber_volume() -> None:
    """The model with the volume law as its form (``fit twist-shear --form volume``): the
    shear along a tilted cell's path is the law of the path's volume, rising with it from
    zero."""
    model = copy.copy(load_model())
    rng = np.random.default_rng(2)
    samples = []
    for i in range(60):
        groups = {g: float(rng.uniform(0.1, 2.0)) for g in VOLUME_GROUPS}
        groups.update(tilt=float(rng.uniform(0.2, 1.0)), jm=float(rng.uniform(10, 80)))
        v = float(rng.uniform(3.0, 15.0))
        fe = 0.3 * math.sin(2 * groups["tilt"]) * (v - 1.0) ** 0.8
        samples.append({"design": i, "holdout": i % 5 == 0, "tilt": groups["tilt"],
                        "jm": groups["jm"], "pressure": 3e4, "fe": fe,
                        "rule": fe * float(rng.uniform(0.5, 3.0)), "volume": v,
                        "groups": groups, "shape": []})
    model.twisting_shear = fit_shear_factor(samples, "volume")
    assert model.twisting_shear["form"] == "volume"
    law = model.twisting_shear["volume_law"]
    cell = _tilted(30.0)
    r = model.tilted_by_straight([cell], 3e5)[0]
    cal = r.meta["calibration"]
    assert cal["shear_law"] == "volume" and "law of its chamber volume" in cal["twisting"]
    lo, hi = cal["shear_range"]
    assert lo < 1.0 < hi
    v = np.asarray(r.path.volume, float) / r.path.volume[0]
    gamma = np.asarray(r.path.extra["shear"], float)
    want, _ = shear_of_volume(law, cell_groups(cell), v)
    assert np.allclose(gamma, want)
    order = np.argsort(v)
    assert gamma[order][0] == pytest.approx(0.0, abs=1e-9)
    assert np.all(np.diff(gamma[order]) >= -1e-12)
    with pytest.raises(ValueError, match="factor or volume"):
        fit_shear_factor(samples, "other")


def test_a_tilted_cell_is_read_on_its_straight_cell_at_the_plate_level() -> None:
    """The tilted FE cells, and the device FE check's twisting modules, are one cell with
    its far end tied to a plate: the straight cell standing for a tilted one is the bending
    kind's plate level (stop 34), not the level of a cell inside a bending module."""
    model = load_model()
    if model.kinds["bending"].end_input is None:
        pytest.skip("the shipped bending kind has no end input")
    cell = _tilted(30.0)
    r = model.tilted_by_straight([cell], 3e5)[0]
    plate = plate_level(model).response(cell.cell, 3e5)
    mirror = model.response(cell.cell, 3e5)
    assert np.allclose(r.path.pressure, plate.path.pressure)
    assert "plate level" in r.meta["calibration"]["twisting"]
    # the plate stiffens the cell: the plate level's pressure at a given volume is higher
    v = np.linspace(2.0, 8.0, 7) * plate.path.volume[0]
    p_plate = np.interp(v, plate.path.volume, plate.path.pressure)
    p_mirror = np.interp(v, mirror.path.volume, mirror.path.pressure)
    assert np.median(p_plate / p_mirror) > 1.0


def test_a_tilted_cells_straight_features_skip_what_they_do_not_read() -> None:
    """A tilted cell reads of its straight cell the bending kind's grid values and its Pc
    anchor (``_fit.STRAIGHT_FEATURES``): ``grid(full=False)`` gives them to the bit (both
    variants), without the predictive stds, the support and Ph (NaN; no anchor std). The
    shipped twisting kind reads the features its manifest names."""
    from dataclasses import replace

    from multimorph.calibrated import reference_spec
    from multimorph.calibrated._fit import straight_features

    model = load_model()
    spec = replace(reference_spec("twisting"), samples=8, seed=3)
    cells = [c.cell for c in spec.design_table().cells if c is not None][:4]
    cells.append(_tilted(25.0).cell)
    for fast in (True, False):
        full = model.grid(cells, fast=fast)
        part = model.grid(cells, fast=fast, full=False)
        assert np.array_equal(straight_features(full), straight_features(part))
        assert np.array_equal(full.values, part.values)
        assert np.all(np.isnan(part.std_log_p)) and np.all(np.isnan(part.t_end))
        assert part.anchors is not None and np.all(np.isnan(part.anchors[:, 1]))
        assert np.array_equal(part.anchors[:, 0], full.anchors[:, 0])
        assert np.array_equal(part.inside, full.inside) and part.anchor_std is None
        kind = (model.fast_kinds if fast else model.kinds)["twisting"]
        names = model.manifest["fast_kinds" if fast else "kinds"]["twisting"].get(
            "straight_features")
        assert names is None or kind.straight_names == tuple(names)
        assert len(kind.fmean) == len(kind.straight_names) + 1


def test_the_weighted_shear_is_the_inverse_variance_estimate_of_its_two_sources() -> None:
    """The strip shear of a tilted cell (stop 41) combines the volume law and the
    twisting kind's GP at each chamber volume by the inverse of their variances: equal
    variances give the mean, a source with no information (infinite variance) gives the
    other, and the combined variance is below both (1/σ² = 1/σ₁² + 1/σ₂²)."""
    from dataclasses import replace

    from multimorph.calibrated._model import _weighted_shear
    from multimorph.calibrated._representation import T_GRID
    from multimorph.response import EquilibriumPath

    t = np.linspace(0.0, 2.5, 40)
    v = np.exp(t) * 1e-6
    n = len(t)
    path = EquilibriumPath(pressure=np.linspace(0.0, 3e4, n), curvature=np.zeros(n),
                           twist_rate=np.zeros(n), axial_stretch=np.ones(n), volume=v,
                           peak_stretch=1.0 + t, stable=np.ones(n, bool))
    rule = 0.2 * t
    path = replace(path, extra={"shear": rule})
    y_gp = np.full(len(T_GRID), 0.1)                         # the GP's γ = 0.1 t
    sigma = 0.3
    # the GP's std of γ equal to the rule's: the mean of the two
    sd_equal = np.full(len(T_GRID), 0.2 * sigma)
    out, sd = _weighted_shear(path, sigma, y_gp, sd_equal)
    assert np.allclose(out.extra["shear"], 0.15 * t)
    assert np.allclose(out.twist_rate, out.extra["shear"])
    assert np.all(sd[1:] < 0.2 * sigma * t[1:]) and sd[1:] == pytest.approx(
        0.2 * sigma * t[1:] / math.sqrt(2.0))
    # no rule (infinite variance): the GP; a GP that knows nothing: the rule
    gp_only, sd_gp = _weighted_shear(path, math.inf, y_gp, sd_equal)
    assert np.allclose(gp_only.extra["shear"], 0.1 * t)
    assert np.allclose(sd_gp, 0.2 * sigma * t)
    rule_only, _ = _weighted_shear(path, sigma, y_gp, np.full(len(T_GRID), 1e6))
    assert np.allclose(rule_only.extra["shear"], rule, atol=1e-9)
    # in between, always between the two sources
    mid, _ = _weighted_shear(path, sigma, y_gp, np.full(len(T_GRID), 0.05))
    g = np.asarray(mid.extra["shear"])
    assert np.all((g >= 0.1 * t - 1e-12) & (g <= rule + 1e-12))


def test_a_tilted_cell_is_answered_on_its_own_calibrated_path() -> None:
    """A tilted cell with the twisting kind (since stop 41): its own calibrated path (the
    tilted FE cells' GP of pressure and shear over the chamber volume), its Pc and Ph the
    kind's anchors (a quarter of the way to the path's readings since stop 59), its shear
    the weighted estimate of the law and the GP — so on every chamber volume between the
    two, rising with the inflation over the plateau. A tilted cell outside the twisting
    kind's box is answered by its straight cell."""
    model = load_model()
    if "twisting" not in model.kinds or model.twisting_shear is None:
        pytest.skip("the shipped model has no twisting kind")
    law = model.twisting_shear.get("volume_law")
    for deg in (20.0, 30.0, 45.0):
        cell = _tilted(deg)
        r = model.response(cell, 3e5)
        cal = r.meta["calibration"]
        assert cal["kind"] == "twisting" and cal["inside"]
        assert "own calibrated path" in cal["twisting"]
        lo, hi = cal["shear_range"]
        assert lo < 1.0 < hi
        # Pc: the anchor moved a quarter of the way to the path's own reading (since stop
        # 59, ``_anchor.PATH_WEIGHT``), within the anchor's ±1σ
        a = cal["anchors"]
        anchor, own, pc = (a["critical_pressure"], a["path_critical_pressure"],
                           r.characteristic.critical)
        assert a["path_weight"] == 0.25 and "critical" in a["used"]
        if own is None or a.get("crossed"):
            assert own is not None or pc == pytest.approx(anchor)
        else:
            assert abs(math.log(pc / anchor)) <= 0.25 * abs(math.log(own / anchor)) + 1e-12
            assert min(anchor, own) * (1 - 1e-12) <= pc <= max(anchor, own) * (1 + 1e-12)
        lo, hi = cal["critical_pressure_range"]
        assert lo < r.characteristic.critical < hi
        gamma = np.asarray(r.path.extra["shear"], float)
        assert np.allclose(gamma, r.path.twist_rate)
        pred = model.grid([cell])
        t = np.asarray(r.path.extra["log_volume_ratio"], float)
        from multimorph.calibrated._representation import T_GRID

        gp = np.interp(t, T_GRID, pred.values[0, :, 1]) * t
        if law is not None and model.twisting_shear.get("form") == "volume":
            v = np.asarray(r.path.volume, float)
            rule, _ = shear_of_volume(law, cell_groups(cell), v / v[0])
            lo_g, hi_g = np.minimum(gp, rule), np.maximum(gp, rule)
            assert np.all((gamma >= lo_g - 1e-9) & (gamma <= hi_g + 1e-9))
        # the twist grows with the chamber's inflation from Pc on
        pc = r.characteristic.critical
        P = np.asarray(r.path.pressure)
        past = (P >= pc) & (P <= 1.5 * pc)
        assert gamma[past][-1] > gamma[past][0] > 0.0
    # outside the twisting kind's box (a tilt of 70°, the box ends at 60°): the straight
    # cell's answer
    wide = _tilted(70.0)
    r = model.response(wide, 3e5)
    s = model.tilted_by_straight([wide], 3e5)[0]
    assert np.allclose(r.path.pressure, s.path.pressure)
    assert "straight cell" in r.meta["calibration"]["twisting"]


def test_a_tilted_cell_without_shear_at_its_pc_still_gets_an_answer_and_a_finite_band() -> None:
    """Held-out `twisting` #45 shears almost nothing where its Pc sits: the shear band
    relative to it has no width to speak of. It used to overflow (math range error) and
    leave the cell without an answer; the band is now capped (no information), the
    response otherwise the same."""
    import json

    from multimorph.calibrated._dataset import load_reference
    from multimorph.calibrated._model import SHEAR_BAND_CAP
    from multimorph.calibrated.validate import at_end_of, requested_pressure

    ref = load_reference()["twisting"]
    row = int(np.flatnonzero(ref.design == 45)[0])
    cell, path = ref.cell(row), ref.path(row)
    model, _ = at_end_of(copy.copy(load_model()), "twisting", "twisting")
    model.twisting_shear = {**model.twisting_shear, "form": "factor"}
    for fast in (True, False):
        r = model.responses([cell], requested_pressure("twisting", 45, path), fast=fast)[0]
        assert not isinstance(r, Exception), r
        lo, hi = r.meta["calibration"]["shear_range"]
        assert math.exp(-SHEAR_BAND_CAP) <= lo <= 1.0 <= hi <= math.exp(SHEAR_BAND_CAP)
        json.dumps(r.meta["calibration"])            # a JSON-able record
