"""The calibrated model's building blocks: the GP, the volume-grid representation, the box."""

from __future__ import annotations

import math

import numpy as np
import pytest

from multimorph.calibrated._box import Box, equivalent_jm
from multimorph.calibrated._gp import fit_gp, matern52
from multimorph.calibrated._representation import T_GRID, grid_values, path_from_grid
from multimorph.geometry import CellGeometry
from multimorph.materials import Material


def test_matern52_is_one_at_zero_distance_and_decays() -> None:
    x = np.array([[0.0, 0.0], [1.0, 0.0], [3.0, 0.0]])
    k = matern52(x, x, np.array([1.0, 1.0]))
    np.testing.assert_allclose(np.diag(k), 1.0)
    r = math.sqrt(5.0)
    assert k[0, 1] == pytest.approx((1 + r + 5 / 3) * math.exp(-r))
    assert k[0, 2] < k[0, 1] < 1.0


def test_gp_interpolates_a_smooth_function_and_knows_where_it_has_no_data() -> None:
    rng = np.random.default_rng(0)
    x = rng.uniform(0, 1, (80, 2))

    def f(z: np.ndarray) -> np.ndarray:
        return np.column_stack([np.sin(3 * z[:, 0]) + z[:, 1] ** 2, 2.0 * z[:, 0] - z[:, 1]])

    y = f(x)
    mask = np.ones_like(y, bool)
    mask[:40, 1] = False  # the second output knows only half the designs
    gp = fit_gp(x, y, mask, restarts=1)
    xt = rng.uniform(0.1, 0.9, (50, 2))
    mean, std = gp.predict(xt, std=True)
    err = np.abs(mean - f(xt))
    assert err[:, 0].max() < 0.02 and err[:, 1].max() < 0.02   # the second is linear
    assert np.all(std[:, 0] < 0.05)
    far = gp.predict(np.array([[3.0, 3.0]]), std=True)[1]
    assert far[0, 0] > 5 * std[:, 0].mean()   # outside the data the variance returns
    # the fitted model survives a round trip through its arrays
    from multimorph.calibrated._gp import MultiOutputGP

    again = MultiOutputGP.from_arrays(gp.to_arrays("k/"), "k/")
    np.testing.assert_array_equal(again.predict(xt), mean)
    np.testing.assert_allclose(again.predict(xt, std=True)[1], std, rtol=1e-12)
    # the variance factor is checked once, when loaded (its solves skip SciPy's check):
    # a damaged factor is refused there, by name, not turned into NaN bands later
    arrays = gp.to_arrays("k/")
    arrays["k/chol"] = arrays["k/chol"].copy()
    arrays["k/chol"][3, 1] = np.nan
    with pytest.raises(ValueError, match="k/chol"):
        MultiOutputGP.from_arrays(arrays, "k/")


def _cell() -> CellGeometry:
    m = Material("gent", {"mu": 1e5, "jm": 30.0})
    return CellGeometry(20e-3, 10e-3, 8e-3, 1e-3, 2e-3, 2e-3, 2e-3, material=m,
                        bottom_material=m.scaled(10.0))


def test_grid_round_trip_reproduces_a_path_with_a_limit_point() -> None:
    """A path sampled on its own points -> volume grid -> path again: the same P(V) and κ(V)
    (pressures within 0.5 %), with the falling branch past the limit point unstable."""
    cell = _cell()
    mu = cell.mu
    def p_of(t: np.ndarray) -> np.ndarray:
        return mu * (0.8 * t / (0.4 + t) - 0.15 * t * np.exp(-((t - 1.5) ** 2)) + 0.02 * t**2)

    t = np.linspace(0.0, math.log(60.0), 300)
    P = p_of(t)
    y = 0.9 * t * (1.0 + t) ** 0.2
    peak = 1.0 + 0.8 * t
    axial = 1.0 + 0.01 * t
    vals, cov = grid_values(t, P, y, peak, axial, mu, "bending")
    assert cov.all()
    path = path_from_grid(vals, cell, points=200)
    tt = path.extra["log_volume_ratio"]
    sel = tt > 0.02
    np.testing.assert_allclose(path.pressure[sel], p_of(tt[sel]), rtol=5e-3)
    y_true = 0.9 * tt[sel] * (1.0 + tt[sel]) ** 0.2
    np.testing.assert_allclose(path.curvature[sel] * cell.length, y_true, rtol=5e-3)
    dP = np.gradient(p_of(tt), tt)
    agree = (dP > 0) == path.stable
    assert agree[sel].mean() > 0.97
    assert not path.stable.all()  # the falling branch is there


