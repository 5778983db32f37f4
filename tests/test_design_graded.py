"""Graded stages: a band wider than one module can span is realised by modules in series.

A module of identical cells activates over a narrow band (the reduced model's cells span
Ph/Pc ≈ 1.2-1.3, 3D FE's less), so a twister that should start at 30 kPa and finish at
50 kPa (Ph/Pc = 1.67) is built from graded parts, each starting where the previous one
completes (:func:`multimorph.design.graded_target`).
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from multimorph.design import (
    GRADED_RATIO,
    DesignSettings,
    design,
    graded_target,
    target_from_spec,
)
from multimorph.errors import SpecError
from test_design_helpers import STANDIN, wide_gripper_text

EXAMPLES = Path(__file__).parents[1] / "examples"


def load(name):
    if name == "target_gripper.toml":       # the paper's 30-50 kPa twist band
        return target_from_spec(tomllib.loads(wide_gripper_text()))
    return target_from_spec(tomllib.loads((EXAMPLES / name).read_text()))


def test_wide_band_splits_geometrically_into_parts():
    t = load("target_gripper.toml")
    g = graded_target(t)
    assert [s.name for s in g.stages] == ["fingers", "twister-1", "twister-2"]
    fingers, a, b = g.stages
    assert fingers == t.stages[0]                      # a single pressure: kept whole
    tw = t.stages[1]
    assert a.start_pressure == pytest.approx(30e3) and b.end_pressure == pytest.approx(50e3)
    assert a.end_pressure == pytest.approx(b.start_pressure)
    assert a.end_pressure == pytest.approx(math.sqrt(30e3 * 50e3))   # equal ratios
    assert a.magnitude + b.magnitude == pytest.approx(tw.magnitude)
    for p in (a, b):
        assert p.part_of == "twister" and p.kind == "twist"
        assert p.shaft_radius == tw.shaft_radius and p.count == tw.count
        assert p.end_pressure / p.start_pressure <= GRADED_RATIO


def test_narrow_bands_and_parallel_copies_are_kept():
    for name in ("target_jar_lifter.toml", "target_double_curvature.toml"):
        t = load(name)                                  # bands 1.25 and 1.24
        assert graded_target(t) is t
    t = load("target_three_stage.toml")                # bands 1.22 and 1.22
    t = replace(t, stages=(t.stages[0], replace(t.stages[1], parts=1), t.stages[2]))
    assert graded_target(t) is t                        # its curl asks for 2 parts: not here
    wide = replace(t, stages=(t.stages[0], replace(t.stages[1], start_pressure=25e3,
                                                   end_pressure=40e3), t.stages[2]))
    assert [s.name for s in graded_target(wide).stages] == ["extend", "curl-1", "curl-2",
                                                             "turn"]
    fingers = replace(load("target_gripper.toml").stages[0], start_pressure=10e3)
    t = replace(t, stages=(fingers,))
    assert graded_target(t) is t                        # count = 3: never split


def test_part_count_follows_the_ratio():
    t = load("target_gripper.toml")
    g = graded_target(t, max_ratio=1.2)                 # 50/30 = 1.67 needs 3 parts of 1.19
    parts = [s for s in g.stages if s.part_of == "twister"]
    assert len(parts) == 3
    assert all(s.end_pressure / s.start_pressure == pytest.approx(1.6667 ** (1 / 3), rel=1e-3)
               for s in parts)
    with pytest.raises(SpecError, match="graded_ratio"):
        graded_target(t, max_ratio=1.0)
    with pytest.raises(SpecError, match="graded_ratio"):
        DesignSettings(graded_ratio=0.9)


def test_part_names_must_not_collide():
    t = load("target_gripper.toml")
    clash = replace(t.stages[0], name="twister-1")
    with pytest.raises(SpecError, match=r"twister-1.*collide"):
        graded_target(replace(t, stages=(clash, t.stages[1])))


def test_graded_design_reports_the_stage_as_a_whole():
    """The stand-in cell spans Ph/Pc = 1.4 exactly, so a 1.25 ratio per part is reachable; the
    whole stage starts at its first part's Pc and completes at its last part's Ph."""
    t = load("target_gripper.toml")
    r = design(t, model=STANDIN, settings=DesignSettings(budget=2400, population=16, seed=3))
    assert r.feasible, r.explanation
    assert r.wanted is t and [s.name for s in r.target.stages][1:] == ["twister-1", "twister-2"]
    g = r.graded_stages()["twister"]
    best = r.best
    a, b = best.stages[1], best.stages[2]
    pr = g["predicted"]
    assert pr["start_pressure"] == a.start and pr["end_pressure"] == b.end
    assert pr["magnitude"] == pytest.approx(a.magnitude + b.magnitude)
    assert pr["met"] is True
    assert abs(pr["end_pressure"] / 50e3 - 1) <= 0.1 and abs(pr["start_pressure"] / 30e3 - 1) <= 0.1
    # the device: the twister's parts in series on the main branch, the fingers at the tip
    mods = {m.name: m for m in best.device.modules}
    assert mods["twister-1"].end == pytest.approx(mods["twister-2"].start)
    assert mods["fingers"].attach_to == "twister-2"
    assert r.to_dict()["graded"]["twister"]["parts"] == ["twister-1", "twister-2"]
    # the report states how far each module keeps moving after Ph (monotone stand-in curves)
    assert all(s.magnitude_at_max >= s.magnitude - 1e-12 for s in best.stages)
    assert "magnitude_at_max_pressure" in best.to_dict()["stages"][0]
    # scored on the stage's ends and the hand-over between its parts, not on the boundary
    d = best.distances
    assert {"twister-1.start_pressure", "twister-2.end_pressure", "twister-2.handover"} <= set(d)
    assert "twister-1.end_pressure" not in d and "twister-2.start_pressure" not in d
    boundary = r.target.stages[2].start_pressure                  # √(30 · 50) kPa
    assert d["twister-2.handover"] == pytest.approx((b.start - a.end) / boundary / 0.1)


def test_a_stage_asks_for_its_parts():
    """``parts = N`` grades a band narrower than ``graded_ratio`` into N parts (the three-
    stage target's curl: 27-33 kPa, 1.22, as two bending modules); the parts split the band
    geometrically and share the magnitude, as the ratio's parts do."""
    t = load("target_three_stage.toml")
    curl = t.stages[1]
    assert curl.parts == 2 and curl.end_pressure / curl.start_pressure < GRADED_RATIO
    g = graded_target(t)
    assert [s.name for s in g.stages] == ["extend", "curl-1", "curl-2", "turn"]
    a, b = g.stages[1:3]
    assert a.end_pressure == pytest.approx(math.sqrt(27e3 * 33e3)) == b.start_pressure
    assert a.magnitude + b.magnitude == pytest.approx(curl.magnitude)
    assert a.parts == b.parts == 1 and a.part_of == b.part_of == "curl"
    # the band's width still wins where it asks for more parts than ``parts``
    assert len([s for s in graded_target(t, max_ratio=1.05).stages
                if s.part_of == "curl"]) == 5


@pytest.mark.parametrize(("extra", "match"), [
    ('parts = 0', "parts: must be a whole number from 1 to 4"),
    ('parts = 5', "parts: must be a whole number from 1 to 4"),
    ('parts = 1.5', "parts: must be a whole number"),
    ('parts = true', "parts: must be a whole number"),
])
def test_bad_parts_are_refused(extra, match):
    text = re.sub(r"(?m)^parts = 2", extra, (EXAMPLES / "target_three_stage.toml").read_text())
    with pytest.raises(SpecError, match=match):
        target_from_spec(tomllib.loads(text))


def test_parts_need_a_band_and_no_copies():
    text = (EXAMPLES / "target_three_stage.toml").read_text()
    single = re.sub(r'band = \["27 kPa", "33 kPa"\]', 'pressure = "33 kPa"', text)
    with pytest.raises(SpecError, match=r"\(curl\)\.parts: graded parts split a band"):
        target_from_spec(tomllib.loads(single))
    copies = re.sub(r"(?m)^parts = 2", "parts = 2\ncount = 2", text)
    with pytest.raises(SpecError, match=r"\(curl\)\.parts: a stage with parallel copies"):
        target_from_spec(tomllib.loads(copies))


def test_a_graded_stage_is_scored_on_its_parts_sum():
    """The motion of a graded stage is what its parts do together: the last part carries
    the distance of their sum from the stage's magnitude, an earlier part none of its own
    (stop 38: in FE the curl's two parts turned 35° and 56° for 45° each, 91° for 90°)."""
    from multimorph.design import SearchSpace, evaluate_one
    from multimorph.design._optimise import explain_design

    t = graded_target(load("target_three_stage.toml"))
    space = SearchSpace(t)
    cand = space.decode(np.random.default_rng(1).random(space.dim))   # two bending parts
    resps = STANDIN(list(cand.cells), t.constraints.max_pressure)
    ev = evaluate_one(t, cand, resps, fixed_cells=[3, 3, 3, 3])
    a, b = (next(s for s in ev.stages if s.name == n) for n in ("curl-1", "curl-2"))
    assert "curl-1.magnitude" not in ev.distances
    whole = math.radians(90.0)
    assert ev.distances["curl-2.magnitude"] == pytest.approx(
        (a.magnitude + b.magnitude - whole) / whole / t.tolerance.magnitude)
    assert a.magnitude > 1.5 * b.magnitude > 0                # unequal parts (161°, 96°)
    assert ev.distances["curl-2.magnitude"] > 1                # 257° for 90°: explained
    assert any(line.startswith("stage 'curl' (curl-1 + curl-2) magnitude 257 deg vs wanted "
                               "90 deg") for line in explain_design(space, ev))


def test_every_graded_part_must_move():
    """Scored on their sum, the parts must each still move by half their share at least
    (``<part>.share``): a part of 2° in a 90° curl (45° its share) violates it, parts of
    161° and 96° do not (three-stage seed 3 had put 13 cells turning 4.7° first)."""
    from multimorph.design import SearchSpace, evaluate_one
    from multimorph.design._evaluate import MIN_PART_SHARE
    from multimorph.design._optimise import explain_design

    t = graded_target(load("target_three_stage.toml"))
    space = SearchSpace(t)
    for seed, still in ((0, "curl-2"), (1, None)):
        cand = space.decode(np.random.default_rng(seed).random(space.dim))
        resps = STANDIN(list(cand.cells), t.constraints.max_pressure)
        ev = evaluate_one(t, cand, resps, fixed_cells=[3, 3, 3, 3])
        for part in ("curl-1", "curl-2"):
            sr = next(s for s in ev.stages if s.name == part)
            share = MIN_PART_SHARE * math.radians(45.0)
            assert ev.violations[f"{part}.share"] == pytest.approx((share - sr.magnitude)
                                                                   / share)
            assert (ev.violations[f"{part}.share"] > 0) == (part == still)
        assert "extend.share" not in ev.violations and "turn.share" not in ev.violations
        if still:
            assert not ev.meets
            assert any(line.startswith(f"{still}: a graded part that hardly moves")
                       for line in explain_design(space, ev))
