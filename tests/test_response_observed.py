"""Backend-independent derivations on synthetic paths: observed curves and Pc/Ph/failure."""

from __future__ import annotations

import numpy as np
import pytest

from multimorph.response import (
    EquilibriumPath,
    build_response,
    characteristic_pressures,
    observed_curves,
)


def _path(P, k, stable=None, peak=None, volume=None):
    P = np.asarray(P, float)
    n = P.shape[0]
    # a chamber grows as its cell moves, whichever way it bends
    vol = 1.0 + np.abs(np.asarray(k, float)) if volume is None else np.asarray(volume, float)
    return EquilibriumPath(
        pressure=P, curvature=np.asarray(k, float), twist_rate=np.zeros(n),
        axial_stretch=np.ones(n), volume=vol,
        peak_stretch=np.ones(n) if peak is None else np.asarray(peak, float),
        stable=np.ones(n, bool) if stable is None else np.asarray(stable, bool))


def _n_shaped():
    """P(κ) = κ³ − 3κ² + 2.4κ: rises to a max at κ1, falls to a min at κ2, rises again."""
    k = np.linspace(0.0, 3.0, 301)
    P = k**3 - 3 * k**2 + 2.4 * k
    dP = 3 * k**2 - 6 * k + 2.4
    return _path(P, k, stable=dP > 0), k, P


def test_loading_snaps_at_the_limit_point_to_the_stiff_branch():
    path, _k, P = _n_shaped()
    loading, _unloading = observed_curves(path)
    k1 = 1 - np.sqrt(1 - 2.4 / 3)          # dP/dκ = 0
    p_max = k1**3 - 3 * k1**2 + 2.4 * k1
    snap = np.flatnonzero(loading.extra["snap"] > 0)
    assert snap.size == 1
    j = int(snap[0])
    # jump at constant pressure (the last stable point before it) onto the rising branch
    assert loading.pressure[j] == pytest.approx(loading.pressure[j - 1], abs=1e-12)
    assert loading.pressure[j] == pytest.approx(p_max, abs=1e-3)
    assert loading.curvature[j] > 1 + np.sqrt(1 - 2.4 / 3)
    assert np.all(np.diff(loading.pressure) >= -1e-12)
    assert loading.pressure[-1] == P[-1] and loading.stable.all()


def test_unloading_snaps_back_at_the_lower_turning_point_hysteresis():
    path, _k, _P = _n_shaped()
    loading, unloading = observed_curves(path)
    k2 = 1 + np.sqrt(1 - 2.4 / 3)
    p_min = k2**3 - 3 * k2**2 + 2.4 * k2
    assert np.all(np.diff(unloading.pressure) <= 1e-12)
    snap = np.flatnonzero(unloading.extra["snap"] > 0)
    assert snap.size == 1
    j = int(snap[0])
    assert unloading.pressure[j] == pytest.approx(p_min, abs=1e-3)
    assert unloading.curvature[j] < 1 - np.sqrt(1 - 2.4 / 3)
    # hysteresis: at a pressure inside the loop, loading is on the soft branch, unloading not
    p_mid = 0.5 * (p_min + loading.pressure[int(np.flatnonzero(loading.extra["snap"])[0])])
    k_load = np.interp(p_mid, loading.pressure, loading.curvature)
    k_unload = np.interp(p_mid, unloading.pressure[::-1], unloading.curvature[::-1])
    assert k_unload > k_load + 0.5


def test_runaway_without_stable_branch_ends_loading():
    k = np.linspace(0, 3, 100)
    P = k * np.exp(-k)                      # max at κ = 1, falls forever
    path = _path(P, k, stable=k <= 1.0)
    loading, unloading = observed_curves(path)
    assert loading.curvature[-1] == pytest.approx(1.0, abs=0.04)
    assert unloading.pressure[0] == loading.pressure[-1]


def test_critical_is_the_limit_point_when_there_is_one():
    path, _k, _P = _n_shaped()
    c = characteristic_pressures(path)
    k1 = 1 - np.sqrt(1 - 2.4 / 3)
    assert c.critical_kind == "limit_point"
    assert c.critical == pytest.approx(k1**3 - 3 * k1**2 + 2.4 * k1, rel=1e-5)
    assert c.curvature_at["critical"] == pytest.approx(k1, abs=0.01)