def test_grid_coverage_stops_where_the_path_stops() -> None:
    cell = _cell()
    t = np.linspace(0, 1.0, 50)
    vals, cov = grid_values(t, 1e5 * t, t, 1 + t, 1 + 0 * t, cell.mu, "bending")
    assert cov[T_GRID <= 1.0].all() and not cov[T_GRID > 1.0].any()
    # the linear regime below the first point: log P continues with slope 1 in log t
    assert vals[0, 0] == pytest.approx(math.log(T_GRID[0]), abs=1e-6)


def test_box_scales_groups_and_names_those_outside() -> None:
    box = Box("bending", ("ht/d", "df/d"), np.array([0.02, 0.05]), np.array([0.2, 0.15]))
    np.testing.assert_allclose(box.scaled(np.array([[0.02, 0.05], [0.2, 0.15]])),
                               [[0, 0], [1, 1]], atol=1e-12)
    assert box.scaled(np.array([[math.sqrt(0.004), 0.1]]))[0, 0] == pytest.approx(0.5)
    assert box.outside({"ht/d": 0.3, "df/d": 0.1}) == {"ht/d": (0.3, 0.02, 0.2)}


def test_box_derived_input_is_the_log_product_of_its_groups_over_the_box() -> None:
    """``bottom/top`` = μb·hb / (μ·ht): 0 at the box's softest corner (μb/μ and hb/d
    lowest, ht/d highest), 1 at the stiffest, linear in its logarithm between, and the
    same for every cell with the same product; a box without it gives its groups alone."""
    from dataclasses import replace

    from multimorph.calibrated._box import DERIVED_INPUTS, GROUP_NAMES

    names = GROUP_NAMES["bending"]
    low = np.array([0.025, 0.04, 0.05, 0.4, 0.35, 0.04, 1.0, 9.0])
    high = np.array([0.16, 0.26, 0.15, 2.5, 1.3, 0.45, 30.0, 80.0])
    plain = Box("bending", names, low, high)
    assert DERIVED_INPUTS["bending"][0] == "bottom/top"
    box = replace(plain, derived=("bottom/top",))
    at = {n: j for j, n in enumerate(names)}

    def cell(ht: float, hb: float, mub: float) -> np.ndarray:
        v = (low + high) / 2
        v[at["ht/d"]], v[at["hb/d"]], v[at["mu_b/mu"]] = ht, hb, mub
        return v

    soft, stiff = cell(0.16, 0.04, 1.0), cell(0.025, 0.45, 30.0)
    x = box.inputs(np.array([soft, stiff]))
    assert x.shape == (2, len(names) + 1)
    np.testing.assert_allclose(x[:, :-1], plain.scaled(np.array([soft, stiff])))
    np.testing.assert_allclose(x[:, -1], [0.0, 1.0], atol=1e-12)
    # the geometric middle of the product's range maps to 0.5, whichever groups make it
    mid = math.sqrt((0.04 * 1.0 / 0.16) * (0.45 * 30.0 / 0.025))
    a = box.inputs(cell(0.05, mid * 0.05 / 10.0, 10.0)[None, :])[0, -1]
    b = box.inputs(cell(0.1, mid * 0.1 / 4.0, 4.0)[None, :])[0, -1]
    assert a == pytest.approx(0.5) and b == pytest.approx(0.5)
    np.testing.assert_array_equal(plain.inputs(soft[None, :]), plain.scaled(soft[None, :]))


def test_box_top_share_and_side_top_are_the_walls_membrane_stiffness_ratios() -> None:
    """``top share`` = μ·ht / (μ·ht + μb·hb): ½ where the two membranes are equally stiff,
    falling as the bottom stiffens, and the same for every cell with the same product.
    ``side/top`` = (ws / hc) / (ht / wc) with hc, wc the chamber's own height and width
    (the geometry's ``chamber_height``, ``chamber_width``): its log mapped linearly from
    ``SIDE_TOP_LOG_RANGE``, so a side wall twice as stiff per span moves it by ln 2 over
    that range's width."""
    from dataclasses import replace

    from multimorph.calibrated._box import GROUP_NAMES, SIDE_TOP_LOG_RANGE, cell_groups

    names = GROUP_NAMES["bending"]
    low = np.array([0.025, 0.04, 0.05, 0.4, 0.35, 0.04, 1.0, 9.0])
    high = np.array([0.16, 0.26, 0.15, 2.5, 1.3, 0.45, 30.0, 80.0])
    box = Box("bending", names, low, high, ("top share", "side/top"))
    gent = Material("gent", {"mu": 1e5, "jm": 20.0})

    def inputs(cell: CellGeometry) -> np.ndarray:
        g = cell_groups(cell)
        return box.inputs(np.array([[g[n] for n in names]]))[0, -2:]

    d = 20e-3
    base = CellGeometry(d, 12e-3, 10e-3, 1e-3, 1e-3, 1.5e-3, 2e-3, material=gent)
    share, side = inputs(base)
    assert share == pytest.approx(0.5)                   # same law, same thickness
    stiff = replace(base, bottom_material=Material("gent", {"mu": 3e5, "jm": 20.0}))
    assert inputs(stiff)[0] == pytest.approx(0.25)       # μb·hb = 3 μ·ht
    thick = replace(base, bottom_wall=3e-3)               # the same product by thickness
    assert inputs(thick)[0] == pytest.approx(0.25)
    ratio = (base.side_wall / base.chamber_height) / (base.top_wall / base.chamber_width)
    lo, hi = SIDE_TOP_LOG_RANGE
    assert side == pytest.approx((math.log(ratio) - lo) / (hi - lo))
    wider_side = replace(base, side_wall=3e-3)            # ws × 2, wc 9 → 6 mm
    r2 = (3e-3 / base.chamber_height) / (base.top_wall / wider_side.chamber_width)
    assert inputs(wider_side)[1] - side == pytest.approx(math.log(r2 / ratio) / (hi - lo))
    assert r2 / ratio == pytest.approx(2.0 * 6.0 / 9.0)


