"""Sequence analysis on synthetic module curves with known answers (issue 4)."""

import numpy as np
import pytest

from multimorph.device import ModuleCurve, analyse_sequence


def sigmoid_curve(name, mode, pc, ph, amp, failure=None, p=None):
    # a smooth step: steep between pc and ph, flat outside (a caricature of
    # ballooning followed by strain hardening)
    p = np.linspace(0.0, 60e3, 601) if p is None else p
    mid, width = 0.5 * (pc + ph), (ph - pc) / 6.0
    m = amp / (1.0 + np.exp(-(p - mid) / width))
    m = m - m[0]
    pu = p[::-1]
    # unloading retraces the curve (elastic, no limit point)
    return ModuleCurve(name, mode, p, m, pc, ph, failure, pu, m[::-1])


def test_two_stage_order_bands_and_matched_handover():
    bend = sigmoid_curve("fingers", "bend", 15e3, 30e3, 1.5, failure=70e3)
    twist = sigmoid_curve("twister", "twist", 31e3, 50e3, 1.0, failure=90e3)
    rep = analyse_sequence([twist, bend])
    assert rep.order == ["fingers", "twister"]
    assert rep.margins[0]["verdict"] == "matched"
    assert rep.margins[0]["margin"] == pytest.approx(1e3)
    assert [b["module"] for b in rep.bands] == ["fingers", "twister"]
    # the hand-over sits between the two activation windows
    switch = rep.bands[0]["to_pressure"]
    assert 25e3 < switch < 36e3
    assert rep.first_to_fail == "fingers"
    assert rep.failure_order == ["fingers", "twister"]
    # unloading releases the later stage first
    assert rep.unloading_order == ["twister", "fingers"]
    assert rep.release_pressure["twister"] > rep.release_pressure["fingers"]


def test_gap_and_overlap_verdicts():
    a = sigmoid_curve("a", "stretch", 10e3, 20e3, 1.0)
    gap = analyse_sequence([a, sigmoid_curve("b", "bend", 35e3, 45e3, 1.0)])
    assert gap.margins[0]["verdict"] == "gap"
    over = analyse_sequence([a, sigmoid_curve("b", "bend", 12e3, 40e3, 1.0)])
    assert over.margins[0]["verdict"] == "overlap"
    assert over.margins[0]["relative_margin"] == pytest.approx((12e3 - 20e3) / 12e3)


def test_missing_pressures_are_undetermined_not_guessed():
    a = sigmoid_curve("a", "bend", 10e3, 20e3, 1.0)
    b = ModuleCurve("b", "twist", a.pressure, 0 * a.measure, None, None)
    rep = analyse_sequence([a, b])
    assert rep.order == ["a", "b"]
    assert rep.margins[0]["verdict"] == "undetermined"
    assert rep.first_to_fail is None


def test_rejects_empty_and_duplicate_names():
    a = sigmoid_curve("a", "bend", 10e3, 20e3, 1.0)
    with pytest.raises(Exception, match="at least one"):
        analyse_sequence([])
    with pytest.raises(Exception, match="unique"):
        analyse_sequence([a, a])
