"""Search inside the calibrated box, trust regions, and space mapping (issue 19).

Space mapping is checked against a pair of closed-form stand-in models with a known,
design-dependent bias: the "accurate" model is the stand-in with every pressure 10-30 %
higher. A search on the stand-in alone misses the accurate model's targets; the mapped
search must meet them, with correction factors that undo the known bias.
"""

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from multimorph.calibrated._box import Box, cell_groups
from multimorph.calibrated._dataset import reference_spec
from multimorph.design import (
    DesignSettings,
    SearchSpace,
    batched,
    correction_factors,
    design,
    mapped_design,
    model_checker,
    target_from_spec,
)
from multimorph.design._space import BOX_MIN_CHAMBER
from multimorph.response import CharacteristicPressures, Response
from test_design_helpers import STANDIN, standin_cell

EXAMPLES = Path(__file__).parents[1] / "examples"


def load(name):
    return target_from_spec(tomllib.loads((EXAMPLES / name).read_text()))


def bias(cell):
    """The accurate model's pressures over the stand-in's: smooth in the design."""
    return 1.1 + 0.2 * cell.top_wall / cell.height


def _scaled(r: Response, f: float, p_max: float) -> Response:
    ch = r.characteristic

    def up(v):
        return None if v is None or v * f >= p_max else v * f

    path = r.loading
    from dataclasses import replace

    moved = replace(path, pressure=np.asarray(path.pressure) * f)
    ch2 = CharacteristicPressures(up(ch.critical), ch.critical_kind, up(ch.hardening), None)
    return Response(moved, moved, moved.take(slice(None, None, -1)), ch2, r.length,
                    r.shear_modulus, "standin-biased")


def accurate_cell(cell, p_max):
    return _scaled(standin_cell(cell, p_max), bias(cell), p_max)


ACCURATE = batched(accurate_cell)


@pytest.mark.parametrize("kind", ["bending", "stretching"])
def test_box_decoding_stays_inside_box_and_constraints(kind):
    """Every decoded cell lies in the calibrated box and meets the target's constraints."""
    boxes = {k: Box.from_spec(k, reference_spec(k)) for k in ("bending", "stretching")}
    box = boxes[kind]
    name = "target_jar_lifter.toml" if kind == "stretching" else "target_gripper.toml"
    t = load(name)
    space = SearchSpace(t, boxes=boxes)
    c = t.constraints
    rng = np.random.default_rng(1)
    n_inside = 0
    for x in rng.random((300, space.dim)):
        for stage, cell in zip(t.stages, space.decode(x).cells, strict=True):
            if (stage.kind == "stretch") != (kind == "stretching"):
                continue
            n_inside += 1
            assert not box.outside(cell_groups(cell)), cell
            for wall in (cell.top_wall, cell.bottom_wall, cell.side_wall, cell.end_wall):
                assert wall >= c.min_wall * (1 - 1e-9)
            assert cell.width <= c.max_width * (1 + 1e-9)
            assert cell.height <= c.max_height * (1 + 1e-9)
            least = max(space.min_chamber, BOX_MIN_CHAMBER * cell.length)
            for size in (cell.wc, cell.hc, cell.dc):
                assert size >= least * (1 - 1e-9)
    assert n_inside >= 300


def test_box_decoding_covers_the_box():
    """The coordinates reach both ends of each group's interval (no dead corner)."""
    box = Box.from_spec("bending", reference_spec("bending"))
    t = load("target_gripper.toml")
    space = SearchSpace(t, boxes={"bending": box})
    lo = space.decode(np.zeros(space.dim)).cells[0]
    hi = space.decode(np.ones(space.dim)).cells[0]
    g_lo, g_hi = cell_groups(lo), cell_groups(hi)
    assert g_lo["ht/d"] < g_hi["ht/d"] and g_lo["w/d"] < g_hi["w/d"]
    # the lower corner is the low end of the group's interval: the box's bound or, where
    # it binds, what two walls of min_wall and the least chamber need
    j = box.names.index("w/d")
    d = lo.length
    need = (2 * t.constraints.min_wall + max(space.min_chamber, BOX_MIN_CHAMBER * d)) / d
    assert math.isclose(g_lo["w/d"], max(box.low[j], need), rel_tol=1e-9)


