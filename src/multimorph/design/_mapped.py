"""Space mapping: search on a fast model, check on an accurate one, correct, search again.

A search model s(x) (cheap: the calibrated model on emulated Ritz features, thousands of
curves a second) and a checking model c(x) (accurate and slower: the calibrated model on
exact Ritz features, or the 3D FE of the whole device) differ by a bias that is smooth in
the design and mostly multiplicative. Output space mapping: with x_k the best checked
design so far, round k + 1 searches on the corrected model

    s̃(x) = s(x) · c(x_k) / s(x_k)

per stage and quantity (Pc, Ph, motion), everything scored on s̃ — the distances to the
targets and the stage order and separations alike — within a trust region around x_k
(seeded into the population), and its best designs are checked again. The rounds stop
when the best checked design meets the targets, or after ``rounds`` corrections. Every
round is kept: the correction it searched with, what the search model and the checking
model say of its best design, and the correction for the next.

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
    design,
    explain_design,
)
from multimorph.design._space import SearchSpace
from multimorph.design._target import TargetSpec, graded_target

__all__ = ["Checker", "MappingRound", "correction_factors", "flat_factors", "mapped_design",
           "model_checker", "polish_stages", "rescore", "screen_cells", "screen_stage"]

#: ``check(target, evaluations) -> evaluations``: the same designs (candidates and cell
#: counts) scored against ``target`` by the checking model.
Checker = Callable[[TargetSpec, Sequence[Evaluation]], list[Evaluation]]
#: Bounds of one correction factor of a pressure (a model that misses by more than 2 × is
#: not corrected in one step).
FACTOR_RANGE = (0.5, 2.0)
#: Bounds of one correction factor of a motion. Wider than the pressures': a module's
#: motion at its Ph is the product of its cells' motion and the pressure it is read at,
#: and the twist of a tilted cell is known only to a factor (the calibrated strip shear's
#: leave-one-out scatter is 24 / 65 %, median / p90). The gripper target's twister, four
#: FE rounds in stop 35, twisted 2.26-2.61 × the model's angle at a matched Ph every
#: round; clipped at 2, the correction could never reach the wanted 90° (117-216° in FE).
MAGNITUDE_FACTOR_RANGE = (1.0 / 3.0, 3.0)
QUANTITIES = ("start_pressure", "end_pressure", "magnitude")
#: Designs a search returns to pick the checked ones from (see ``_diverse``).
POOL = 64
#: Where a pressure a model does not reach below max_pressure is put (× it).
BEYOND = 1.1
#: Model calls (each one batch of ≤ 16 probe cells) of the compass polish after the
#: rounds (:func:`polish_stages`): an evaluation budget, so that a design is the same on
#: every machine. Until stop 39 the polish ran for 20 s of wall time; on the 2-core
#: machine that was 29 calls of the calibrated model (about 0.7 s a call), and the jar
#: lifter's seed 3 ended in a different place on another machine.
POLISH_CALLS = 30
#: Wall-time cap of the polish (seconds), a guard only: the budget is POLISH_CALLS.
POLISH_SECONDS = 120.0

Correction = tuple[dict[str, float], ...]


@dataclass(frozen=True, eq=False)
class MappingRound:
    """One round of a space-mapped design (model vs model, or model vs device FE).

    Attributes
    ----------
    index : int
        0 for the first search, then 1, 2, …
    wanted : TargetSpec
        The targets (graded parts included).
    correction : tuple of dict or None
        The factors the round's search applied to its model (``None``: none).
    search : Evaluation
        The round's best design as the search model scores it, uncorrected.
    check : Evaluation
        The same design as the checking model scores it.
    factors : dict
        ``"<stage>.<quantity>"`` → check/search ratio at the round's design (FE in the
        loop since stop 34; model-vs-model mapping: at the best checked design so far):
        the correction of the next round.
    evaluations : int
        Search-model evaluations of the round.
    wall_time : float
        Seconds, search and check.
    screened : tuple of dict
        FE in the loop: the other cells of the stage FE missed most that the round also
        checked in FE (``_pipeline._screen_stage``): per cell, the stage, its FE Pc, Ph
        and motion, and whether it replaced the search's cell in the round's design.
    """

    index: int
    wanted: TargetSpec
    correction: Correction | None
    search: Evaluation
    check: Evaluation
    factors: dict[str, float]
    evaluations: int
    wall_time: float
    screened: tuple[dict[str, Any], ...] = ()

    def to_dict(self) -> dict[str, Any]:
        stages = []
        for i, (want, s, c) in enumerate(zip(self.wanted.stages, self.search.stages,
                                             self.check.stages, strict=True)):
            stages.append({
                "name": want.name, "kind": want.kind,
                "wanted": {"start_pressure": want.start_pressure,
                           "end_pressure": want.end_pressure, "magnitude": abs(want.magnitude)},
                "correction": None if self.correction is None else dict(self.correction[i]),
                "search_model": {"start_pressure": s.start, "end_pressure": s.end,
                                 "magnitude": s.magnitude},
                "check_model": {"start_pressure": c.start, "end_pressure": c.end,
                                "magnitude": c.magnitude},
                "cells": c.n_cells})
        out = {"round": self.index, "meets_targets": bool(self.check.meets),
               "objective_search": self.search.objective,
               "objective_check": self.check.objective, "factors": dict(self.factors),
               "evaluations": self.evaluations, "wall_time": self.wall_time,
               "stages": stages}
        if self.screened:
            out["screened"] = [dict(s) for s in self.screened]
        return out


def correction_factors(search: Evaluation, check: Evaluation, p_max: float,
                       ) -> Correction:
    """Per stage, the check/search ratio of Pc, Ph and motion of one design (clipped to
    :data:`FACTOR_RANGE`, the motion to :data:`MAGNITUDE_FACTOR_RANGE`). A pressure one model
    does not reach below ``p_max`` (while that model's stage also moves less: it is stiffer, and
    its path did reach ``p_max``: a path that stopped early says nothing above it) is taken at
    :data:`BEYOND` × ``p_max``; where the ratio is not known, the stage's other pressure ratio
    is used (both move with the cell's stiffness), else 1.
    """
    out = []
    for s, c in zip(search.stages, check.stages, strict=True):
        raw: dict[str, float | None] = {}
        # a pressure the checking model lacks is beyond p_max only when the stage also moves
        # less there (it is stiffer); a stage that moves as much or more without a knee
        # says nothing about the ratio
        stiffer = c.magnitude < s.magnitude
        # a path that stopped below max_pressure (an FE run that stalled, a model whose
        # support ends) says nothing about what lies above it
        c_whole = c.traced_to is None or c.traced_to >= 0.98 * p_max
        s_whole = s.traced_to is None or s.traced_to >= 0.98 * p_max
        for q, sv, cv in (("start_pressure", s.start, c.start),
                          ("end_pressure", s.end, c.end)):
            if (sv is None and cv is None) or (cv is None and (not stiffer or not c_whole)) or (
                    sv is None and (stiffer or not s_whole)):
                raw[q] = None
            else:
                raw[q] = _ratio(BEYOND * p_max if cv is None else cv,
                                BEYOND * p_max if sv is None else sv)
        if raw["end_pressure"] is None:
            raw["end_pressure"] = raw["start_pressure"]
        if raw["start_pressure"] is None:
            raw["start_pressure"] = raw["end_pressure"]
        raw["magnitude"] = _ratio(c.magnitude, s.magnitude)
        out.append({q: 1.0 if v is None else min(max(v, bounds[0]), bounds[1])
                    for q, v in raw.items()
                    for bounds in [MAGNITUDE_FACTOR_RANGE if q == "magnitude"
                                   else FACTOR_RANGE]})
    return tuple(out)


def flat_factors(wanted: TargetSpec, correction: Correction) -> dict[str, float]:
    return {f"{stage.name}.{q}": f[q] for stage, f in zip(wanted.stages, correction,
                                                         strict=True) for q in QUANTITIES}


def _ratio(num: float | None, den: float | None) -> float | None:
    if num is None or den is None or not (num > 0 and den > 0):
        return None
    r = num / den
    return r if math.isfinite(r) else None


def model_checker(model: Any, correction: Correction | None = None) -> Checker:
    """A checker that scores designs with a batch model (e.g. the exact calibrated model),
    all designs in one call, each with the cell counts the search chose; ``correction``
    (e.g. FE/model factors) applied to the model's values, and then the stages must also
    come in order on the model's own values (``model_order`` of :func:`evaluate_one`)."""

    def check(target: TargetSpec, evs: Sequence[Evaluation]) -> list[Evaluation]:
        cells = [c for e in evs for c in e.candidate.model_cells(model)]
        if not cells:
            return []
        from multimorph.design._space import trace_pmax

        out = list(model(cells, trace_pmax(target.constraints.max_pressure, correction)))
        n = len(target.stages)
        return [evaluate_one(target, e.candidate, out[k * n:(k + 1) * n],
                             fixed_cells=[s.n_cells for s in e.stages], correction=correction,
                             model_order=True)
                for k, e in enumerate(evs)]

    return check


def mapped_design(target: TargetSpec, *, search_model: Any, check: Checker,
                  settings: DesignSettings | None = None, rounds: int = 3,
                  round_budget: float = 0.4, progress: Progress | None = None,
                  boxes: Any = None, radius: float = 0.15, checked: int = 8,
                  x0: Any = None, correction: Correction | None = None,
                  polish_model: Any = None, polish_seconds: float = POLISH_SECONDS,
                  polish_calls: int | None = POLISH_CALLS,
                  model_order: bool = False) -> DesignResult:
    """Search on ``search_model``, check on ``check``, correct the model, search again.

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
        from the best checked design and the next seed.
    rounds : int
        Corrections at most (0: one search whose designs are only re-scored by ``check``).
    progress : callable, optional
        ``progress(done, total, phase)`` of every search.
    boxes : dict, optional
        The calibrated boxes the search keeps to (reported in an explanation's bounds).
    radius : float
        Trust region of the corrected rounds: ± this much of every unit coordinate around
        the best checked design so far (the correction holds near it).
    checked : int
        Distinct designs of each search scored by ``check`` (the best of them is kept).
    x0, correction
        Start the first search from the design ``x0`` (within ``radius``) with this
        correction of the search model (a search that corrects an earlier design: FE in
        the loop).
    polish_model, polish_seconds, polish_calls
        When the rounds end without meeting the targets: a compass search directly on this
        batch model (the checking model's own: e.g. the calibrated model) from the best
        checked design, one stage at a time, worst stage first — each probe changes one
        stage's cell, so it costs one cell — for at most ``polish_calls`` model calls
        (:data:`POLISH_CALLS`) and ``polish_seconds``.
    model_order : bool
        The searches keep the stages in order on the search model's own Pc too, where they
        correct it (FE in the loop; :func:`design`).

    Returns
    -------
    DesignResult
        Ranked designs as the *checking* model scores them (the checked designs of every
        round), ``feasible`` when the best one meets the targets there, ``rounds`` with
        every round's record.
    """
    settings = settings or DesignSettings()
    t0 = time.perf_counter()
    searched = graded_target(target, settings.graded_ratio) if settings.graded else target
    wanted_whole = target if searched is not target else None
    pmax = searched.constraints.max_pressure
    plain = replace(settings, graded=False)
    records: list[MappingRound] = []
    checked_all: list[Evaluation] = []
    evaluations = calls = 0
    history: list[float] = []
    last: DesignResult | None = None
    n_check = max(1, int(checked))
    incumbent: tuple[Evaluation, Evaluation] | None = None   # (search raw, check) of the best
    for k in range(rounds + 1):
        t1 = time.perf_counter()
        st = replace(plain, top=max(settings.top, POOL))
        if k > 0:
            st = replace(st, budget=max(1, int(settings.budget * round_budget)),
                         seed=settings.seed + k)

        def tell(done: int, total: int, phase: str, _k: int = k) -> None:
            if progress is not None:
                progress(done, total, phase if _k == 0 else f"round {_k}: {phase}")

        res = design(searched, model=search_model, settings=st, progress=tell, x0=x0,
                     radius=None if x0 is None else radius, correction=correction,
                     model_order=model_order)
        last = res
        evaluations += res.evaluations
        calls += res.model_calls
        history.extend(res.history)
        if res.best is None:          # refused up front (static bounds, reachability)
            break
        cands = _diverse(searched, res.designs, n_check, search_model, boxes)
        scored = check(searched, cands)
        # the stages interact only through the sequence constraints: join each stage's
        # best checked cell into one more design and check it too
        joined = _join_stages(searched, cands, scored, search_model, boxes)
        if joined is not None:
            cands.append(joined)
            scored += check(searched, [joined])
        checked_all.extend(scored)
        j = min(range(len(scored)), key=lambda i: scored[i].objective)
        raw = rescore(searched, cands[j])
        if incumbent is None or scored[j].objective < incumbent[1].objective:
            incumbent = (raw, scored[j])
        # the next correction: check/search at the best checked design so far, near which
        # the next round searches
        nxt = correction_factors(*incumbent, pmax)
        records.append(MappingRound(k, searched, correction, raw, scored[j],
                                    flat_factors(searched, nxt), res.evaluations,
                                    time.perf_counter() - t1))
        if progress is not None:
            progress(evaluations, evaluations, f"round {k} checked: "
                     + ("meets the targets" if scored[j].meets
                        else f"objective {scored[j].objective:.3g}"))
        if incumbent[1].meets:
            break
        correction, x0 = nxt, incumbent[1].candidate.x
    assert last is not None
    if (polish_model is not None and incumbent is not None and not incumbent[1].meets
            and polish_seconds > 0):
        # first another kind of cell for the stage the checking model misses most, then
        # the compass polish from the better of the two; ``correction`` is the last
        # round's next one, read at the incumbent
        start = screen_stage(searched, incumbent[0], incumbent[1], list(last.designs),
                             search_model, polish_model,
                             correction=correction, boxes=boxes,
                             seed=settings.seed, seen=checked_all)
        if progress is not None:
            progress(0, 0, f"screening: objective {start.objective:.3g}")
        if start is not incumbent[1]:
            checked_all.append(start)
        polished = polish_stages(searched, start, polish_model, boxes=boxes,
                                 seconds=polish_seconds, calls=polish_calls,
                                 progress=progress)
        if polished.objective < incumbent[1].objective:
            checked_all.append(polished)
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
    pool = tuple(ranked)
    ranked = ranked[:settings.top]
    best = ranked[0]
    space = SearchSpace(searched, boxes=boxes)
    explanation = [] if best.meets else explain_design(space, best)
    return DesignResult(searched, settings, bool(best.meets), ranked, explanation,
                        last.reachable, evaluations, calls, history,
                        time.perf_counter() - t0, {}, last.gradient_steps,
                        wanted=wanted_whole, rounds=tuple(records), pool=pool)


def _diverse(target: TargetSpec, pool: Sequence[Evaluation], k: int, search_model: Any,
             boxes: Any) -> list[Evaluation]:
    """``k`` designs to check: the search's best, then designs joining each stage's next
    best distinct cell in the search model (ranked by :func:`stage_score`), so that a cell
    the checking model contradicts is not the only one checked for its stage."""
    import numpy as np

    from multimorph.design._optimise import evaluate_population
    from multimorph.design._space import N_VARS

    pool = list(pool)
    S = len(target.stages)
    if len(pool) <= 1 or k <= 1 or S < 2:
        return pool[:k]
    slices: list[list[np.ndarray]] = []
    counts: list[list[int]] = []
    for i in range(S):
        ranked = sorted(range(len(pool)), key=lambda j, _i=i: stage_score(pool[j], _i, target))
        seen: set[bytes] = set()
        xs, ns = [], []
        for j in ranked:
            z = pool[j].candidate.x[i * N_VARS:(i + 1) * N_VARS]
            key = np.round(z, 2).tobytes()
            if key in seen:
                continue
            seen.add(key)
            xs.append(z)
            ns.append(pool[j].stages[i].n_cells)
            if len(xs) >= k - 1:
                break
        slices.append(xs)
        counts.append(ns)
    m = min(len(xs) for xs in slices)
    if m == 0:
        return pool[:k]
    X = np.array([np.concatenate([slices[i][r] for i in range(S)]) for r in range(m)])
    evs = evaluate_population(SearchSpace(target, boxes=boxes), X, search_model)
    joined = [evaluate_one(target, e.candidate, e.responses,
                           fixed_cells=[counts[i][r] for i in range(S)])
              for r, e in enumerate(evs)]
    return [pool[0], *joined][:k]


def polish_stages(target: TargetSpec, start: Evaluation, model: Any, *, boxes: Any = None,
                  seconds: float = POLISH_SECONDS, calls: int | None = POLISH_CALLS,
                  step: float = 0.04, min_step: float = 0.004,
                  progress: Progress | None = None) -> Evaluation:
    """Compass search on ``model`` itself from ``start``, one stage's cell at a time.

    Stages are taken worst first (:func:`stage_score`); for each, the continuous
    coordinates of its cell are probed ± ``step`` (one batched call of 2 × 8 cells; the
    other stages keep their responses), the best improvement of the whole design's
    objective is taken, else the step is halved, down to ``min_step``. Stops when the design
    meets the targets, after ``calls`` model calls (``None``: no budget) or after
    ``seconds``.
    """
    import numpy as np

    from multimorph.design._space import N_VARS

    t_end = time.perf_counter() + seconds
    space = SearchSpace(target, boxes=boxes)
    pmax = target.constraints.max_pressure
    best = start
    S = len(target.stages)
    order = sorted(range(S), key=lambda i: -stage_score(start, i, target))
    cont = (0, 1, 2, 3, 4, 5, 6, 9)
    used = 0

    def spent() -> bool:
        return time.perf_counter() > t_end or (calls is not None and used >= calls)

    for i in order:
        if best.meets or spent():
            break
        if stage_score(best, i, target) <= 1e-9:
            continue
        h = step
        while h >= min_step and not spent() and not best.meets:
            x = np.asarray(best.candidate.x, float)
            probes = []
            for j in cont:
                for sgn in (1.0, -1.0):
                    z = x.copy()
                    k = i * N_VARS + j
                    z[k] = min(max(z[k] + sgn * h, 0.0), 1.0)
                    if z[k] != x[k]:
                        probes.append(z)
            cands = [space.decode(z) for z in probes]
            out = list(model([c.model_cells(model)[i] for c in cands], pmax))
            used += 1
            trial = []
            for cand, r in zip(cands, out, strict=True):
                resps = list(best.responses)
                resps[i] = r
                # cell counts chosen afresh from the model's motion per cell
                trial.append(evaluate_one(target, cand, resps))
            k = min(range(len(trial)), key=lambda m: trial[m].objective)
            if trial[k].objective < best.objective - 1e-12:
                best = trial[k]
            else:
                h *= 0.5
        if progress is not None:
            progress(0, 0, f"polish: stage {target.stages[i].name}, objective "
                     f"{best.objective:.3g}")
    return best


#: Two cells of a stage closer than this (unit coordinates, any variable) are one cell to
#: the screenings (:func:`screen_cells`: FE in the loop, ``_pipeline._screen_stage``, and
#: the checking model's, :func:`screen_stage`).
SCREEN_DISTANCE = 0.03
#: Random cells of the screened stage scored on the search model (one batched call).
SCREEN_SAMPLES = 2048
#: The best scored cells the screening picks the most different ones from.
SCREEN_SHORTLIST = 32


def screen_cells(target: TargetSpec, pool: Sequence[Evaluation], mine: Evaluation, i: int,
                 model: Any, space: Any, correction: Any, n: int, seen: list[Any],
                 seed: int) -> list[tuple[Any, int]]:
    """Up to ``n`` cells of stage ``i`` to screen, with their counts. The candidates: the
    stage's cells in ``pool`` and :data:`SCREEN_SAMPLES` random cells of the stage in the
    design ``mine`` (scored on ``model``, whose responses ``mine`` holds, with
    ``correction``), ranked by :func:`stage_score`. The best scored
    first, then each the farthest (largest least ∞-distance in unit coordinates) from
    ``seen`` and the picks so far among the :data:`SCREEN_SHORTLIST` best; none within
    :data:`SCREEN_DISTANCE` of ``seen`` (extended with the picks)."""
    import numpy as np

    from multimorph.design._space import N_VARS, trace_pmax

    cut = slice(i * N_VARS, (i + 1) * N_VARS)
    cells: list[tuple[float, Any, int]] = []
    for d in pool:
        cells.append((stage_score(d, i, target), np.asarray(d.candidate.x, float)[cut],
                      d.stages[i].n_cells))
    rng = np.random.default_rng(seed)
    X = np.repeat(np.asarray(mine.candidate.x, float)[None, :], SCREEN_SAMPLES, axis=0)
    X[:, cut] = rng.random((SCREEN_SAMPLES, N_VARS))
    cands = [space.decode(x) for x in X]
    out = list(model([c.model_cells(model)[i] for c in cands],
                     trace_pmax(target.constraints.max_pressure, correction)))
    resps = list(mine.responses)
    for cand, r, x in zip(cands, out, X, strict=True):
        resps[i] = r
        ev = evaluate_one(target, cand, resps, correction=correction)
        cells.append((stage_score(ev, i, target), x[cut], ev.stages[i].n_cells))
    cells.sort(key=lambda c: c[0])

    def gap(z: Any, others: list[Any]) -> float:
        return min((float(np.max(np.abs(z - w))) for w in others), default=np.inf)

    picks: list[tuple[Any, int]] = []
    first = next((c for c in cells if gap(c[1], seen) >= SCREEN_DISTANCE), None)
    if first is None or n <= 0:
        return picks
    picks.append((first[1], first[2]))
    seen.append(first[1].copy())
    short = [c for c in cells if gap(c[1], seen) >= SCREEN_DISTANCE][:SCREEN_SHORTLIST]
    while len(picks) < n and short:
        far = max(short, key=lambda c: gap(c[1], seen))
        if gap(far[1], seen) < SCREEN_DISTANCE:
            break
        picks.append((far[1], far[2]))
        seen.append(far[1].copy())
        short = [c for c in short if c is not far]
    return picks


#: Cells of the checking model's screening (:func:`screen_stage`): one model call.
SCREEN_MODEL_CELLS = 16


def screen_stage(target: TargetSpec, search: Evaluation, check: Evaluation,
                 pool: Sequence[Evaluation], search_model: Any, model: Any, *,
                 correction: Correction | None = None, boxes: Any = None,
                 n: int = SCREEN_MODEL_CELLS, seed: int = 0,
                 seen: Sequence[Evaluation] = ()) -> Evaluation:
    """The checked design ``check`` with the cell of the stage it misses most replaced by
    the best of up to ``n`` other cells (:func:`screen_cells`, scored on the search model
    with ``correction``), all checked on ``model`` in one call; ``check`` itself when none
    is better. ``search`` is the same design on the search model.

    Why: where the checking model contradicts the search model qualitatively (stop 40: the
    three-stage twist with a hardening knee on the fast variant and none on the exact
    calibrated model; the jar lifter's lifter, seed 3, a tiny-chamber cell whose motion in
    its band is a third of the fast variant's), a multiplicative correction cannot find
    another kind of cell, and the polish only steps around this one."""
    import numpy as np

    from multimorph.design._space import N_VARS

    S = len(target.stages)
    misses = {i: stage_score(check, i, target) for i in range(S)}
    i = max(misses, key=lambda j: misses[j])
    if misses[i] <= 0.0 or n <= 0:
        return check
    cut = slice(i * N_VARS, (i + 1) * N_VARS)
    base = np.asarray(check.candidate.x, float)
    tried = [base[cut].copy(), *(np.asarray(e.candidate.x, float)[cut] for e in seen)]
    space = SearchSpace(target, boxes=boxes)
    picks = screen_cells(target, pool, search, i, search_model, space, correction, n, tried,
                         seed)
    if not picks:
        return check
    cands = []
    for z, _n_cells in picks:
        x = base.copy()
        x[cut] = z
        cands.append(space.decode(x))
    out = list(model([c.model_cells(model)[i] for c in cands],
                     target.constraints.max_pressure))
    best = check
    for cand, r in zip(cands, out, strict=True):
        resps = list(check.responses)
        resps[i] = r
        ev = evaluate_one(target, cand, resps)      # cell counts from the model's motion
        if ev.objective < best.objective - 1e-12:
            best = ev
    return best


def stage_score(ev: Evaluation, i: int, target: TargetSpec) -> float:
    """How well stage ``i`` of a scored design meets its own targets: the squared distances
    of its quantities, its safety-factor violation, and the penalties for a pressure not
    reached (the objective's terms that belong to that stage alone)."""
    from multimorph.design._evaluate import MISSING_PENALTY

    sr = ev.stages[i]
    name = sr.name
    wanted_start = any(k == f"{name}.start_pressure" for k in ev.distances)
    f = sum(d * d for k, d in ev.distances.items() if k.split(".", 1)[0] == name)
    v = ev.violations.get(f"{name}.safety_factor", 0.0)
    f += (4.0 * max(v, 0.0) / target.tolerance.pressure) ** 2   # as in the objective
    if sr.end is None:
        f += MISSING_PENALTY
    if sr.start is None and (wanted_start or i > 0):
        f += MISSING_PENALTY
    return float(f)


def _join_stages(target: TargetSpec, cands: Sequence[Evaluation],
                 scored: Sequence[Evaluation], search_model: Any,
                 boxes: Any) -> Evaluation | None:
    """A design of each stage's best checked cell (``None`` when that is one of ``cands``),
    as the search model scores it."""
    import numpy as np

    from multimorph.design._optimise import evaluate_population
    from multimorph.design._space import N_VARS

    if len(cands) < 2 or len(target.stages) < 2:
        return None
    picks = [min(range(len(scored)), key=lambda k, _i=i: stage_score(scored[k], _i, target))
             for i in range(len(target.stages))]
    if len(set(picks)) == 1:
        return None
    x = np.concatenate([cands[k].candidate.x[i * N_VARS:(i + 1) * N_VARS]
                        for i, k in enumerate(picks)])
    space = SearchSpace(target, boxes=boxes)
    [ev] = evaluate_population(space, x[None, :], search_model)
    # keep each stage's cell count from the design it came from
    return evaluate_one(target, ev.candidate, ev.responses,
                        fixed_cells=[cands[k].stages[i].n_cells for i, k in enumerate(picks)])


def rescore(target: TargetSpec, ev: Evaluation) -> Evaluation:
    """A model evaluation scored against ``target`` with its own cell counts, uncorrected."""
    return evaluate_one(target, ev.candidate, ev.responses,
                        fixed_cells=[s.n_cells for s in ev.stages])
