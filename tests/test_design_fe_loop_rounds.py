"""FE in the loop without FE (issue 19): the loop's own rules, with a stand-in "FE" that
scores each design as the model does but with every stage stiffer (20 %, then 50 %, 80 %
for the designs checked after it), so that no design meets the target in "FE".

- each round corrects the next search by its own design's FE/model ratio (stop 34; before,
  the best design's ratio, which repeated one design when a round did worse);
- a search that returns a design FE has already checked ends the loop: the same FE result
  would only repeat (the gripper's rounds 4–6 were one design three times).
"""

from dataclasses import replace

import numpy as np
import pytest

from multimorph.design import DesignSettings, _mapped, _pipeline, design
from multimorph.design._evaluate import evaluate_one
from test_design_helpers import STANDIN
from test_design_infeasible import target as two_bends

#: the stand-in FE's pressure factor on the first, second, third … design it checks
STIFFER = (1.2, 1.5, 1.8)


def _stiffer(responses, factor):
    """The stand-in responses of a design with every pressure × ``factor``."""
    out = []
    for r in responses:
        ch = r.characteristic
        out.append(replace(r, characteristic=replace(
            ch, critical=None if ch.critical is None else factor * ch.critical,
            hardening=None if ch.hardening is None else factor * ch.hardening)))
    return out


@pytest.fixture
def loop(monkeypatch, tmp_path):
    target = two_bends(p1="30 kPa", p2="45 kPa",
                       materials='["ecoflex-00-30", "dragon-skin-10"]')
    # modules of any cell count, as when the ranking below was laid out: the stand-in has
    # no ends, and what this tests is the loop's bookkeeping (min_cells: test_design_spec)
    target = replace(target, constraints=replace(target.constraints, min_cells=1))
    first = design(target, model=STANDIN, settings=DesignSettings(budget=400, population=8,
                                                                   seed=0))
    assert first.best is not None
    checked: list[np.ndarray] = []

    def fake_checker(folder, **kw):
        def check(t, evs):
            ev = evs[0]
            factor = STIFFER[min(len(checked), len(STIFFER) - 1)]
            checked.append(np.asarray(ev.candidate.x, float).copy())
            return [evaluate_one(t, ev.candidate, _stiffer(ev.responses, factor),
                                 fixed_cells=[s.n_cells for s in ev.stages])]
        return check

    monkeypatch.setattr(_pipeline, "fe_checker", fake_checker)
    return target, first, checked, tmp_path


def test_a_search_that_returns_a_checked_design_ends_the_loop(loop) -> None:
    target, first, checked, tmp_path = loop
    searches = []

    def same_again(x0=None, correction=None, tag=""):
        searches.append(correction)
        return first                       # the search finds the same design again

    r = _pipeline._fe_loop(target, first, same_again, fe_rounds=3, model=STANDIN,
                           folder=tmp_path, mesh="coarse", wall_elements=None, stage=None,
                           records=[])
    assert len(checked) == 1 and len(r.fe_rounds) == 1     # FE ran once, not 4 times
    assert len(searches) == 1                              # the repeat was searched, not FE'd
    assert not r.fe_rounds[0].check.meets


def test_each_round_is_corrected_by_its_own_designs_ratio(loop) -> None:
    target, first, checked, tmp_path = loop
    others = iter([replace(first, designs=[d]) for d in first.designs[1:4]
                   if d is not first.best])
    corrections = []

    def next_design(x0=None, correction=None, tag=""):
        corrections.append(correction)
        return next(others)

    r = _pipeline._fe_loop(target, first, next_design, fe_rounds=2, model=STANDIN,
                           folder=tmp_path, mesh="coarse", wall_elements=None, stage=None,
                           records=[])
    assert len(r.fe_rounds) == 3 and len(checked) == 3
    # the best FE-checked design is the result (no design meets, so the least objective) ...
    assert r.fe_best.objective == min(rd.check.objective for rd in r.fe_rounds)
    # ... but each search is corrected by the ratio of the design checked just before it
    # (round 0's 1.2, then round 1's 1.5), not by the best one's every time
    for corr, want in zip(corrections, STIFFER, strict=False):
        for stage in corr:
            assert stage["start_pressure"] == pytest.approx(want)
            assert stage["end_pressure"] == pytest.approx(want)
    for rd, corr in zip(r.fe_rounds[:-1], corrections, strict=True):
        assert all(corr[i][q] == pytest.approx(rd.factors[f"{st.name}.{q}"])
                   for i, st in enumerate(target.stages) for q in corr[i])