def test_trust_region_keeps_designs_near_x0():
    t = load("target_jar_lifter.toml")
    space = SearchSpace(t)
    x0 = np.full(space.dim, 0.5)
    r = design(t, model=STANDIN, settings=DesignSettings(budget=400, population=8, seed=0,
                                                         graded=False),
               x0=x0, radius=0.1)
    for e in r.designs:
        assert np.all(np.abs(e.candidate.x - x0) <= 0.1 + 1e-9)


def test_correction_factors_measure_a_known_bias():
    t = load("target_jar_lifter.toml")
    r = design(t, model=STANDIN, settings=DesignSettings(budget=600, population=12, seed=2,
                                                         graded=False))
    best = r.best
    [checked] = model_checker(ACCURATE)(t, [best])
    pmax = t.constraints.max_pressure
    rho = correction_factors(best, checked, pmax)
    for _stage, cell, s, c, f in zip(t.stages, best.candidate.cells, best.stages,
                                    checked.stages, rho, strict=True):
        for q, sv, cv in (("start_pressure", s.start, c.start), ("end_pressure", s.end, c.end)):
            if cv is not None:          # the accurate model reaches it: the bias exactly
                assert f[q] == pytest.approx(bias(cell), rel=1e-6)
            else:                       # beyond max_pressure there: bounded just above it
                assert f[q] == pytest.approx(1.1 * pmax / sv, rel=1e-6)
                assert bias(cell) * sv > pmax
    # the corrected stand-in reproduces the accurate model on this design
    [again] = model_checker(STANDIN, rho)(t, [best])
    for c, a in zip(checked.stages, again.stages, strict=True):
        if c.start is not None:
            assert a.start == pytest.approx(c.start, rel=1e-9)


def test_mapped_design_meets_the_accurate_model():
    """Plain search on the stand-in misses in the accurate model; the mapped one meets."""
    t = load("target_jar_lifter.toml")
    settings = DesignSettings(budget=900, population=16, seed=3, graded=False)
    plain = design(t, model=STANDIN, settings=settings)
    [plain_checked] = model_checker(ACCURATE)(t, [plain.best])
    assert plain.feasible and not plain_checked.meets      # the bias is beyond tolerance
    r = mapped_design(t, search_model=STANDIN, check=model_checker(ACCURATE),
                      settings=settings, rounds=4)
    assert r.feasible, r.explanation
    assert 2 <= len(r.rounds) <= 5 and r.rounds[0].index == 0
    assert not r.rounds[0].check.meets and r.rounds[-1].check.meets
    # the best design, recomputed independently in the accurate model, meets the targets
    best = r.best
    for stage, cell, sr in zip(t.stages, best.candidate.cells, best.stages, strict=True):
        pc, ph = (bias(cell) * v for v in _standin(cell))
        assert sr.start == pytest.approx(pc, rel=1e-9)
        assert sr.end == pytest.approx(ph, rel=1e-9)
        assert abs(ph / stage.end_pressure - 1) <= t.tolerance.pressure
    d = r.to_dict()
    assert [rd["round"] for rd in d["rounds"]] == list(range(len(r.rounds)))
    assert d["rounds"][-1]["meets_targets"] is True
    assert set(d["rounds"][0]["stages"][0]) >= {"wanted", "correction", "search_model",
                                                "check_model", "cells"}
    assert d["rounds"][0]["stages"][0]["correction"] is None         # round 0: the model
    assert d["rounds"][1]["stages"][0]["correction"]["end_pressure"] > 1  # then corrected


def _standin(cell):
    from test_design_helpers import standin_pressures

    return standin_pressures(cell)


def test_polish_on_the_accurate_model_improves_one_stage_at_a_time():
    """From a design that misses in the accurate model, the stage-wise compass search on
    that model lowers the objective; every probe batch is one cell per probe."""
    from multimorph.design import polish_stages

    t = load("target_jar_lifter.toml")
    plain = design(t, model=STANDIN, settings=DesignSettings(budget=900, population=16,
                                                             seed=3, graded=False))
    [start] = model_checker(ACCURATE)(t, [plain.best])
    assert not start.meets
    calls = []

    def counting(cells, p_max):
        calls.append(len(cells))
        return ACCURATE(cells, p_max)

    out = polish_stages(t, start, counting, seconds=30.0)
    assert out.objective < start.objective
    assert calls and max(calls) <= 16                  # 8 coordinates × ± of one stage
    # the result is what the accurate model says of its cells (independent recomputation)
    [again] = model_checker(ACCURATE)(t, [out])
    assert again.objective == pytest.approx(out.objective, rel=1e-9)
    # the budget is model calls, not wall time (stop 39): the same start, the same result
    calls.clear()
    short = polish_stages(t, start, counting, seconds=30.0, calls=3)
    assert len(calls) == 3
    calls.clear()
    assert polish_stages(t, start, counting, seconds=30.0, calls=3).objective == \
        pytest.approx(short.objective, rel=1e-12) and len(calls) == 3