def test_equivalent_jm_is_gent_own_and_places_other_laws_by_their_hardening() -> None:
    assert equivalent_jm(Material("gent", {"mu": 1e5, "jm": 33.0})) == 33.0
    # Gent's series W = μ/2 (x + x²/(2 Jm) + x³/(3 Jm²) + …), x = I1 − 3, cut after three
    # terms (a Yeoh law): it hardens a little less, so its equivalent Jm is a little larger
    jm = 25.0
    yeoh = Material("yeoh", {"c10": 5e4, "c20": 5e4 / (2 * jm), "c30": 5e4 / (3 * jm**2)})
    assert jm < equivalent_jm(yeoh) < 1.5 * jm
    # neo-Hooke has no lock-up: its equivalent Jm is huge
    assert equivalent_jm(Material("neo-hooke", {"mu": 1e5})) > 500


def _ballooning_path(pc: float, ph: float):
    """A synthetic bending path: κ(P) rises fastest at P = pc and flattens by P ≈ ph."""
    from multimorph.response import EquilibriumPath

    P = np.linspace(0.0, 2.5 * pc, 400)
    width = (ph - pc) / 1.6
    k = np.tanh((P - pc) / width) + math.tanh(pc / width) + 0.02 * P / pc
    n = len(P)
    return EquilibriumPath(pressure=P, curvature=k, twist_rate=np.zeros(n),
                           axial_stretch=np.ones(n), volume=1.0 + k, peak_stretch=1.0 + k,
                           stable=np.ones(n, bool))


def _ballooning_response(pc: float, ph: float):
    from multimorph.response import build_response

    return build_response(_ballooning_path(pc, ph), length=0.02, shear_modulus=1.0,
                          backend="calibrated")


@pytest.mark.parametrize(("pc_a", "ph_a"), [(0.8, 0.9), (1.3, 1.6), (1.2, 1.1)])
def test_anchors_become_pc_and_ph_and_leave_the_path_as_predicted(pc_a, ph_a) -> None:
    """Where the loading curve reaches them, the anchors are the response's Pc and Ph
    (Ph never below Pc), κ at each is read on the loading curve, and the path's own
    readings are kept in the record."""
    from multimorph.calibrated._anchor import anchored_characteristic

    resp = _ballooning_response(1.0, 1.25)
    own = resp.characteristic
    assert own.critical == pytest.approx(1.0, rel=0.01)
    ch, info = anchored_characteristic(resp, pc_a, ph_a)
    if ph_a < pc_a:
        # crossing anchors: projected onto Pc <= Ph, both at their (equal-weight) log mean
        assert ch.critical == pytest.approx(math.sqrt(pc_a * ph_a))
        assert ch.hardening == pytest.approx(ch.critical) and info["crossed"]
    else:
        assert ch.critical == pc_a and ch.hardening == ph_a
    assert info["used"] == ["critical", "hardening"]
    assert info["path_critical_pressure"] == own.critical
    k_at = np.interp(ch.critical, resp.loading.pressure, resp.loading.curvature)
    assert ch.curvature_at["critical"] == pytest.approx(k_at)
    assert ch.critical_kind == own.critical_kind


def test_crossing_anchors_meet_at_their_precision_weighted_mean() -> None:
    """The better-known anchor (smaller predictive std of log P) moves less: the pair is
    the most likely one with Pc <= Ph under the GPs' Gaussian errors."""
    from multimorph.calibrated._anchor import anchored_characteristic

    resp = _ballooning_response(1.0, 1.25)
    ch, _ = anchored_characteristic(resp, 1.2, 1.1, (0.05, 0.15))
    want = math.exp((math.log(1.2) / 0.05**2 + math.log(1.1) / 0.15**2)
                    / (1 / 0.05**2 + 1 / 0.15**2))
    assert ch.critical == pytest.approx(want) == pytest.approx(ch.hardening)
    assert 1.1 < want < 1.2 and want - 1.1 > 1.2 - want


