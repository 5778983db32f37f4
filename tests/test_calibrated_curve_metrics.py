"""The curve measures of the validation (``calibrated._validate``) on curves with known answers.

A snapping cell's κ(P) jumps at Pc. The vertical measure (the issue's: the largest
|y_model(P) − y_FE(P)| over FE's range) counts any shift of the jump as the jump's height;
the graph measure (the distance between the curves drawn in the plane of P/Pc and y/range)
counts it as the shift. Both are exact on smooth curves that differ vertically only.
"""

from __future__ import annotations

import numpy as np
import pytest

from multimorph.calibrated._validate import compare, graph_error
from multimorph.response import CharacteristicPressures, EquilibriumPath, Response

PC = 20e3
LENGTH = 0.02


def _response(P: np.ndarray, kd: np.ndarray, pc: float | None) -> Response:
    n = len(P)
    path = EquilibriumPath(pressure=P, curvature=kd / LENGTH, twist_rate=np.zeros(n),
                           axial_stretch=np.ones(n), volume=np.linspace(1.0, 5.0, n),
                           peak_stretch=np.linspace(1.0, 3.0, n), stable=np.ones(n, bool))
    ch = CharacteristicPressures(pc, "limit_point" if pc else None, None, None)
    return Response(path, path, path.take(slice(None, None, -1)), ch, LENGTH, 100e3, "test")


def _snap(shift: float) -> Response:
    """κd: 0.1 P/Pc up to the limit point at (1 + shift) Pc, there a jump to 1, then a
    slow rise; traced to 1.6 (1 + shift) Pc."""
    pc = (1.0 + shift) * PC
    lo = np.linspace(0.0, 1.0, 41)
    hi = np.linspace(1.0 + 1e-4, 1.6, 41)
    P = np.concatenate([lo, hi]) * pc
    kd = np.concatenate([0.1 * lo, 1.0 + 0.2 * (hi - 1.0)])
    return _response(P, kd, pc)


def test_a_shifted_snap_is_a_large_vertical_error_and_a_small_graph_error() -> None:
    fe = _snap(0.0)
    for shift in (0.01, 0.03, -0.03):
        c = compare(_snap(shift), fe, "bending")
        assert c.pc_error == pytest.approx(abs(shift), rel=1e-9)
        # the FE points between the two jumps see the other branch: the jump's height
        assert c.curve_error > 0.7
        # as a graph the curves are the shift apart (P in units of FE's Pc)
        assert c.graph_error == pytest.approx(abs(shift), rel=0.05)
        assert graph_error(_snap(shift), fe, "bending") == c.graph_error


def test_identical_curves_are_zero_and_a_vertical_offset_is_bounded_by_itself() -> None:
    fe = _snap(0.0)
    assert compare(fe, fe, "bending").graph_error == pytest.approx(0.0, abs=1e-12)
    assert compare(fe, fe, "bending").curve_error == pytest.approx(0.0, abs=1e-12)
    # a smooth curve offset by a constant: the vertical measure is that offset over the
    # range; the graph distance is no larger
    P = np.linspace(0.0, 1.6 * PC, 81)
    y = 0.5 * (P / PC) ** 2
    smooth = _response(P, y, PC)
    up = _response(P, y + 0.05, PC)
    rng = 0.5 * 1.5 ** 2
    c = compare(up, smooth, "bending")
    assert c.curve_error == pytest.approx(0.05 / rng, rel=1e-9)
    assert 0.0 < c.graph_error <= c.curve_error + 1e-12


def test_no_pc_in_fe_gives_no_graph_error() -> None:
    P = np.linspace(0.0, 30e3, 31)
    flat = _response(P, 0.01 * P / 30e3, None)
    assert np.isnan(graph_error(_snap(0.0), flat, "bending"))


def test_a_value_beyond_the_other_path_is_not_known_not_a_miss() -> None:
    from multimorph.calibrated._validate import one_sided

    # FE stopped at 30 kPa (its snap); the model's knee at 35 kPa: FE does not know it
    assert not one_sided(None, 35e3, 30e3, 60e3)
    # FE went on to 60 kPa without a knee: the model's knee at 35 kPa is a miss
    assert one_sided(None, 35e3, 60e3, 60e3)
    # the other way round: FE's Pc at 40 kPa, the model traced to 50 kPa without one
    assert one_sided(40e3, None, 60e3, 50e3)
    assert not one_sided(40e3, None, 60e3, 35e3)
    assert not one_sided(None, None, 1.0, 1.0) and not one_sided(1.0, 2.0, 5.0, 5.0)


def _runaway(at: float) -> Response:
    """κd 0.1 P/P* up to a limit point at P* = ``at`` × Pc, then the unstable branch (the
    pressure falling 1 %, κd rising to 1.2) with nothing stable to land on: under pressure
    control the cell runs away at P*."""
    from multimorph.response import build_response

    up = np.linspace(0.0, 1.0, 41)
    down = np.linspace(0.0, 1.0, 21)[1:]
    P = np.concatenate([up, 1.0 - 0.01 * down]) * at * PC
    kd = np.concatenate([0.1 * up, 0.1 + 1.1 * down])
    stable = np.concatenate([np.ones(41, bool), np.zeros(20, bool)])
    n = len(P)
    path = EquilibriumPath(pressure=P, curvature=kd / LENGTH, twist_rate=np.zeros(n),
                           axial_stretch=np.ones(n), volume=np.linspace(1.0, 5.0, n),
                           peak_stretch=np.linspace(1.0, 3.0, n), stable=stable)
    return build_response(path, length=LENGTH, shear_modulus=100e3, backend="test",
                          signal="curvature")