def test_a_path_that_stopped_early_is_not_read_as_stiffer():
    """A missing Pc/Ph is 'beyond max_pressure' only where the checking path got there: a
    device FE that stalled at a limit point (the jar lifter's seal, 100.5 kPa of 180) says
    nothing about the pressures above it, and its stage is not corrected as stiffer."""
    from dataclasses import replace as _replace

    from multimorph.design import StageResult
    from multimorph.design._mapped import BEYOND

    t = load("target_jar_lifter.toml")
    pmax = t.constraints.max_pressure
    s = StageResult("sealer", "stretch", 115e3, 120e3, 0.99, 1, None, None, None,
                    traced_to=pmax)
    c = StageResult("sealer", "stretch", None, None, 0.93, 1, None, None, None,
                    traced_to=100.5e3)

    class Ev:                                # the two fields correction_factors reads
        def __init__(self, st):
            self.stages = (st,)

    [f] = correction_factors(Ev(s), Ev(c), pmax)
    assert f["start_pressure"] == 1.0 and f["end_pressure"] == 1.0     # unknown: no change
    [g] = correction_factors(Ev(s), Ev(_replace(c, traced_to=pmax)), pmax)
    assert g["end_pressure"] == pytest.approx(BEYOND * pmax / 120e3)   # reached: stiffer


def test_a_motion_is_corrected_further_than_a_pressure():
    """The motion's factor may reach 3 (the gripper's twister twisted 2.3-2.6 × the model
    in FE, round after round; clipped at 2 the loop could not reach its angle); a pressure's
    stays within 2, and both are bounded."""
    from multimorph.design import StageResult
    from multimorph.design._mapped import FACTOR_RANGE, MAGNITUDE_FACTOR_RANGE

    t = load("target_gripper.toml")
    pmax = t.constraints.max_pressure

    class Ev:
        def __init__(self, st):
            self.stages = (st,)

    s = StageResult("twister", "twist", 30e3, 40e3, 0.8, 3, None, None, None, traced_to=pmax)
    for ratio, want in ((2.4, 2.4), (4.0, MAGNITUDE_FACTOR_RANGE[1]),
                        (0.2, MAGNITUDE_FACTOR_RANGE[0])):
        c = StageResult("twister", "twist", 2.5 * 30e3, 2.5 * 40e3, 0.8 * ratio, 3, None,
                        None, None, traced_to=pmax)
        [f] = correction_factors(Ev(s), Ev(c), pmax)
        assert f["magnitude"] == pytest.approx(want)
        assert f["start_pressure"] == FACTOR_RANGE[1]                 # 2.5 × clipped at 2
    assert MAGNITUDE_FACTOR_RANGE[1] > FACTOR_RANGE[1]


def test_a_softer_checking_model_is_reached_by_tracing_further():
    """When the checking model is softer (factors < 1), the search model is traced beyond
    max_pressure (SearchSpace.model_pmax), so designs whose own Ph lies above it — the ones
    that meet the targets once corrected — can be found."""
    soft = batched(lambda cell, p_max: _scaled(standin_cell(cell, p_max / 0.8), 0.8, p_max))
    t = load("target_jar_lifter.toml")
    settings = DesignSettings(budget=900, population=16, seed=3, graded=False)
    r = mapped_design(t, search_model=STANDIN, check=model_checker(soft), settings=settings,
                      rounds=4)
    assert r.feasible, r.explanation
    pmax = t.constraints.max_pressure
    best = r.best
    # the stand-in's own completion pressure of the lifter is above max_pressure
    _, ph = _standin(best.candidate.cells[1])
    assert ph > pmax and 0.8 * ph == pytest.approx(best.stages[1].end, rel=1e-9)