def test_a_path_weight_takes_the_log_mean_of_the_anchor_and_the_paths_reading() -> None:
    """With a path weight (stretching cells: 0.5 on both; bending cells 0.75 on both since stop
    45, 0.5 on Pc and 0.25 on Ph before; tilted cells 0.25 on both since stop 59) Pc and
    Ph are the weighted means in log P of the anchor and the path's own reading where
    both exist; the anchor alone where the path reads none; the record says the weights.
    Weight 0 is the anchor (the default)."""
    from multimorph.calibrated._anchor import PATH_WEIGHT, anchored_characteristic

    assert PATH_WEIGHT == {"stretching": (0.5, 0.5), "bending": (0.75, 0.75),
                           "twisting": (0.25, 0.25)}
    resp = _ballooning_response(1.0, 1.25)
    own = resp.characteristic
    ch, info = anchored_characteristic(resp, 1.1, 1.4, path_weight=0.5)
    assert ch.critical == pytest.approx(math.sqrt(1.1 * own.critical))
    assert ch.hardening == pytest.approx(math.sqrt(1.4 * own.hardening))
    assert info["path_weight"] == 0.5 and info["critical_pressure"] == 1.1
    assert info["path_weight_hardening"] == 0.5
    # separate weights of Pc and Ph
    ch, info = anchored_characteristic(resp, 1.1, 1.4, path_weight=(0.5, 0.25))
    assert ch.critical == pytest.approx(math.sqrt(1.1 * own.critical))
    assert ch.hardening == pytest.approx(1.4 ** 0.75 * own.hardening ** 0.25)
    assert (info["path_weight"], info["path_weight_hardening"]) == (0.5, 0.25)
    # the path's reading moves the anchor by at most the anchor's own σ of log P
    sd = 0.5 * abs(math.log(own.critical / 1.1)) / 3.0  # a third of the plain shift
    ch, _ = anchored_characteristic(resp, 1.1, 1.4, (sd, 1.0), path_weight=0.5)
    assert ch.critical == pytest.approx(1.1 * math.exp(math.copysign(sd, own.critical - 1.1)))
    assert ch.hardening == pytest.approx(math.sqrt(1.4 * own.hardening))  # σ 1: not binding
    w = 0.25
    ch, _ = anchored_characteristic(resp, 1.1, 1.4, path_weight=w)
    assert ch.critical == pytest.approx(1.1 ** (1 - w) * own.critical ** w)
    ch0, info0 = anchored_characteristic(resp, 1.1, 1.4)
    assert ch0.critical == 1.1 and ch0.hardening == 1.4 and "path_weight" not in info0
    # no reading of the path's own (a curve cut before its knee): the anchor alone
    from dataclasses import replace

    cut = replace(resp, characteristic=replace(own, hardening=None))
    ch, _ = anchored_characteristic(cut, 1.1, 1.4, path_weight=0.5)
    assert ch.hardening == 1.4


def test_an_anchor_beyond_the_path_or_far_from_its_reading_is_not_used() -> None:
    from multimorph.calibrated._anchor import MAX_FACTOR, anchored_characteristic

    resp = _ballooning_response(1.0, 1.25)
    top = float(resp.loading.pressure[-1])
    for pc_a in (1.05 * top, 1.1 * MAX_FACTOR, None, math.nan):
        ch, info = anchored_characteristic(resp, pc_a, None)
        assert ch is resp.characteristic and not info["used"]
    # a path whose own reading finds no Pc but that reaches the anchor takes the anchor
    short = _ballooning_response(1.0, 1.25)
    from dataclasses import replace

    short = replace(short, characteristic=replace(short.characteristic, critical=None,
                                                  critical_kind=None, hardening=None))
    ch, info = anchored_characteristic(short, 0.9, 1.0)
    assert ch.critical == 0.9 and ch.hardening == 1.0 and ch.critical_kind == "max_slope"


def test_a_tilted_cells_anchor_is_left_out_only_three_times_off_its_paths_reading() -> None:
    """The disagreement rule's factor is the kind's (``_anchor.max_factor``): 2 for bending
    and stretching cells, 3 for tilted cells, whose path's reading weighs a quarter; the
    record keeps it, and ``readings_disagree`` reads it."""
    from multimorph.calibrated._anchor import (
        MAX_FACTOR,
        anchored_characteristic,
        max_factor,
        readings_disagree,
    )

    assert max_factor("bending") == max_factor("stretching") == max_factor(None) == MAX_FACTOR
    assert max_factor("twisting") == 3.0
    resp = _ballooning_response(1.0, 1.25)
    own = resp.characteristic.critical
    top = float(resp.loading.pressure[-1])
    anchor = 2.3 * own
    assert anchor < top
    _, info2 = anchored_characteristic(resp, anchor, None)
    assert not info2["used"] and info2["max_factor"] == MAX_FACTOR and readings_disagree(info2)
    ch3, info3 = anchored_characteristic(resp, anchor, None, factor=max_factor("twisting"))
    assert info3["used"] == ["critical"] and ch3.critical == anchor
    assert not readings_disagree(info3)
    # a tilted cell's anchor three times off its path's reading is still left out
    assert readings_disagree({"used": [], "max_factor": 3.0, "critical_pressure": 3.2 * own,
                              "path_critical_pressure": own})


