"""The optimiser: reachability check, differential evolution over the batched cell model,
then gradient and pattern-search refinement; ranked designs and, when the target cannot be
met, an explanation of the binding constraints.

Global stage: differential evolution (DE/rand/1/bin with dithered F), the whole population
evaluated as one batch of cells (one model call per generation). Gradient stage
(:mod:`multimorph.design._gradient`): bounded Gauss–Newton steps on the best design's
continuous variables, with the Jacobian from implicit-function-theorem sensitivities of the
traced equilibrium paths (:func:`multimorph.rom.path_sensitivity`) carried through the
Pc/Ph estimators and the objective on the linearised paths — no model run and no
differentiation through the tracer; the trial steps of one iteration are one batched call.
Skipped for cell models without generalised coordinates. Local stage: a derivative-free
compass (pattern) search around the result (material choices held), all 2·n probes of a
step evaluated as one batch. See ``docs/design.md``.

Everything is seeded (``numpy.random.default_rng(seed)``): the same target, settings and
model give the same designs.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from multimorph.design._evaluate import Evaluation, evaluate_candidates, support_sigma
from multimorph.design._gradient import GradientStep, gradient_refine
from multimorph.design._models import BatchModel, CountingModel, rom_batch_model
from multimorph.design._space import N_VARS, VAR_NAMES, SearchSpace
from multimorph.design._target import GRADED_RATIO, TargetSpec, graded_target
from multimorph.errors import SpecError

__all__ = ["DesignResult", "DesignSettings", "design", "evaluate_population", "explain_design"]

Progress = Callable[[int, int, str], None]


@dataclass(frozen=True)
class DesignSettings:
    """Optimiser settings.

    Parameters
    ----------
    budget : int
        Cell-model evaluations for the whole search (designs × stages), reachability check
        and refinement included.
    population : int
        Differential-evolution population size.
    seed : int
    refine_fraction : float
        Share of the budget kept for the local refinement.
    top : int
        Number of ranked designs returned.
    robust_samples : int
        Robust objective: Monte Carlo samples per shortlisted design (0: nominal ranking).
    robust_shortlist : int
        Designs re-ranked by the robust objective.
    wall_tolerance, default_cv : float
        Uncertainty model of the robust objective (see :func:`multimorph.design.robustness`).
    batch_cells : int, optional
        Cells per batched model call (one compiled shape); default population × stages.
    gradient : bool
        Refine the best global design by bounded Gauss–Newton steps on IFT gradients through
        the traced equilibrium paths (before the compass search, within the refinement
        budget). Needs a cell model with sensitivities (the reduced model); skipped
        otherwise.
    gradient_iterations : int
        Gradient iterations at most (each: one Jacobian, no model call, and one batched call
        of ``len(dampings)`` trial designs).
    graded : bool
        Realise a stage whose band is wider than ``graded_ratio`` (Ph/Pc) by graded modules
        in series (:func:`multimorph.design.graded_target`); ``False`` asks one module of
        identical cells to span it.
    graded_ratio : float
        Widest band end/start of one module when grading.
    stagewise : bool
        Before the joint search, search each stage's cell alone against its own targets
        (scipy's differential evolution on its 10 coordinates, one cell per design), and
        start the joint search from combinations of the stages' best cells. The stages
        interact only through the sequence constraints and the device length, so this
        finds every stage's region at a fraction of the joint search's cost.
    stage_fraction : float
        Share of the global budget spent on the stage-by-stage searches.
    """

    budget: int = 1200
    population: int = 24
    seed: int = 0
    refine_fraction: float = 0.3
    top: int = 5
    robust_samples: int = 0
    robust_shortlist: int = 4
    wall_tolerance: float = 0.1e-3
    default_cv: float = 0.05
    batch_cells: int | None = None
    gradient: bool = True
    gradient_iterations: int = 12
    graded: bool = True
    graded_ratio: float = GRADED_RATIO
    stagewise: bool = True
    stage_fraction: float = 0.5

    def __post_init__(self) -> None:
        if self.population < 4:
            raise SpecError(f"population must be at least 4, got {self.population}")
        if self.budget < 1:
            raise SpecError(f"budget must be positive, got {self.budget}")
        if not 0 <= self.refine_fraction < 1:
            raise SpecError(f"refine_fraction must lie in [0, 1), got {self.refine_fraction}")
        if not self.graded_ratio > 1.0:
            raise SpecError(f"graded_ratio must exceed 1, got {self.graded_ratio}")
        if self.gradient_iterations < 0:
            raise SpecError(f"gradient_iterations must be non-negative, got "
                            f"{self.gradient_iterations}")


@dataclass(frozen=True, eq=False)
class DesignResult:
    """What :func:`design` found.

    Attributes
    ----------
    feasible : bool
        The best design meets every target within tolerance and every constraint.
    designs : list of Evaluation
        Ranked, best first (may be empty when the target is infeasible up front).
    explanation : list of str
        Why the target cannot be met (binding constraints), empty when feasible.
    reachable : dict
        Per stage, the completion pressures of the softest and stiffest corner designs.
    evaluations : int
        Cell-model evaluations used.
    history : list of float
        Best objective after each model call.
    gradient_steps : tuple of GradientStep
        Log of the gradient refinement (empty when skipped).
    wanted : TargetSpec or None
        The target as written when some of its stages were graded (``target`` then holds
        the parts that were searched); ``None`` when nothing was graded.
    """

    target: TargetSpec
    settings: DesignSettings
    feasible: bool
    designs: list[Evaluation]
    explanation: list[str]
    reachable: dict[str, Any]
    evaluations: int
    model_calls: int
    history: list[float]
    wall_time: float
    robust_scores: dict[int, float] = field(default_factory=dict)
    gradient_steps: tuple[GradientStep, ...] = ()
    wanted: TargetSpec | None = None
    rounds: tuple[Any, ...] = ()
    """Space-mapping rounds (:class:`multimorph.design.MappingRound`) when the designs were
    searched on a fast model and scored on an accurate one; empty otherwise."""
    fe_rounds: tuple[Any, ...] = ()
    """FE in the loop: per round the best design as the model and as the device FE score
    it (:class:`multimorph.design.MappingRound`, ``check`` the FE); empty without FE."""
    fe_best: Evaluation | None = None
    """The FE evaluation of the best FE-checked design (``designs[0]``), if any."""
    fe_route: str | None = None
    """How FE inflated the designs (:data:`multimorph.design.FE_ROUTES`); ``None``: no FE."""
    fe_twist: str | None = None
    """How the ``modules`` route inflated twisting modules
    (:data:`multimorph.design.TWIST_ROUTES`); ``None``: no module FE."""
    pool: tuple[Evaluation, ...] = ()
    """Space mapping: every distinct design the checking model scored, ranked (``designs``
    is its head); the FE screening picks other cells of a stage from it. Empty otherwise."""

    @property
    def fe_verified(self) -> bool | None:
        """Whether the device FE meets every target (``None``: no device FE was run)."""
        return None if self.fe_best is None else bool(self.fe_best.meets)

    @property
    def best(self) -> Evaluation | None:
        return self.designs[0] if self.designs else None

    def to_dict(self) -> dict[str, Any]:
        return {
            "target": self.target.name,
            "feasible": self.feasible,
            "explanation": list(self.explanation),
            "reachable": self.reachable,
            "evaluations": self.evaluations,
            "model_calls": self.model_calls,
            "wall_time": self.wall_time,
            "seed": self.settings.seed,
            "budget": self.settings.budget,
            "designs": [d.to_dict() for d in self.designs],
            "gradient": [{"objective_before": step.objective_before,
                          "objective_after": step.objective_after, "trials": step.trials}
                         for step in self.gradient_steps],
            "graded": self.graded_stages(),
            "rounds": [r.to_dict() for r in self.rounds],
            "fe_verified": self.fe_verified,
            "fe_route": self.fe_route,
            "fe_twist": self.fe_twist,
            "fe_rounds": [r.to_dict() for r in self.fe_rounds],
            "fe": None if self.fe_best is None else self.fe_best.to_dict(),
        }

    def graded_stages(self) -> dict[str, Any]:
        """Per graded stage of the wanted target: its parts and, for the best design, the
        stage as a whole (start = first part's Pc, end = last part's Ph, magnitude = sum)
        against what was wanted. Empty when nothing was graded."""
        if self.wanted is None:
            return {}
        out: dict[str, Any] = {}
        best = self.best
        tol = self.target.tolerance
        for whole in self.wanted.stages:
            idx = [i for i, part in enumerate(self.target.stages) if part.part_of == whole.name]
            if not idx:
                continue
            entry: dict[str, Any] = {
                "parts": [self.target.stages[i].name for i in idx],
                "wanted": {"start_pressure": whole.start_pressure,
                           "end_pressure": whole.end_pressure, "magnitude": whole.magnitude}}
            if best is not None:
                srs = [best.stages[i] for i in idx]
                start, end = srs[0].start, srs[-1].end
                mags = [part.magnitude for part in srs]
                mag = None if any(value is None for value in mags) else float(sum(mags))
                ok = (start is not None and end is not None and mag is not None
                      and whole.start_pressure is not None
                      and abs(start / whole.start_pressure - 1) <= tol.pressure
                      and abs(end / whole.end_pressure - 1) <= tol.pressure
                      and abs(mag / abs(whole.magnitude) - 1) <= tol.magnitude)
                entry["predicted"] = {"start_pressure": start, "end_pressure": end,
                                      "magnitude": mag, "met": bool(ok)}
            out[whole.name] = entry
        return out


def evaluate_population(space: SearchSpace, X: np.ndarray, model: Any) -> list[Evaluation]:
    """Decode and score designs ``X`` (shape (n, dim)) with one batched model call."""
    cands = [space.decode(x) for x in np.atleast_2d(X)]
    cells = [c for cand in cands for c in cand.model_cells(model)]
    out = model(cells, space.model_pmax)
    stage_count = space.n_stages
    resps = [out[k * stage_count:(k + 1) * stage_count] for k in range(len(cands))]
    return evaluate_candidates(space, cands, resps)


def _stagewise_start(space: SearchSpace, X: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                     to_local: Callable[[np.ndarray], np.ndarray], model: Any,
                     rng: np.random.Generator, settings: DesignSettings, *, budget: float,
                     progress: Callable[[str], None] | None) -> np.ndarray:
    """The joint search's first population from stage-by-stage searches (see
    ``DesignSettings.stagewise``): row 0 joins every stage's best cell, the other rows
    random picks among each stage's best distinct cells; ``X`` (local coordinates) is
    returned unchanged where a stage search finds nothing."""
    from scipy.optimize import differential_evolution

    t = space.target
    S = space.n_stages
    n = X.shape[0]
    per_stage = max(int(budget // S), 0)
    popsize = 5                                   # × 10 coordinates: 50 cells a generation
    generations = per_stage // (popsize * N_VARS) - 1
    if generations < 2:
        return X
    X = X.copy()
    for i, stage in enumerate(t.stages):
        sub = replace(t, stages=(replace(stage, part_of=None),))
        sub_space = SearchSpace(sub, d_range=space.d_range, min_chamber=space.min_chamber,
                                boxes=space.boxes,
                                correction=None if space.correction is None
                                else (space.correction[i],))
        sl = slice(i * N_VARS, (i + 1) * N_VARS)
        b_lo, b_hi = lo[sl], np.maximum(hi[sl], lo[sl] + 1e-9)
        seen: dict[bytes, tuple[float, np.ndarray]] = {}

        def f(Z: np.ndarray, _space: SearchSpace = sub_space,
              _seen: dict[bytes, tuple[float, np.ndarray]] = seen) -> np.ndarray:
            Z = np.atleast_2d(Z.T)
            evs = evaluate_population(_space, Z, model)
            out = np.array([e.objective for e in evs])
            for z, v in zip(Z, out, strict=True):
                _seen.setdefault(np.round(z, 3).tobytes(), (float(v), z.copy()))
            return out

        differential_evolution(f, list(zip(b_lo, b_hi, strict=True)), popsize=popsize,
                               maxiter=generations, init="latinhypercube", polish=False,
                               vectorized=True, updating="deferred",
                               seed=int(rng.integers(2**31)), tol=0.0, mutation=(0.5, 0.9),
                               recombination=0.8)
        if progress is not None:
            progress(f"stage {stage.name}")
        best = sorted(seen.values(), key=lambda vz: vz[0])[:max(4, n // 2)]
        if not best:
            continue
        picks = [best[0][1]] + [best[int(k)][1] for k in rng.integers(0, len(best), n - 1)]
        for row, z in enumerate(picks):
            full = lo + X[row] * (hi - lo)
            full[sl] = z
            X[row] = to_local(full)
    return X


def _static_checks(space: SearchSpace) -> list[str]:
    t = space.target
    pmax = t.constraints.max_pressure
    out = list(space.check())
    for stage in t.stages:
        if stage.end_pressure > pmax:
            out.append(f"max_pressure binds: stage {stage.name!r} must complete at "
                       f"{stage.end_pressure / 1e3:.4g} kPa, above the supply pressure "
                       f"max_pressure = {pmax / 1e3:.4g} kPa")
    return out


def _reachability(space: SearchSpace, model: Any) -> tuple[dict[str, Any], list[str]]:
    """Evaluate the softest and stiffest corner design of every allowed material."""
    t = space.target
    mats = t.constraints.materials
    tol = t.tolerance.pressure
    stiff_order = sorted(range(len(mats)), key=lambda j: mats[j].shear_modulus)
    stiffest = stiff_order[-1]
    X = [space.corner(stiff=True, material=j, bottom=stiffest) for j in range(len(mats))]
    X += [space.corner(stiff=False, material=j, bottom=stiffest) for j in range(len(mats))]
    evs = evaluate_population(space, np.array(X), model)
    nm = len(mats)
    reach: dict[str, Any] = {}
    reasons: list[str] = []
    for i, stage in enumerate(t.stages):
        stiff = [(evs[j].stages[i].end, mats[j].name) for j in range(nm)]
        soft = [(evs[nm + j].stages[i].end, evs[nm + j].stages[i].start, mats[j].name)
                for j in range(nm)]
        reach[stage.name] = {
            "stiffest_end_pressure": {n: p for p, n in stiff},
            "softest_end_pressure": {n: p for p, _, n in soft},
        }
        # a module whose cells do not activate at all in any allowed material (a
        # stretching or twisting cell of a wall whose membrane does not snap)
        still = [_no_activation(evs[k], i) for k in range(2 * nm)]
        if all(still):
            reasons.append(
                f"stage {stage.name!r} ({stage.kind}) cannot activate: its cells in every "
                f"allowed material stretch or twist without a knee (material "
                f"{mats[0].name!r}: {still[0]}); allow a material whose membrane snaps (a "
                f"Gent fit of the same rubber, or a Yeoh wall of c20/c10 ≤ 0.042)")
            continue
        # too stiff a target: even the stiffest corner of every material completes too early
        if all(p is not None for p, _ in stiff):
            top, name = max(stiff, key=lambda pn: pn[0])
            if top < stage.end_pressure * (1.0 - tol):
                reasons.append(
                    f"stage {stage.name!r} must complete at {stage.end_pressure / 1e3:.4g} kPa, "
                    f"but "
                    f"the stiffest allowed design (material {name!r}, the thickest walls "
                    f"max_width = {t.constraints.max_width * 1e3:.4g} mm and max_height = "
                    f"{t.constraints.max_height * 1e3:.4g} mm allow) completes by "
                    f"{top / 1e3:.4g} kPa: the allowed materials and cell size bind "
                    f"(a stiffer material or a larger cell is needed)")
        # too soft a target: even the softest corner starts/completes too late
        firsts = [(s_ if s_ is not None else (e_ if e_ is not None else math.inf))
                  for e_, s_, _ in soft]
        low = min(firsts)
        name = soft[firsts.index(low)][2]
        if low > stage.end_pressure * (1.0 + tol):
            when = (f"only starts moving at {low / 1e3:.4g} kPa" if math.isfinite(low) else
                    f"does not start moving below max_pressure = "
                    f"{t.constraints.max_pressure / 1e3:.4g} kPa")
            reasons.append(
                f"stage {stage.name!r} must complete at {stage.end_pressure / 1e3:.4g} kPa, but "
                f"the softest allowed design (material {name!r}, every wall at min_wall = "
                f"{t.constraints.min_wall * 1e3:.4g} mm, largest chambers) {when}: min_wall "
                f"and the allowed materials bind (thinner walls or a softer material are "
                f"needed)")
    return reach, reasons


def _no_activation(ev: Evaluation, stage: int) -> str | None:
    """Why the cell model says stage ``stage``'s module of ``ev`` does not activate at all
    (``calibration.activation``), or None."""
    resp = ev.responses[stage] if ev.responses and stage < len(ev.responses) else None
    meta = getattr(resp, "meta", None) or {}
    act = (meta.get("calibration") or {}).get("activation") or {}
    return str(act.get("reason", "no activation")) if act.get("activates") is False else None


def _binding(space: SearchSpace, ev: Evaluation) -> list[str]:
    """Active bounds of a design, named by the constraint that sets them."""
    t = space.target
    c = t.constraints
    out: list[str] = []
    mats = c.materials
    mu = [material.shear_modulus for material in mats]
    for i, stage in enumerate(t.stages):
        u = ev.candidate.x[i * N_VARS:(i + 1) * N_VARS]
        im, ib = ev.candidate.material_index[i]
        act = []
        for j, name in enumerate(VAR_NAMES[:7]):
            if stage.kind == "stretch" and name == "bottom_wall":
                continue
            if name in ("top_wall", "bottom_wall", "side_wall", "end_wall") and u[j] <= 0.02:
                act.append(f"{name} at min_wall {c.min_wall * 1e3:.3g} mm")
            elif name in ("top_wall", "bottom_wall", "side_wall", "end_wall") and u[j] >= 0.98:
                act.append(f"{name} at its largest (chamber at its minimum)")
            elif name == "width" and u[j] >= 0.98:
                act.append(f"width at max_width {c.max_width * 1e3:.3g} mm")
            elif name == "height" and u[j] >= 0.98:
                act.append(f"height at max_height {c.max_height * 1e3:.3g} mm")
        if len(mats) > 1 and mu[im] == max(mu):
            act.append(f"wall material the stiffest allowed ({mats[im].name})")
        if len(mats) > 1 and mu[im] == min(mu):
            act.append(f"wall material the softest allowed ({mats[im].name})")
        sr = ev.stages[i]
        cell = ev.candidate.cells[i]
        if stage.kind != "stretch" and sr.n_cells >= max(1, int(c.max_length // cell.length)):
            act.append(f"cells capped by max_length {c.max_length * 1e3:.4g} mm")
        if act:
            out.append(f"stage {stage.name!r}: " + "; ".join(act))
        del ib
    return out


def explain_design(space: SearchSpace, ev: Evaluation) -> list[str]:
    t = space.target
    out: list[str] = []
    if ev.message:
        out.append(ev.message)
    for key, d in ev.distances.items():
        if abs(d) > 1.0:
            stage, what = key.split(".", 1)
            wanted = next(candidate for candidate in t.stages if candidate.name == stage)
            sr = next(candidate for candidate in ev.stages if candidate.name == stage)
            tolv = t.tolerance.magnitude if what == "magnitude" else t.tolerance.pressure
            rel = d * tolv
            if what == "magnitude":
                unit = "%" if wanted.kind == "stretch" else "deg"
                scale = 100.0 if wanted.kind == "stretch" else math.degrees(1.0)
                label = repr(stage)
                got, want = sr.magnitude * scale, abs(wanted.magnitude) * scale
                if wanted.part_of is not None:        # a graded stage: its parts' sum
                    names = [p.name for p in t.stages if p.part_of == wanted.part_of]
                    label = f"{wanted.part_of!r} ({' + '.join(names)})"
                    got = scale * sum(r.magnitude for r in ev.stages if r.name in names)
                    want = scale * sum(abs(p.magnitude) for p in t.stages if p.name in names)
                out.append(f"stage {label} magnitude {got:.3g} {unit} vs wanted {want:.3g} "
                           f"{unit} ({rel:+.0%}, tolerance ±{tolv:.0%})")
            else:
                want = wanted.end_pressure if what == "end_pressure" else wanted.start_pressure
                got = sr.end if what == "end_pressure" else sr.start
                out.append(f"stage {stage!r} {what.replace('_', ' ')} {got / 1e3:.4g} kPa vs "
                           f"wanted {want / 1e3:.4g} kPa ({rel:+.0%}, tolerance ±{tolv:.0%})")
    kinds = {stage.name: stage.module_kind for stage in t.stages}
    for key, v in ev.violations.items():
        if v > 0:
            name, what = key.rsplit(".", 1)
            limit = support_sigma(kinds.get(name, "")) if what == "support" else 0.0
            text = {"order": "stage order violated (the later stage starts first)",
                    "separation": "min_separation violated (the stages overlap)",
                    "safety_factor": "min_safety_factor violated (walls too close to break "
                                     "at max_pressure)",
                    "length": "max_length violated (device too long)",
                    "share": "a graded part that hardly moves (under half its share of the "
                             "stage's motion)",
                    "support": "the cell model's Pc uncertainty exceeds "
                               f"{limit:.0%} (the cell sits where the calibration "
                               "has few FE designs)"}.get(what, what)
            out.append(f"{name}: {text} by {v:.0%}")
    bind = _binding(space, ev)
    if bind:
        out.append("active bounds of the closest design: " + " | ".join(bind))
    return out


def design(target: TargetSpec, *, model: BatchModel | None = None,
           settings: DesignSettings | None = None, progress: Progress | None = None,
           x0: np.ndarray | None = None, radius: float | None = None,
           correction: Any = None, model_order: bool = False) -> DesignResult:
    """Search for devices whose predicted sequence meets ``target``.

    Parameters
    ----------
    target : TargetSpec
    model : BatchModel, optional
        ``model(cells, p_max) -> list[Response | Exception]``; default the reduced model
        (:func:`multimorph.design.rom_batch_model`).
    settings : DesignSettings, optional
    progress : callable, optional
        ``progress(evaluations, budget, phase)`` after every model call.
    x0 : ndarray, optional
        A design (unit vector of the searched stages) seeded into the initial population:
        a warm start from an earlier search (the rounds of :func:`mapped_design`).
    radius : float, optional
        With ``x0``: search only the box ``x0 ± radius`` of the unit coordinates (a trust
        region: the rounds of a space mapping correct the targets by ratios measured at
        ``x0``, which hold near it).
    correction : sequence of mapping, optional
        Per stage, factors on the model's Pc, Ph and motion before scoring (output space
        mapping, :func:`mapped_design`).
    model_order : bool
        With ``correction``: the stages must also come in order on the model's own,
        uncorrected Pc (FE in the loop: the design's device file is simulated on the model).

    Returns
    -------
    DesignResult
        Ranked designs; ``feasible`` False with an ``explanation`` when no design meets the
        target (never a silent poor design).
    """
    settings = settings or DesignSettings()
    t0 = time.perf_counter()
    # bounds that no design can meet, named by the stages as written
    static = _static_checks(SearchSpace(target))
    if static:
        return DesignResult(target, settings, False, [], static, {}, 0, 0, [],
                            time.perf_counter() - t0)
    wanted = None
    if settings.graded:
        parts = graded_target(target, settings.graded_ratio)
        if parts is not target:
            wanted, target = target, parts
    raw = model if model is not None else rom_batch_model()
    counted = CountingModel(raw, pad_to=(settings.batch_cells
                                         or settings.population * len(target.stages)))
    # a model with a bounded support (the calibrated one): search inside it
    boxes = counted.support_boxes()
    space = SearchSpace(target, boxes=boxes,
                        correction=None if correction is None else tuple(correction),
                        model_order=model_order)
    rng = np.random.default_rng(settings.seed)
    history: list[float] = []
    archive: dict[bytes, Evaluation] = {}

    # the searched region: the unit box, or a trust region around x0 (local coordinates
    # X in [0, 1] map to lo + X (hi - lo))
    lo, hi = np.zeros(space.dim), np.ones(space.dim)
    if x0 is not None and radius is not None:
        x0c = np.clip(np.asarray(x0, float).ravel(), 0.0, 1.0)
        lo, hi = np.clip(x0c - radius, 0.0, 1.0), np.clip(x0c + radius, 0.0, 1.0)
    span = np.where(hi > lo, hi - lo, 1.0)

    def to_local(x: np.ndarray) -> np.ndarray:
        return np.clip((np.asarray(x, float) - lo) / span, 0.0, 1.0)

    def run(X: np.ndarray, phase: str, local: bool = True) -> list[Evaluation]:
        X = lo + np.atleast_2d(X) * (hi - lo) if local else X
        evs = evaluate_population(space, X, counted)
        for e in evs:
            archive.setdefault(np.round(e.candidate.x, 6).tobytes(), e)
        best = min(e.objective for e in archive.values()) if archive else math.inf
        history.append(best)
        if progress is not None:
            progress(counted.evaluations, settings.budget, phase)
        return evs

    # reachability of the targets by the corner designs (explains infeasible targets)
    reach, reasons = _reachability(space, lambda c, p: counted(c, p))
    if progress is not None:
        progress(counted.evaluations, settings.budget, "reachability")
    if reasons:
        return DesignResult(target, settings, False, [], reasons, reach, counted.evaluations,
                            counted.calls, history, time.perf_counter() - t0, wanted=wanted)

    # global stage: differential evolution
    n, dim = settings.population, space.dim
    S = space.n_stages
    global_budget = settings.budget * (1.0 - settings.refine_fraction)
    X = (rng.permuted(np.tile(np.arange(n), (dim, 1)), axis=1).T
         + rng.random((n, dim))) / n                     # Latin hypercube
    if x0 is not None:
        x0 = np.clip(np.asarray(x0, float).ravel(), 0.0, 1.0)
        if x0.shape != (dim,):
            raise SpecError(f"x0: expected {dim} coordinates, got {x0.shape[0]}")
        X[0] = to_local(x0)
    if settings.stagewise and S > 1:
        X = _stagewise_start(space, X, lo, hi, to_local, counted, rng, settings,
                             budget=settings.stage_fraction * global_budget,
                             progress=None if progress is None else (
                                 lambda phase: progress(counted.evaluations, settings.budget,
                                                        phase)))
        if x0 is not None:
            X[0] = to_local(x0)
    evs = run(X, "global")
    f = np.array([e.objective for e in evs])
    while counted.evaluations + n * S <= global_budget:
        idx = np.array([rng.choice(np.delete(np.arange(n), k), 3, replace=False)
                        for k in range(n)])
        F = rng.uniform(0.5, 0.9, size=(n, 1))
        V = X[idx[:, 0]] + F * (X[idx[:, 1]] - X[idx[:, 2]])
        V = np.where(V < 0, -V, V)
        V = np.where(V > 1, 2 - V, V)
        V = np.clip(V, 0.0, 1.0)
        cross = rng.random((n, dim)) < 0.8
        cross[np.arange(n), rng.integers(0, dim, n)] = True
        U = np.where(cross, V, X)
        tevs = run(U, "global")
        ft = np.array([e.objective for e in tevs])
        better = ft <= f
        X[better], f[better] = U[better], ft[better]
        evs = [tevs[k] if better[k] else evs[k] for k in range(n)]

    # gradient stage: Gauss-Newton on IFT gradients through the traced paths
    kb = int(np.argmin(f))
    xb, fb = X[kb].copy(), float(f[kb])
    steps: list[GradientStep] = []
    if settings.gradient and settings.gradient_iterations > 0:
        gbest, steps = gradient_refine(
            space, evs[kb], lambda Xg: run(Xg, "gradient", local=False),
            lambda k: counted.evaluations + k * S <= settings.budget,
            max_iter=settings.gradient_iterations)
        if gbest.objective < fb:
            xb, fb = to_local(gbest.candidate.x), float(gbest.objective)

    # local stage: compass search on the continuous variables of the best design
    cont = [i * N_VARS + j for i in range(S) for j in (0, 1, 2, 3, 4, 5, 6, 9)]
    step = 0.08
    while step > 2e-3 and counted.evaluations + 2 * len(cont) * S <= settings.budget:
        P = np.repeat(xb[None, :], 2 * len(cont), axis=0)
        for k, j in enumerate(cont):
            P[2 * k, j] = min(1.0, xb[j] + step)
            P[2 * k + 1, j] = max(0.0, xb[j] - step)
        pevs = run(P, "refine")
        fp = np.array([e.objective for e in pevs])
        k = int(np.argmin(fp))
        if fp[k] < fb - 1e-12:
            xb, fb = P[k].copy(), float(fp[k])
        else:
            step *= 0.5

    ranked = sorted(archive.values(), key=lambda e: e.objective)
    top: list[Evaluation] = []
    seen: set[tuple[Any, ...]] = set()
    for e in ranked:
        key = (round(e.objective, 9), e.candidate.material_index)
        if key in seen:
            continue
        seen.add(key)
        top.append(e)
        if len(top) >= max(settings.top, settings.robust_shortlist):
            break
    robust_scores: dict[int, float] = {}
    if settings.robust_samples > 0:
        from multimorph.design._robust import robustness

        shortlist = top[:settings.robust_shortlist]
        scored = []
        for e in shortlist:
            rep = robustness(target, e, n_samples=settings.robust_samples, seed=settings.seed,
                             model=lambda c, p: counted(c, p),
                             wall_tolerance=settings.wall_tolerance, default_cv=settings.default_cv)
            score = rep.mean_objective + 10.0 * (1.0 - rep.p_order)
            scored.append((score, e))
        scored.sort(key=lambda se: se[0])
        top = [e for _, e in scored] + top[len(shortlist):]
        robust_scores = {k: sc for k, (sc, _) in enumerate(scored)}
    top = top[:settings.top]
    best = top[0]
    feasible = bool(best.meets)
    explanation = [] if feasible else explain_design(space, best)
    return DesignResult(target, settings, feasible, top, explanation, reach, counted.evaluations,
                        counted.calls, history, time.perf_counter() - t0, robust_scores,
                        tuple(steps), wanted=wanted)