def test_a_corrected_design_keeps_its_stage_order_on_the_model_alone():
    """FE in the loop scores designs on a corrected model; a design must then also come in
    order on the model's own Pc (``<a>-><b>.model_order``), or its device example would
    simulate with its stages swapped (the gripper's verified design, stop 36: twister
    0.6 % before the fingers on the model, 7.7 % after in FE)."""
    from multimorph.design._evaluate import Measured, score_measured

    t = load("target_jar_lifter.toml")
    r = design(t, model=STANDIN, settings=DesignSettings(budget=300, population=12, seed=2,
                                                         graded=False))
    best = r.best
    a, b = best.stages
    # the checker adds the constraint only where it corrects the model
    assert not any(k.endswith("model_order") for k in model_checker(STANDIN)(t, [best])[0]
                   .violations)
    ones = tuple({"start_pressure": 1.0, "end_pressure": 1.0, "magnitude": 1.0}
                 for _ in t.stages)
    [same] = model_checker(STANDIN, ones)(t, [best])
    key = f"{a.name}->{b.name}.model_order"
    assert same.violations[key] == pytest.approx(same.violations[f"{a.name}->{b.name}.order"])
    # measured (corrected) in order, the model's own Pc swapped: violated, not met
    measured = [Measured(s.start, s.end, s.magnitude, s.n_cells, s.safety_factor,
                         s.peak_stretch, s.failure, s.magnitude_at_max, traced_to=s.traced_to)
                for s in best.stages]
    plain = score_measured(t, best.candidate, measured)
    swapped = score_measured(t, best.candidate, measured,
                             model_starts=[1.2 * b.start, b.start])
    kept = score_measured(t, best.candidate, measured, model_starts=[0.8 * b.start, b.start])
    assert key not in plain.violations
    assert swapped.violations[key] == pytest.approx(0.2 + 0.01)
    assert not swapped.meets and swapped.objective > plain.objective
    assert kept.violations[key] < 0 and kept.meets == plain.meets
    assert kept.objective == pytest.approx(plain.objective)


def test_screening_finds_another_kind_of_cell_where_the_checking_model_has_no_knee():
    """Where the checking model contradicts the search model qualitatively (no hardening
    knee near the searched cell: the three-stage twist of stop 40), the screening tries
    other cells of that stage, all in one call of the checking model, and keeps a better
    design; the other stage's cell stays as it was."""
    from multimorph.design._mapped import SCREEN_MODEL_CELLS, rescore, screen_stage
    from multimorph.design._space import N_VARS

    t = load("target_jar_lifter.toml")
    plain = design(t, model=STANDIN, settings=DesignSettings(budget=900, population=16,
                                                             seed=3, graded=False))
    assert plain.feasible
    ref = plain.best.candidate.cells[1]
    fields = ("length", "width", "height", "top_wall", "bottom_wall", "side_wall", "end_wall")

    def near(cell):         # the searched lifter cell and its near copies
        return all(abs(getattr(cell, f) / getattr(ref, f) - 1) < 0.01 for f in fields)

    def kneeless_cell(cell, p_max):
        r = standin_cell(cell, p_max)
        if not near(cell):
            return r
        ch = r.characteristic
        return Response(r.path, r.loading, r.unloading,
                        CharacteristicPressures(ch.critical, ch.critical_kind, None, None),
                        r.length, r.shear_modulus, "standin-kneeless")

    kneeless = batched(kneeless_cell)
    [start] = model_checker(kneeless)(t, [plain.best])
    assert start.stages[1].end is None and not start.meets
    calls = []

    def counting(cells, p_max):
        calls.append(len(cells))
        return kneeless(cells, p_max)

    out = screen_stage(t, rescore(t, plain.best), start, plain.designs, STANDIN, counting,
                       seed=0)
    assert len(calls) == 1 and calls[0] <= SCREEN_MODEL_CELLS
    assert out.objective < start.objective and out.stages[1].end is not None
    assert not near(out.candidate.cells[1])
    x0, x1 = (np.asarray(e.candidate.x, float) for e in (start, out))
    np.testing.assert_allclose(x1[:N_VARS], x0[:N_VARS])        # the sealer's cell stays
    # the result is what the checking model says of its cells (independent recomputation)
    [again] = model_checker(kneeless)(t, [out])
    assert again.stages[1].end == pytest.approx(out.stages[1].end, rel=1e-9)