@pytest.mark.parametrize(("pc", "width"), [(40e3, 8e3), (100e3, 5e3)])
def test_max_slope_and_knee_on_a_sigmoid(pc, width):
    # κ = tanh((P − pc)/w) + 1: steepest at pc, most negative κ'' at pc + atanh(1/√3) w
    P = np.linspace(0.0, pc + 6 * width, 400)
    k = np.tanh((P - pc) / width) + 1.0 + 1e-3 * P / pc
    c = characteristic_pressures(_path(P, k))
    assert c.critical_kind == "max_slope"
    assert c.critical == pytest.approx(pc, abs=0.01 * width)
    assert c.hardening == pytest.approx(pc + np.arctanh(1 / np.sqrt(3)) * width,
                                        abs=0.02 * width)
    assert c.failure is None
    d = c.to_dict()
    assert {"critical_pressure", "hardening_pressure", "failure_pressure"} <= set(d)


def test_no_activation_when_the_curve_keeps_steepening():
    # issue 20: the slope is largest at the last point traced, so the inflection lies beyond
    # the range: Pc is "not reached" (None), not the highest pressure traced (the old
    # behaviour reported Pc = 1.0 here, the end of the range)
    P = np.linspace(0, 1, 50)
    c = characteristic_pressures(_path(P, P**3))
    assert c.critical is None and c.critical_kind is None and c.hardening is None
    assert c.curvature_at["critical"] is None


@pytest.mark.parametrize("stop", [-3.0, -0.5, 0.0, 0.1])
def test_a_sigmoid_cut_before_its_inflection_has_no_pc(stop):
    # κ = tanh((P − pc)/w) + 1 traced only to pc + stop·w: dκ/dP still rises (or has fallen
    # by less than SLOPE_DROP: sech²(0.1) = 0.990) where the path ends
    pc, width = 40e3, 8e3
    P = np.linspace(0.0, pc + stop * width, 300)
    c = characteristic_pressures(_path(P, np.tanh((P - pc) / width) + 1.0))
    assert c.critical is None and c.hardening is None


@pytest.mark.parametrize("stop", [0.5, 1.0, 6.0])
def test_a_sigmoid_cut_after_its_inflection_has_it(stop):
    # sech²(0.5) = 0.79: the slope has fallen by 21 % from its maximum, an interior one
    pc, width = 40e3, 8e3
    P = np.linspace(0.0, pc + stop * width, 300)
    c = characteristic_pressures(_path(P, np.tanh((P - pc) / width) + 1.0))
    assert c.critical_kind == "max_slope"
    assert c.critical == pytest.approx(pc, abs=0.01 * width)


def test_pc_is_never_the_last_pressure_traced():
    # whatever the curve, a max-slope Pc lies strictly inside the traced range
    rng = np.random.default_rng(0)
    for _ in range(50):
        P = np.sort(rng.uniform(0, 1, 30))
        k = np.cumsum(rng.uniform(0, 1, 30))
        c = characteristic_pressures(_path(P, k))
        if c.critical_kind == "max_slope":
            assert P[0] < c.critical < P[-1]


def test_failure_pressure_where_peak_stretch_reaches_break():
    P = np.linspace(0, 100e3, 101)
    r = build_response(_path(P, P / 1e3, peak=1 + P / 50e3), length=0.02, shear_modulus=2e5,
                       backend="test", break_stretch=2.5)
    assert r.characteristic.failure == pytest.approx(75e3)
    assert r.characteristic.curvature_at["failure"] == pytest.approx(75.0)
    assert len(r.loading) == len(P) and len(r.unloading) == len(P)


def test_a_shallow_fold_on_the_plateau_is_not_the_activation():
    # the sigmoid of the test above, traced on: past its knee the pressure dips by 3 % and
    # recovers while κ hardly moves (as on a 3D FE cell's hardening plateau, where a
    # secondary wall mode folds); pressure control crosses it with a jump of 0.02 % of the
    # κ range, so Pc is still the steepest rise and Ph the knee before the fold
    pc, width = 40e3, 8e3
    P = np.linspace(0.0, pc + 6 * width, 400)
    k = np.tanh((P - pc) / width) + 1.0 + 1e-3 * P / pc
    top = P[-1]
    s = np.linspace(0.0, 1.0, 41)[1:]
    fold_P = top - 0.03 * top * np.sin(np.pi * s) + 0.02 * top * s
    fold_k = k[-1] + 4e-4 * s
    path = _path(np.concatenate([P, fold_P]), np.concatenate([k, fold_k]),
                 stable=np.concatenate([np.ones(P.size, bool), np.cos(np.pi * s) <= 0]))
    c = characteristic_pressures(path)
    assert c.critical_kind == "max_slope"
    assert c.critical == pytest.approx(pc, abs=0.01 * width)
    assert c.hardening == pytest.approx(pc + np.arctanh(1 / np.sqrt(3)) * width,
                                        abs=0.02 * width)
    # the same fold with a large jump is a snap-through; it comes after a ballooning that
    # has run and hardened, so it is a second event and Pc stays the first activation
    big = _path(np.concatenate([P, fold_P]), np.concatenate([k, fold_k + 2.0 * s]),
                stable=np.concatenate([np.ones(P.size, bool), np.cos(np.pi * s) <= 0]))
    c_big = characteristic_pressures(big)
    assert c_big.critical_kind == "max_slope"
    assert c_big.critical == pytest.approx(pc, abs=0.01 * width)
    # without the ballooning before it, the same snap-through is the activation
    lin = _path(np.concatenate([P, fold_P]), np.concatenate([1e-3 * P / pc, 0.02 + 2.0 * s]),
                stable=np.concatenate([np.ones(P.size, bool), np.cos(np.pi * s) <= 0]))
    assert characteristic_pressures(lin).critical_kind == "limit_point"


