"""Space mapping: search on a fast model, check on an accurate one, shift the targets.

A search model s(x) (cheap: the calibrated model on emulated Ritz features, thousands of
curves a second) and a checking model c(x) (accurate and slower: the calibrated model on
exact Ritz features, or the 3D FE of the whole device) differ by a bias that is smooth in
the design and mostly multiplicative. Output space mapping: with x_k the best design of
round k, the targets searched in round k + 1 are

    T_{k+1} = T · s(x_k) / c(x_k)

per stage and quantity (start pressure, completion pressure, magnitude), so that a design
that meets T_{k+1} in the search model meets T in the checking model as far as the bias
holds near x_k. Round k + 1 starts from x_k (seeded into its population) and its best
designs are checked again. The rounds stop when the checked best design meets T, or after
``rounds`` corrections. Every round is kept: what was searched for, what the search model
and the checking model say of its best design, and the factors applied next.

Sources: Bandler et al., "Space mapping: the state of the art", IEEE T-MTT 52 (2004)
(output space mapping); Koziel, Bandler & Madsen, IEEE T-MTT 54 (2006) (its convergence
when the models' responses are close).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

from multimorph.design._evaluate import Evaluation, evaluate_one
from multimorph.design._optimise import (
    DesignResult,
    DesignSettings,
    Progress,
    _explain,
    design,
)
from multimorph.design._space import SearchSpace
from multimorph.design._target import TargetSpec, graded_target

__all__ = ["Checker", "MappingRound", "mapped_design", "model_checker", "shift_target"]

#: ``check(target, evaluations) -> evaluations``: the same designs (candidates and cell
#: counts) scored against ``target`` by the checking model.
Checker = Callable[[TargetSpec, Sequence[Evaluation]], list[Evaluation]]
#: Bounds of one round's correction factor (a factor outside them is clipped: a model
#: that misses by more than 2 × is not corrected in one step).
FACTOR_RANGE = (0.5, 2.0)
QUANTITIES = ("start_pressure", "end_pressure", "magnitude")


@dataclass(frozen=True, eq=False)
class MappingRound:
    """One round of :func:`mapped_design`.

    Attributes
    ----------
    index : int
        0 for the first search (targets as wanted), then 1, 2, …
    wanted : TargetSpec
        The targets as wanted (graded parts included).
    searched : TargetSpec
        The targets the search model was asked to meet in this round.
    search : Evaluation
        The round's best design as the search model scores it (against ``searched``).
    check : Evaluation
        The same design as the checking model scores it (against the wanted targets).
    factors : dict
        ``"<stage>.<quantity>"`` → search/check ratio of this design: the wanted value is
        multiplied by it to give the next round's target.
    evaluations : int
        Search-model evaluations of the round.
    wall_time : float
        Seconds, search and check.
    """

    index: int
    wanted: TargetSpec
    searched: TargetSpec
    search: Evaluation
    check: Evaluation
    factors: dict[str, float]
    evaluations: int
    wall_time: float

    def to_dict(self) -> dict[str, Any]:
        stages = []
        for want, sought, s, c in zip(self.wanted.stages, self.searched.stages,
                                      self.search.stages, self.check.stages, strict=True):
            stages.append({
                "name": want.name, "kind": want.kind,
                "wanted": {"start_pressure": want.start_pressure,
                           "end_pressure": want.end_pressure, "magnitude": abs(want.magnitude)},
                "searched_for": {"start_pressure": sought.start_pressure,
                                 "end_pressure": sought.end_pressure,
                                 "magnitude": abs(sought.magnitude)},
                "search_model": {"start_pressure": s.start, "end_pressure": s.end,
                                 "magnitude": s.magnitude},
                "check_model": {"start_pressure": c.start, "end_pressure": c.end,
                                "magnitude": c.magnitude},
                "cells": c.n_cells})
        return {"round": self.index, "meets_targets": bool(self.check.meets),
                "objective_search": self.search.objective,
                "objective_check": self.check.objective, "factors": dict(self.factors),
                "evaluations": self.evaluations, "wall_time": self.wall_time,
                "stages": stages}


def shift_target(wanted: TargetSpec, search: Evaluation, check: Evaluation,
                 ) -> tuple[TargetSpec, dict[str, float]]:
    """The targets of the next round: each wanted value times the search/check ratio of the
    current design (clipped to :data:`FACTOR_RANGE`; a pressure either model does not reach
    takes the stage's other pressure ratio, 1 when neither is known).
    Completion pressures stay below the supply pressure (a search target above it would be
    refused as unreachable)."""
    pmax = wanted.constraints.max_pressure
    stages = []
    factors: dict[str, float] = {}
    for stage, s, c in zip(wanted.stages, search.stages, check.stages, strict=True):
        raw = {q: _ratio(sv, cv) for q, sv, cv in (
            ("start_pressure", s.start, c.start), ("end_pressure", s.end, c.end),
            ("magnitude", s.magnitude, c.magnitude))}
        # a pressure one model does not reach (beyond max_pressure) borrows the stage's
        # other pressure ratio: both move with the cell's stiffness
        if raw["end_pressure"] is None:
            raw["end_pressure"] = raw["start_pressure"]
        if raw["start_pressure"] is None:
            raw["start_pressure"] = raw["end_pressure"]
        f = {}
        for q, ratio in raw.items():
            f[q] = 1.0 if ratio is None else min(max(ratio, FACTOR_RANGE[0]), FACTOR_RANGE[1])
            factors[f"{stage.name}.{q}"] = f[q]
        end = min(stage.end_pressure * f["end_pressure"], 0.98 * pmax)
        start = (None if stage.start_pressure is None
                 else min(stage.start_pressure * f["start_pressure"], end))
        stages.append(replace(stage, start_pressure=start, end_pressure=end,
                              magnitude=stage.magnitude * f["magnitude"]))
    return replace(wanted, stages=tuple(stages)), factors


def _ratio(search: float | None, check: float | None) -> float | None:
    if search is None or check is None or not (search > 0 and check > 0):
        return None
    r = search / check
    return r if math.isfinite(r) else None


def model_checker(model: Any) -> Checker:
    """A checker that scores designs with a batch model (e.g. the exact calibrated model),
    all designs in one call, each with the cell counts the search chose."""

    def check(target: TargetSpec, evs: Sequence[Evaluation]) -> list[Evaluation]:
        cells = [c for e in evs for c in e.candidate.cells]
        if not cells:
            return []
        out = list(model(cells, target.constraints.max_pressure))
        n = len(target.stages)
        return [evaluate_one(target, e.candidate, out[k * n:(k + 1) * n],
                             fixed_cells=[s.n_cells for s in e.stages])
                for k, e in enumerate(evs)]

    return check


def mapped_design(target: TargetSpec, *, search_model: Any, check: Checker,
                  settings: DesignSettings | None = None, rounds: int = 3,
                  round_budget: float = 0.4, progress: Progress | None = None,
                  boxes: Any = None, radius: float = 0.15, checked: int = 8,
                  ) -> DesignResult:
    """Search on ``search_model``, check on ``check``, correct the targets, search again.

    Parameters
    ----------
    target : TargetSpec
        As wanted (graded here when ``settings.graded``; the rounds search the parts).
    search_model : BatchModel
        The fast model of the searches.
    check : Checker
        Scores designs in the accurate model (:func:`model_checker`, or the device FE).
    settings : DesignSettings
        Of the first search; later rounds get ``round_budget`` × its budget, a warm start
        from the best design so far and the next seed.
    rounds : int
        Corrections at most (0: one search whose designs are only re-scored by ``check``).
    progress : callable, optional
        ``progress(done, total, phase)`` of every search.
    boxes : dict, optional
        The calibrated boxes the search keeps to (reported in an explanation's bounds).
    radius : float
        Trust region of the later rounds: ± this much of every unit coordinate around
        the best checked design so far (the correction holds near it).
    checked : int
        Distinct designs of each search scored by ``check`` (the best of them is kept).

    Returns
    -------
    DesignResult
        Ranked designs as the *checking* model scores them (the search's best designs of
        every round), ``feasible`` when the best one meets the wanted targets there,
        ``rounds`` with every round's record.
    """
    settings = settings or DesignSettings()
    t0 = time.perf_counter()
    searched = graded_target(target, settings.graded_ratio) if settings.graded else target
    wanted_whole = target if searched is not target else None
    plain = replace(settings, graded=False)
    goal = searched
    x0 = None
    records: list[MappingRound] = []
    checked_all: list[Evaluation] = []
    evaluations = calls = 0
    history: list[float] = []
    last: DesignResult | None = None
    n_check = max(1, int(checked))
    incumbent: tuple[Evaluation, Evaluation] | None = None   # (search, check) of the best
    for k in range(rounds + 1):
        t1 = time.perf_counter()
        st = replace(plain, top=max(settings.top, n_check))
        if k > 0:
            st = replace(st, budget=max(1, int(settings.budget * round_budget)),
                         seed=settings.seed + k)

        def tell(done: int, total: int, phase: str, _k: int = k) -> None:
            if progress is not None:
                progress(done, total, phase if _k == 0 else f"round {_k}: {phase}")

        res = design(goal, model=search_model, settings=st, progress=tell, x0=x0,
                     radius=None if x0 is None else radius)
        last = res
        evaluations += res.evaluations
        calls += res.model_calls
        history.extend(res.history)
        if res.best is None:          # refused up front (static bounds, reachability)
            break
        scored = check(searched, res.designs[:n_check])
        checked_all.extend(scored)
        j = min(range(len(scored)), key=lambda i: scored[i].objective)
        if incumbent is None or scored[j].objective < incumbent[1].objective:
            incumbent = (_rescore(searched, res.designs[j]), scored[j])
        # the next targets: corrected at the best checked design so far, searched near it
        nxt, factors = shift_target(searched, *incumbent)
        records.append(MappingRound(k, searched, goal, res.designs[j], scored[j], factors,
                                    res.evaluations, time.perf_counter() - t1))
        if progress is not None:
            progress(evaluations, evaluations, f"round {k} checked: "
                     + ("meets the targets" if scored[j].meets
                        else f"objective {scored[j].objective:.3g}"))
        if incumbent[1].meets:
            break
        goal, x0 = nxt, incumbent[1].candidate.x
    assert last is not None
    if not checked_all:               # nothing searched: the refusal stands as it is
        return replace(last, target=searched, wanted=wanted_whole,
                       wall_time=time.perf_counter() - t0)
    ranked: list[Evaluation] = []
    seen: set[bytes] = set()
    for e in sorted(checked_all, key=lambda e: e.objective):
        key = e.candidate.x.round(6).tobytes()
        if key not in seen:
            seen.add(key)
            ranked.append(e)
    ranked = ranked[:settings.top]
    best = ranked[0]
    space = SearchSpace(searched, boxes=boxes)
    explanation = [] if best.meets else _explain(space, best)
    return DesignResult(searched, settings, bool(best.meets), ranked, explanation,
                        last.reachable, evaluations, calls, history,
                        time.perf_counter() - t0, {}, last.gradient_steps,
                        wanted=wanted_whole, rounds=tuple(records))


def _rescore(target: TargetSpec, ev: Evaluation) -> Evaluation:
    """A search-model evaluation scored against ``target`` with its own cell counts."""
    return evaluate_one(target, ev.candidate, ev.responses,
                        fixed_cells=[s.n_cells for s in ev.stages])