def test_the_tilted_cells_straight_features_read_the_bending_prediction() -> None:
    """The twisting kind's inputs from its straight cell (``_fit.STRAIGHT_FEATURES``): log P
    of the bending kind's grid prediction at t = 0.25 and 0.75, its Pc anchor and (since
    stop 62) its signal and bottom strain over t at t = 0.75; none for a straight cell
    outside the bending support. A model fitted before stop 62 reads the first three
    (``STRAIGHT_FEATURES_V1``), and its manifest naming none means those."""
    from types import SimpleNamespace

    from multimorph.calibrated._fit import (
        STRAIGHT_FEATURES,
        STRAIGHT_FEATURES_V1,
        STRAIGHT_T,
        kind_features,
        straight_features,
    )

    values = np.zeros((2, len(T_GRID), 4))
    values[:, :, 0] = np.array([1.0, 2.0])[:, None] * T_GRID[None, :]   # log P = a t
    values[:, :, 1] = 0.5 + T_GRID[None, :]                              # κd/t
    values[:, :, 3] = -0.1 * T_GRID[None, :] ** 2                        # e/t
    pred = SimpleNamespace(values=values, anchors=np.array([[-3.0, -2.5], [-2.0, -1.5]]),
                           inside=np.array([True, False]))
    f = straight_features(pred)
    assert f.shape == (2, len(STRAIGHT_FEATURES)) == (2, 5)
    t = 0.75
    np.testing.assert_allclose(f[0], [STRAIGHT_T[0], STRAIGHT_T[1], -3.0,
                                      np.interp(t, T_GRID, values[0, :, 1]),
                                      np.interp(t, T_GRID, values[0, :, 3])])
    assert np.all(np.isnan(f[1]))
    np.testing.assert_array_equal(straight_features(pred, STRAIGHT_FEATURES_V1), f[:, :3])
    with pytest.raises(ValueError, match="not a straight-cell feature"):
        straight_features(pred, ("kappa_straight_t075",))
    ritz = np.array([[0.1, 0.2, 0.3, 0.4], [0.1, 0.2, 0.3, 0.4]])
    tilt = np.array([math.pi / 4, math.pi / 12])
    kf = kind_features("twisting", ritz, tilt, f)
    assert kf.shape == (2, 6)
    np.testing.assert_allclose(kf[:, 5], 0.4 * np.sin(2 * tilt))   # the Ritz shear rule
    assert kind_features("twisting", ritz, tilt).shape == (2, 3)    # Ritz pressures alone


def test_censored_outputs_take_the_truncated_normal_of_their_continuation() -> None:
    """Closed form: with uncorrelated designs (K = I) a censored output's continuation is
    β δ_e (the regression of output j on output e over the designs with both, δ the
    leave-one-out error = the residual itself), and it enters as the normal N(β r_e, s²)
    conditioned on lying above its bound (scipy's truncnorm)."""
    from scipy.stats import truncnorm

    from multimorph.calibrated._gp import MIN_PAIRS, censored_residuals

    rng = np.random.default_rng(4)
    n = MIN_PAIRS + 20
    r = rng.standard_normal((n, 2))
    r[:, 1] = 0.8 * r[:, 0] + 0.3 * rng.standard_normal(n)
    mask = np.ones((n, 2), bool)
    mask[:3, 1] = False                       # three designs stopped after output 0
    bound = np.full((n, 2), np.nan)
    bound[:3, 1] = [-5.0, 0.5, 3.0]           # far below, near, far above the continuation
    out, var, imputed = censored_residuals(np.eye(n), 0.0, np.where(mask, r, 0.0), mask,
                                           bound)
    assert imputed[:3, 1].all() and imputed.sum() == 3
    np.testing.assert_array_equal(out[mask], r[mask])          # observed values kept
    a, b = r[3:, 0], r[3:, 1]
    beta = a @ b / (a @ a)
    s = math.sqrt(np.mean((b - beta * a) ** 2))
    for i in range(3):
        mu = beta * r[i, 0]
        tn = truncnorm((bound[i, 1] - mu) / s, np.inf, loc=mu, scale=s)
        if i < 2:
            assert out[i, 1] == pytest.approx(tn.mean(), rel=1e-9)
            assert var[i, 1] == pytest.approx(tn.var(), rel=1e-6)
        else:                                 # the bound 3σ+ above: the value sits on it
            assert out[i, 1] == pytest.approx(tn.mean(), abs=0.1 * s)
        assert out[i, 1] >= bound[i, 1]
    assert out[0, 1] == pytest.approx(beta * r[0, 0], abs=1e-6)  # an inactive bound