def test_the_knee_is_read_from_the_slope_not_from_a_ripple_on_the_plateau():
    # the sigmoid with a small ripple on its plateau (a 3D FE curve's wall modes): the ripple
    # has |d²κ/dP²| = 0.003 (8π)² / w² ≈ 1.9 / w², more than the knee's 0.77 / w², so the
    # most negative second derivative would sit on the ripple; the slope falls to 2/3 of its
    # value at Pc exactly at the knee, atanh(1/√3) w above Pc, untouched by the ripple
    # (slope 0.08 / w, from 2 w above Pc on)
    pc, width = 40e3, 8e3
    P = np.linspace(0.0, pc + 6 * width, 1200)
    ripple = np.where(P > pc + 2 * width,
                      0.003 * np.sin(8 * np.pi * (P - pc - 2 * width) / width), 0.0)
    k = np.tanh((P - pc) / width) + 1.0 + ripple
    c = characteristic_pressures(_path(P, k))
    assert c.critical == pytest.approx(pc, abs=0.01 * width)
    assert c.hardening == pytest.approx(pc + np.arctanh(1 / np.sqrt(3)) * width,
                                        abs=0.02 * width)


def _ballooning_then_second_steepening(pc: float, width: float, p2: float,
                                       ) -> tuple[np.ndarray, np.ndarray]:
    """κ(P): a ballooning sigmoid at ``pc`` that hardens, then a steeper rise at ``p2``
    (a second instability at large bend, as near the end of 3D FE cells' traced paths)."""
    P = np.linspace(0.0, p2 + 0.2 * width, 600)
    k = (np.tanh((P - pc) / width) + 1.0 + 1e-3 * P / pc
         + 2.0 * (np.tanh((P - p2) / (0.25 * width)) + 1.0))
    return P, k


def test_the_first_ballooning_is_the_activation_not_a_later_steeper_rise():
    # the slope at p2 (8/w) is four times the ballooning's (1/w) and still rising where the
    # path ends; the activation and its knee are the first sigmoid's
    pc, width = 40e3, 8e3
    P, k = _ballooning_then_second_steepening(pc, width, pc + 7 * width)
    c = characteristic_pressures(_path(P, k))
    assert c.critical_kind == "max_slope"
    assert c.critical == pytest.approx(pc, abs=0.01 * width)
    assert c.hardening == pytest.approx(pc + np.arctanh(1 / np.sqrt(3)) * width,
                                        abs=0.02 * width)


def test_a_fold_at_the_end_of_the_trace_after_a_ballooning_is_not_the_activation():
    # the sigmoid, then the path folds back (pressure falls, nothing traced to land on: a
    # runaway, as where a 3D FE trace ends in a secondary instability at large bend)
    pc, width = 40e3, 8e3
    P = np.linspace(0.0, pc + 5 * width, 300)
    k = np.tanh((P - pc) / width) + 1.0 + 1e-3 * P / pc
    s = np.linspace(0.0, 1.0, 31)[1:]
    back_P = P[-1] - 0.1 * P[-1] * s ** 2
    back_k = k[-1] + 0.5 * s
    path = _path(np.concatenate([P, back_P]), np.concatenate([k, back_k]),
                 stable=np.concatenate([np.ones(P.size, bool), np.zeros(s.size, bool)]))
    c = characteristic_pressures(path)
    assert c.critical_kind == "max_slope"
    assert c.critical == pytest.approx(pc, abs=0.01 * width)
    # the bare fold, without the ballooning before it, is the activation (a runaway)
    bare = _path(np.concatenate([P, back_P]),
                 np.concatenate([1e-3 * P / pc, 0.04 + back_k - k[-1]]),
                 stable=np.concatenate([np.ones(P.size, bool), np.zeros(s.size, bool)]))
    cb = characteristic_pressures(bare)
    assert cb.critical_kind == "limit_point"
    assert cb.critical == pytest.approx(P[-1], rel=1e-3)