def test_a_design_fe_verifies_but_the_model_swaps_is_not_the_end(loop, monkeypatch) -> None:
    """FE meets the targets on round 0's design, but on the model alone its stages come in
    the other order (as the gripper's first verified design, stop 37): the loop goes on, and
    the design both agree on (round 1) is the result, though its FE objective is worse."""
    target, first, checked, tmp_path = loop
    second = replace(first, designs=[d for d in first.designs if d is not first.best][:1])
    assert second.best is not None and second.best is not first.best

    def fe_meets(folder, **kw):
        def check(t, evs):
            ev = evs[0]
            checked.append(np.asarray(ev.candidate.x, float).copy())
            worse = 1.0 + len(checked)              # each later design's FE objective higher
            fe = evaluate_one(t, ev.candidate, ev.responses,
                              fixed_cells=[s.n_cells for s in ev.stages])
            return [replace(fe, meets=True, objective=worse)]
        return check

    real = _pipeline.rescore
    calls = []

    def swapped_first(t, ev):
        calls.append(ev)
        out = real(t, ev)
        if len(calls) == 1:                         # round 0: the model swaps the stages
            a, b = (s.name for s in t.stages)
            out = replace(out, violations={**out.violations, f"{a}->{b}.order": 0.02})
        return out

    monkeypatch.setattr(_pipeline, "fe_checker", fe_meets)
    monkeypatch.setattr(_pipeline, "rescore", swapped_first)
    r = _pipeline._fe_loop(target, first, lambda **kw: second, fe_rounds=3, model=STANDIN,
                           folder=tmp_path, mesh="coarse", wall_elements=None, stage=None,
                           records=[])
    assert len(r.fe_rounds) == 2                    # on past a verified, swapped round 0
    assert r.fe_rounds[0].check.meets and r.fe_rounds[1].check.meets
    assert r.fe_best.objective == r.fe_rounds[1].check.objective   # the agreed one
    assert r.fe_best.objective > r.fe_rounds[0].check.objective
    assert not _pipeline._agreed(r.fe_rounds[0].check, r.fe_rounds[0].search)
    assert _pipeline._agreed(r.fe_rounds[1].check, r.fe_rounds[1].search)


def test_every_model_alone_must_keep_the_order(loop) -> None:
    """The FE loop asks the checking model and the search model (calibrated and
    calibrated-fast: the demo and ``simulate`` run on the fast one) for the order: one of
    them swapping the stages is enough to go on (the gripper's second FE-verified design,
    stop 37: in order on the calibrated model, twister first on the fast one)."""
    target, first, _, _ = loop
    best = first.best
    a, b = (s.name for s in target.stages)
    fe = replace(best, meets=True)
    swapped = replace(best, violations={**best.violations, f"{a}->{b}.order": 0.02})
    in_order = replace(best, violations={**best.violations, f"{a}->{b}.order": -0.05})
    assert _pipeline._agreed(fe, in_order, in_order)
    assert not _pipeline._agreed(fe, in_order, swapped)
    assert not _pipeline._agreed(replace(fe, meets=False), in_order)
    assert _pipeline._rank(fe, True) < _pipeline._rank(replace(fe, objective=0.0), False)