def test_a_runaway_is_a_vertical_ray_of_the_graph() -> None:
    """A loading curve that ends at a limit point with nothing stable to land on (a
    runaway: the signal grows without bound at that pressure) is drawn as a vertical ray
    there. Against FE that snaps at the same pressure to a far state (its data end) the
    graph error is the pressure shift; a runaway 20 % early is 20 % off; the vertical
    measure sees the jump's height either way."""
    fe = _snap(0.0)
    fe = _response(np.asarray(fe.path.pressure)[:42], np.asarray(fe.path.curvature)[:42]
                   * LENGTH, PC)            # FE: the rise, then the landing at κd 1, ends
    same = _runaway(1.005)
    assert np.asarray(same.loading.pressure)[-1] == pytest.approx(1.005 * PC)
    c = compare(same, fe, "bending")
    assert c.curve_error > 0.7
    assert c.graph_error == pytest.approx(0.005, abs=2e-3)
    early = compare(_runaway(0.8), fe, "bending")
    assert 0.15 < early.graph_error < 0.25


def test_the_band_score_is_the_error_in_units_of_the_models_sigma() -> None:
    """|log(model / FE)| over the σ of log P that the model's ±1σ band gives, and the
    summary's share of designs inside ±1σ and ±2σ: a model 10 % low with a band of
    exp(±0.06) is 1.76σ off (inside ±2σ, outside ±1σ); no band (the Ritz model), no
    score."""
    import math

    from multimorph.calibrated._validate import band_z, summary

    fe = _snap(0.0)
    low = _snap(-0.1)
    assert np.isnan(band_z(low, PC, "critical"))          # no band
    pc_m = 0.9 * PC
    banded = low.with_meta(calibration={"critical_pressure_range": [pc_m * math.exp(-0.06),
                                                                    pc_m * math.exp(0.06)],
                                        "hardening_pressure_range": [None, None]})
    z = band_z(banded, PC, "critical")
    assert z == pytest.approx(abs(math.log(0.9)) / 0.06, rel=1e-9)
    assert np.isnan(band_z(banded, None, "critical"))
    c = compare(banded, fe, "bending")
    assert c.pc_z == pytest.approx(z) and np.isnan(c.ph_z)
    exact = compare(fe.with_meta(calibration={"critical_pressure_range": [0.9 * PC, 1.1 * PC]}),
                    fe, "bending")
    assert exact.pc_z == pytest.approx(0.0, abs=1e-12)
    s = summary([c, exact])
    assert s["pc_within_1sigma"] == pytest.approx(0.5)
    assert s["pc_within_2sigma"] == pytest.approx(1.0)
    assert np.isnan(s["ph_within_1sigma"])


def test_a_band_over_an_unused_anchor_covers_both_readings_and_is_scored_on_fes_side(
        ) -> None:
    """Where the path's reading and the anchor disagree by more than MAX_FACTOR (the
    anchor unused), the ±1σ band reaches over the anchor's own ±1σ; within the factor
    (an anchor unused because the path ends before it) the band is the path's own. The
    band score takes σ on FE's side of an asymmetric band: FE 5 times the model's value,
    inside the band's upper reach, is within 1σ; FE 10 % below, on the narrow side, is
    10 %/σ off."""
    import math

    from multimorph.calibrated._anchor import MAX_FACTOR
    from multimorph.calibrated._model import unused_anchor_band
    from multimorph.calibrated._validate import band_z

    own, s, anchor, sa = 6.0e3, 0.05, 39.0e3, 0.06
    lo, hi = unused_anchor_band(own, s, anchor, sa)
    assert lo == pytest.approx(own * math.exp(-s))
    assert hi == pytest.approx(anchor * math.exp(sa))
    near = 0.99 * MAX_FACTOR * own       # unused only because the path ended first
    assert unused_anchor_band(own, s, near, sa) == pytest.approx(
        [own * math.exp(-s), own * math.exp(s)])
    assert unused_anchor_band(own, s, None, sa) == pytest.approx(
        [own * math.exp(-s), own * math.exp(s)])
    # the anchor's own σ unknown: the path's σ stands for it
    assert unused_anchor_band(own, s, anchor, None)[1] == pytest.approx(anchor * math.exp(s))

    model = _snap(0.0)
    pc_m = model.characteristic.critical
    wide = model.with_meta(calibration={"critical_pressure_range": unused_anchor_band(
        pc_m, s, 6.5 * pc_m, sa), "hardening_pressure_range": [None, None]})
    up = band_z(wide, 5.0 * pc_m, "critical")
    assert up == pytest.approx(math.log(5.0) / math.log(6.5 * math.exp(sa)), rel=1e-9)
    assert up < 1.0
    assert band_z(wide, 0.9 * pc_m, "critical") == pytest.approx(-math.log(0.9) / s, rel=1e-9)