def test_a_cell_that_bends_the_other_way_activates_at_the_same_pressures():
    """κ(P) = −tanh-like ballooning: the mirror of a positive bend has the same Pc and Ph
    (read in the sense of the motion), not the tiny positive slope at its first points."""
    P = np.linspace(0.0, 2.0, 401)
    k = np.tanh(4.0 * (P - 1.0)) + np.tanh(4.0) + 0.01 * P   # inflection at P = 1
    k_down = -k + 0.002 * np.sin(np.pi * P)                 # a wiggle up at small P first
    up = characteristic_pressures(_path(P, k))
    down = characteristic_pressures(_path(P, k_down))
    assert up.critical == pytest.approx(1.0, abs=0.01)
    assert down.critical == pytest.approx(up.critical, abs=0.01)
    assert down.hardening == pytest.approx(up.hardening, rel=0.02)
    # the reported curvatures keep their sign
    assert down.curvature_at["critical"] < 0 < up.curvature_at["critical"]


def test_a_rise_before_the_chamber_balloons_is_not_the_activation():
    """The signal moves by a third of its range at P = 0.1 while the chamber has grown by
    0.1 % (no ballooning: noise of a cell that barely bends), then the chamber balloons
    around P = 1: Pc is the ballooning's (BALLOONING_VOLUME_RATIO)."""
    P = np.linspace(0.0, 2.0, 401)
    balloon = np.tanh(4.0 * (P - 1.0)) + np.tanh(4.0)
    k = 0.25 * (np.tanh(40.0 * (P - 0.1)) + 1.0) + balloon + 0.01 * P
    volume = 1.0 + 3.0 * balloon
    c = characteristic_pressures(_path(P, k, volume=volume))
    assert c.critical_kind == "max_slope"
    assert c.critical == pytest.approx(1.0, abs=0.01)
    # the same signal on a chamber that has ballooned by P = 0.1 reads the first rise
    early = characteristic_pressures(_path(P, k, volume=1.0 + 3.0 * (P > 0.05) + P))
    assert early.critical == pytest.approx(0.1, abs=0.01)
    # a path that stops before the ballooning has no Pc at all, not the early rise
    cut = P <= 0.6
    none = characteristic_pressures(_path(P[cut], k[cut], volume=volume[cut]))
    assert none.critical is None and none.hardening is None


def _sigmoid(pc=10.0, width=1.0, n=81):
    P = np.linspace(0.0, 2.0 * pc, n)
    return P, 1.0 / (1.0 + np.exp(-(P - pc) / width))


@pytest.mark.parametrize("where", [0.4, 0.5, 0.6])
def test_a_lone_unstable_flag_on_a_rising_branch_is_walked_through(where):
    """The FE's stability test can flag one point unstable at the steepest rise (a
    near-singular tangent; bending_mirror #109, twisting #114 of the data set): with the
    pressure rising into and out of it the loading curve goes on, and Pc and Ph are those
    of the same path without the flag."""
    P, k = _sigmoid()
    st = np.ones(P.size, bool)
    st[int(where * P.size)] = False
    clean = characteristic_pressures(_path(P, k))
    flagged = characteristic_pressures(_path(P, k, stable=st))
    loading, _ = observed_curves(_path(P, k, stable=st))
    assert loading.pressure[-1] == pytest.approx(P[-1])
    assert not np.any(loading.extra["snap"] > 0)
    assert flagged.critical == pytest.approx(clean.critical)
    assert flagged.hardening == pytest.approx(clean.hardening)


def test_two_unstable_points_on_a_rising_branch_still_end_the_stable_branch():
    """Only a lone flag is read as the test's noise: two or more unstable points in a row
    are a stretch of unstable branch, and the loading curve snaps from before them (here
    with nowhere to land at that pressure: a runaway)."""
    P, k = _sigmoid()
    st = np.ones(P.size, bool)
    st[40:42] = False
    loading, _ = observed_curves(_path(P, k, stable=st))
    assert loading.pressure[-1] == pytest.approx(P[39])


def test_the_slope_is_numpys_gradient_to_the_bit():
    """The characteristic pressures read dκ/dP with ``np.gradient``'s formula (second-order
    inside, first-order at the ends, its even-spacing shortcut), written for 1-D arrays."""
    from multimorph.response._characteristic import _gradient

    rng = np.random.default_rng(3)
    for n in (2, 3, 5, 40, 96):
        for even in (False, True):
            x = 0.37 * np.arange(n) + 2.0 if even else np.cumsum(rng.uniform(1e-3, 3.0, n))
            f = np.cumsum(rng.normal(size=n))
            assert np.array_equal(_gradient(f, x), np.gradient(f, x))