def test_fe_screening_tries_other_cells_of_the_stage_fe_misses(loop, monkeypatch) -> None:
    """FE screening (stop 39): the stand-in FE makes the search's cell of the first stage
    50 % stiffer and answers every other cell as the model does. With ``screen = 2`` the
    round also checks two other cells of the stage FE then misses most (and only of that
    stage: the other stage's cell stays), keeps the design FE finds best, and records
    both."""
    from multimorph.design._mapped import stage_score
    from multimorph.design._space import N_VARS

    target, _, checked, tmp_path = loop
    # one module per stage (no graded parts): the report below reads the design's cells
    first = design(target, model=STANDIN, settings=DesignSettings(
        budget=400, population=8, seed=0, graded=False, top=12))
    best = first.best
    x_best = np.asarray(best.candidate.x, float)
    bad = x_best[:N_VARS].copy()

    def stiff(ev):
        x = np.asarray(ev.candidate.x, float)
        factor = 1.5 if np.allclose(x[:N_VARS], bad) else 1.0
        return evaluate_one(target, ev.candidate, _stiffer(ev.responses[:1], factor)
                            + list(ev.responses[1:]),
                            fixed_cells=[s.n_cells for s in ev.stages])

    def fe(folder, **kw):
        def check(t, evs):
            checked.append(np.asarray(evs[0].candidate.x, float).copy())
            return [stiff(evs[0])]
        return check

    fe_first = stiff(best)
    scores = [stage_score(fe_first, i, target) for i in range(len(target.stages))]
    i = int(np.argmax(scores))
    cut = slice(i * N_VARS, (i + 1) * N_VARS)
    kept_out = [j for j in range(len(x_best)) if not cut.start <= j < cut.stop]
    monkeypatch.setattr(_pipeline, "fe_checker", fe)
    r = _pipeline._fe_loop(target, first, lambda **kw: first, fe_rounds=0, model=STANDIN,
                           folder=tmp_path, mesh="coarse", wall_elements=None, stage=None,
                           records=[], screen=2)
    [rd] = r.fe_rounds
    assert len(checked) == 3 and len(rd.screened) == 2
    for x in checked[1:]:      # only that stage's cell moved, to a cell FE had not checked
        np.testing.assert_allclose(x[kept_out], x_best[kept_out])
        assert np.max(np.abs(x[cut] - x_best[cut])) >= _mapped.SCREEN_DISTANCE
    assert all(s["stage"] == target.stages[i].name for s in rd.screened)
    # the second screened cell is not the first one again (the farthest of the best)
    assert np.max(np.abs(checked[1][cut] - checked[2][cut])) >= _mapped.SCREEN_DISTANCE
    kept = [s for s in rd.screened if s["kept"]]
    assert len(kept) <= 1
    # the round's design is the best FE found: the search's or the screened one kept
    assert rd.check.objective == pytest.approx(min(
        [fe_first.objective] + [s["fe_objective"] for s in rd.screened]))
    if kept:
        assert rd.check.objective == pytest.approx(kept[0]["fe_objective"])
    assert "screened" in rd.to_dict() and "x" not in rd.to_dict()["screened"][0]
    from multimorph.design._report import report_markdown

    md = report_markdown(replace(r, fe_route="modules"))
    assert "FE screening" in md and md.count(f"| 0 | {target.stages[i].name} |") >= 3


def test_no_screening_where_fe_meets(loop, monkeypatch) -> None:
    target, first, checked, tmp_path = loop

    def fe_meets(folder, **kw):
        def check(t, evs):
            ev = evs[0]
            checked.append(np.asarray(ev.candidate.x, float).copy())
            fe = evaluate_one(t, ev.candidate, ev.responses,
                              fixed_cells=[s.n_cells for s in ev.stages])
            return [replace(fe, meets=True)]
        return check

    monkeypatch.setattr(_pipeline, "fe_checker", fe_meets)
    r = _pipeline._fe_loop(target, first, lambda **kw: first, fe_rounds=2, model=STANDIN,
                           folder=tmp_path, mesh="coarse", wall_elements=None, stage=None,
                           records=[], screen=2)
    assert len(checked) == 1 and r.fe_rounds[0].screened == ()


def test_a_modules_fe_is_keyed_by_the_module_not_the_device() -> None:
    """The ``modules`` route keeps each module's FE under a key of the module as written,
    its end and the FE settings (stop 39), so that a design sharing a module with one FE
    has checked (the FE screening's designs, a later round) re-uses it: the same twister
    in two devices has one key; another wall, count, tilt or setting another."""
    import math
    import tomllib
    from pathlib import Path

    from multimorph.design._fe_check import module_description, module_key
    from multimorph.device import device_from_spec

    spec = tomllib.loads((Path(__file__).parents[1] / "examples" / "gripper.toml").read_text())
    dev = device_from_spec(spec)
    twister = next(m for m in dev.modules if m.kind == "twisting")
    options = {"mesh": "coarse", "p_max": 55e3}
    d = module_description(twister, "strip")
    assert d["kind"] == "twisting" and d["tilt"] == pytest.approx(twister.tilt)
    assert d["cell"]["top_wall"] == pytest.approx(twister.cell.top_wall)
    assert d["material"]["name"] == twister.cell.material.name
    key = module_key(d, options)
    # the same module in another device (renamed, the other modules gone): the same key
    alone = device_from_spec({**spec, "module": [
        {**m, "name": "other"} for m in spec["module"] if m["name"] == twister.name]})
    assert module_key(module_description(alone.modules[0], "strip"), options) == key
    changed = [
        {**d, "cell": {**d["cell"], "top_wall": d["cell"]["top_wall"] * 1.01}},
        {**d, "cells": d["cells"] + 1}, {**d, "tilt": d["tilt"] + math.radians(1.0)},
        {**d, "end": "shaft"}]
    keys = {module_key(c, options) for c in changed} | {module_key(d, {**options,
                                                                        "p_max": 60e3})}
    assert key not in keys and len(keys) == 5