def test_a_fit_with_censored_designs_learns_they_lie_above_their_bound() -> None:
    """Designs that stop once their output passes a cap (an FE run at its pressure limit)
    are censored past their end. Where only censored designs live (x0 > 0.6, whose outputs
    jump above the cap at large t) the masked fit predicts below the cap everywhere, the
    censored fit learns that they are above it (half its predictions there above the cap,
    the mean error down by more than 15 %); on a smooth response it changes nothing."""
    rng = np.random.default_rng(3)
    n = 120
    x = rng.uniform(0, 1, (n, 2))
    t = np.linspace(0.5, 3.0, 12)

    def jump(z: np.ndarray) -> np.ndarray:
        return (0.5 * z[:, 1:2] + 0.4 * t[None, :]
                + 2.0 * (z[:, 0:1] > 0.6) * np.maximum(t[None, :] - 1.5, 0.0))

    def smooth(z: np.ndarray) -> np.ndarray:
        return (0.5 * z[:, 1:2] + (0.6 + 0.2 * z[:, 0:1]) * t[None, :]
                + 0.25 * z[:, 0:1] ** 2 * t[None, :] ** 2)

    xt = np.column_stack([np.linspace(0.7, 0.95, 20), rng.uniform(0, 1, 20)])
    for f, cap in ((jump, 1.8), (smooth, float(np.quantile(smooth(x)[:, -1], 0.45)))):
        y = f(x)
        mask = np.ones_like(y, bool)
        for i in range(n):
            over = np.flatnonzero(y[i] > cap)
            if over.size:
                mask[i, over[0] + 1:] = False
        lower = np.where(~mask, cap, np.nan)
        masked = fit_gp(x, np.where(mask, y, 0.0), mask, restarts=1)
        cens = fit_gp(x, np.where(mask, y, 0.0), mask, restarts=1, lower=lower)
        # the censored outputs join their outputs' solves, the observed ones stay
        assert cens.mask.sum() > mask.sum() and not (mask & ~cens.mask).any()
        e_masked = np.abs(masked.predict(xt) - f(xt))[:, -4:]
        e_cens = np.abs(cens.predict(xt) - f(xt))[:, -4:]
        if f is jump:
            assert e_cens.mean() < 0.85 * e_masked.mean()
            assert (cens.predict(xt)[:, -4:] < cap).sum() <= 0.6 * e_masked.size
            assert (masked.predict(xt)[:, -4:] < cap).all()
        else:
            assert e_cens.max() <= 1.05 * e_masked.max() + 1e-3


def test_the_robust_likelihood_puts_an_outlier_at_its_limit() -> None:
    """robust_noise: the leave-one-out residual of a design does not depend on its own
    noise, and its leave-one-out variance grows by it; so the noise it gives an outlier
    puts that design's z exactly at the limit (the others' noises held), and a design
    inside the limit keeps its noise."""
    from multimorph.calibrated._gp import matern52, robust_noise

    rng = np.random.default_rng(5)
    x = rng.uniform(0, 1, (60, 2))
    r = 0.5 * np.sin(3 * x[:, 0]) + 0.03 * rng.standard_normal(60)
    r[7] += 1.0
    K = matern52(x, x, np.array([0.5, 0.5]))
    noise = 9e-4

    def loo_z(own: np.ndarray) -> np.ndarray:
        inv = np.linalg.inv(K + np.diag(noise + own))
        return (inv @ r) / np.sqrt(np.diag(inv))

    own = robust_noise(K, noise, r, np.zeros(60), 3.0)
    z0 = loo_z(np.zeros(60))
    only7 = np.where(np.arange(60) == 7, own, 0.0)
    assert abs(z0[7]) > 10.0 and abs(abs(loo_z(only7)[7]) - 3.0) < 1e-6
    assert np.all(own[np.abs(z0) <= 3.0] == 0.0) and np.all(own[np.abs(z0) > 3.0] > 0.0)


def test_a_robust_fit_is_not_pulled_by_labels_that_jump() -> None:
    """A smooth response with a few labels read off another feature (Pc read at a second
    excursion: far off its neighbours). The Gaussian fit bends towards them; the robust one
    (``fit_gp(..., robust=3)``) weighs them down: its error on the true response near them
    falls by a third or more, the designs it weighs down carry their own noise in its
    variance, and on clean data it gives the plain fit."""
    rng = np.random.default_rng(11)
    n = 150
    x = rng.uniform(0, 1, (n, 2))

    def f(z: np.ndarray) -> np.ndarray:
        return (np.sin(2.5 * z[:, 0]) + 0.5 * z[:, 1] ** 2)[:, None]

    y = f(x) + 0.01 * rng.standard_normal((n, 1))
    bad = rng.choice(n, 6, replace=False)
    jumped = y.copy()
    jumped[bad] += 0.6
    near = np.vstack([x[b] + 0.03 * rng.standard_normal((10, 2)) for b in bad])
    ones = np.ones((n, 1), bool)
    plain = fit_gp(x, jumped, ones, restarts=1)
    robust = fit_gp(x, jumped, ones, restarts=1, robust=3.0)
    e_plain = np.abs(plain.predict(near) - f(near)).mean()
    e_robust = np.abs(robust.predict(near) - f(near)).mean()
    assert e_robust < 0.67 * e_plain
    # the weighed-down designs carry their own noise in the variance factor
    own = np.diag(robust.chol @ robust.chol.T) - 1.0 - robust.noise
    assert set(np.flatnonzero(own > 1e-9)) >= set(bad)
    clean_plain = fit_gp(x, y, ones, restarts=1)
    clean_robust = fit_gp(x, y, ones, restarts=1, robust=3.0)
    xt = rng.uniform(0, 1, (40, 2))
    assert np.allclose(clean_robust.predict(xt), clean_plain.predict(xt), atol=0.02)
    with pytest.raises(ValueError, match="robust needs one output"):
        fit_gp(x, np.column_stack([y, y]), np.ones((n, 2), bool), robust=3.0)


def test_a_design_stopped_at_its_pressure_limit_is_censored_past_its_end() -> None:
    """The FE path's stop reason at p_max is the one the training data read as censoring,
    and the bound covers exactly the grid volumes past such a design's end."""
    from multimorph.calibrated._fit import STOPPED_AT_P_MAX, TrainingData
    from multimorph.fe.engine._path import path_end

    assert path_end([0.0, 1.0, 2.0, 3.1], "arc-length", 3.0, False) == STOPPED_AT_P_MAX
    mask = np.array([[True, True, False, False], [True, False, False, False],
                     [True, True, True, True]])
    data = TrainingData(kind="bending", set_name=np.array(["a"] * 3), design=np.arange(3),
                        groups=np.zeros((3, 1)), features=np.zeros((3, 4)),
                        y=np.zeros((3, 4, 4)), mask=mask, holdout=np.zeros(3, bool),
                        cells=[None] * 3, paths=[{}] * 3,
                        censor=np.array([math.log(2.0), math.nan, math.log(3.0)]))
    low = data.lower(np.arange(3))
    np.testing.assert_array_equal(np.isfinite(low), [[False, False, True, True],
                                                     [False] * 4, [False] * 4])
    assert low[0, 2] == pytest.approx(math.log(2.0))
    np.testing.assert_array_equal(np.isfinite(data.lower(np.array([0]))), [[0, 0, 1, 1]])


def test_a_cross_validated_kernel_lowers_the_leave_one_out_loss_and_is_a_gp() -> None:
    """fit_gp_cv: its kernel's mean leave-one-out loss (closed form) is at most the
    likelihood kernel's and the start's; the stored GP is that kernel's posterior (mean at
    new inputs = the closed-form one, amplitude rᵀK⁻¹r / n) and predicts the function."""
    from scipy.linalg import cho_factor, cho_solve

    from multimorph.calibrated._gp import CV_LOSS_SOFTNESS, _linear, fit_gp_cv

    rng = np.random.default_rng(3)
    n = 90
    x = rng.uniform(0, 1, (n, 3))

    def f(z: np.ndarray) -> np.ndarray:
        return np.sin(3.0 * z[:, 0]) + 0.5 * z[:, 1] ** 2   # z[:, 2] does nothing

    y = f(x) + 0.02 * rng.standard_normal(n)
    cv = fit_gp_cv(x, y)
    ml = fit_gp(x, y[:, None], np.ones((n, 1), bool), restarts=1)
    coef = _linear(x, y, 1e-3)
    r = y - np.column_stack([np.ones(n), x]) @ coef
    r = r / r.std()

    def loss(length: np.ndarray, noise: float) -> float:
        c = cho_factor(matern52(x, x, length) + noise * np.eye(n), lower=True)
        e = cho_solve(c, r) / np.diag(cho_solve(c, np.eye(n)))
        return float(np.mean(np.sqrt(e * e + CV_LOSS_SOFTNESS ** 2)))

    own = loss(cv.length, cv.noise)
    assert own <= loss(np.ones(3), 1e-2) + 1e-9
    assert own <= loss(ml.length, ml.noise) + 1e-6
    assert cv.length[2] > 3.0 * cv.length[0]   # the idle input against the sine's
    xt = rng.uniform(0.1, 0.9, (40, 3))
    assert np.abs(cv.predict(xt)[:, 0] - f(xt)).max() < 0.05
    sd = float(np.std(y - np.column_stack([np.ones(n), x]) @ coef))
    a = np.linalg.solve(matern52(x, x, cv.length) + cv.noise * np.eye(n), r)
    mean = (np.column_stack([np.ones(len(xt)), xt]) @ coef
            + matern52(xt, x, cv.length) @ a * sd)
    np.testing.assert_allclose(cv.predict(xt)[:, 0], mean, atol=1e-8)
    assert cv.scale[0] == pytest.approx(sd * math.sqrt(float(r @ a) / n), rel=1e-9)
    far = cv.predict(np.full((1, 3), 1e3), std=True)[1][0, 0]   # no data near: the prior
    assert far == pytest.approx(cv.scale[0] * math.sqrt(1.0 + cv.noise), rel=1e-6)


def test_matern52_is_the_closed_form_and_the_support_maximum_the_masked_one():
    """The in-place Matérn-5/2 kernel is (1 + √5 r + 5r²/3) exp(−√5 r) of the scaled
    distance, and the support's running maximum gives, at every grid volume, the largest
    correlation with a training design that reaches it (a prefix per design, or any mask
    through the fallback)."""
    from multimorph.calibrated._model import _best_reaching

    rng = np.random.default_rng(7)
    a, b, length = rng.normal(size=(30, 5)), rng.normal(size=(40, 5)), rng.uniform(0.3, 3, 5)
    r = np.sqrt((((a[:, None, :] - b[None, :, :]) / length) ** 2).sum(axis=2))
    closed = (1 + np.sqrt(5) * r + 5 / 3 * r**2) * np.exp(-np.sqrt(5) * r)
    assert np.allclose(matern52(a, b, length), closed, rtol=1e-12, atol=1e-14)
    ks = matern52(a, b, length)
    for reach in (np.arange(12)[None, :] < rng.integers(0, 13, 40)[:, None],
                  rng.uniform(size=(40, 12)) < 0.5):
        masked = np.stack([np.where(reach[:, j][None, :], ks, 0.0).max(axis=1)
                           for j in range(12)], axis=1)
        assert np.array_equal(_best_reaching(ks, reach), masked)


def test_an_interrupted_fit_resumes_from_the_gps_it_had(tmp_path):
    """Each GP of a kind is kept as soon as it is fitted (``_fit.resumable``): a second
    call with the same key loads it instead of fitting (the same predictions, the same
    arrays), and a file that cannot be read is fitted again."""
    from multimorph.calibrated._fit import resumable

    rng = np.random.default_rng(11)
    x = rng.uniform(size=(40, 3))
    y = np.sin(3 * x[:, :1]) + x[:, 1:2]
    calls = []

    def fit():
        calls.append(1)
        return {"gp": fit_gp(x, y, np.ones_like(y, bool), restarts=0),
                "fmean": np.array([1.0, 2.0])}

    first = resumable(tmp_path, "k", "path", fit)
    again = resumable(tmp_path, "k", "path", fit)
    assert len(calls) == 1
    q = rng.uniform(size=(5, 3))
    assert np.array_equal(first["gp"].predict(q), again["gp"].predict(q))
    assert np.array_equal(again["fmean"], [1.0, 2.0])
    (tmp_path / "k-path.npz").write_bytes(b"not an npz")
    resumable(tmp_path, "k", "path", fit)
    assert len(calls) == 2
    resumable(tmp_path, "other", "path", fit)           # another key: fitted
    assert len(calls) == 3


def test_the_resume_key_follows_the_training_data():
    """``_fit.fit_fingerprint``: one FE label moved, or the other variant, is another key;
    the same data the same key."""
    from multimorph.calibrated._fit import TrainingData, fit_fingerprint

    n, J = 12, len(T_GRID)

    def data(anchors):
        return TrainingData(
            kind="bending", set_name=np.array(["s"] * n), design=np.arange(n),
            groups=np.full((n, 3), 0.5), features=np.ones((n, 4)),
            y=np.zeros((n, J, 3)), mask=np.ones((n, J), bool), holdout=np.zeros(n, bool),
            cells=[], paths=[], anchors=anchors)

    box = Box("bending", ("a", "b", "c"), np.zeros(3), np.ones(3))
    a = np.full((n, 2), -1.0)
    b = a.copy()
    b[3, 0] = -1.01
    assert fit_fingerprint(data(a), box, "") == fit_fingerprint(data(a.copy()), box, "")
    assert fit_fingerprint(data(a), box, "") != fit_fingerprint(data(b), box, "")
    assert fit_fingerprint(data(a), box, "") != fit_fingerprint(data(a), box, "fast/")
    scaling = (np.zeros(4), np.ones(4))
    assert fit_fingerprint(data(a), box, "", scaling) != fit_fingerprint(data(a), box, "")
