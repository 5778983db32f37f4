r"""Gradient refinement of a design through the equilibrium (implicit function theorem).

The objective is a sum of squares, f(x) = Σ r_k(x)², of the normalised distances and
constraint violations of :func:`~multimorph.design.evaluate_one` (the fixed penalties for
missing pressures are constant locally). Its Jacobian over the continuous design variables
(cell lengths and tilt; materials and cell counts held) is assembled without re-running the
cell model:

1. for every stage's traced path, the IFT gives how each path point moves per unit change of
   each cell length (:func:`multimorph.rom.path_sensitivity`, one bordered linear solve per
   point, regular through limit points);
2. a unit-cube coordinate x_j changes the lengths by dG/dx_j (the decoder of
   :class:`~multimorph.design.SearchSpace`, piecewise linear); the stage's path is moved to
   first order, path + (∂path/∂G)·dG, and the cheap post-processing — observed curves, Pc,
   Ph, module strains, magnitudes, constraints — is applied to the moved paths at
   x_j ± ``step`` and differenced centrally. This differentiates the estimators on the
   linearised curves; the tracer is never differentiated and the model never re-run.

The step is a bounded Levenberg–Marquardt (Gauss–Newton) step on the variables not held by an
active bound, for several dampings at once: the trial designs are evaluated as one batched
model call, the best one is kept if it lowers the objective, and the damping and a trust
radius adapt. Deterministic (no random numbers).

The number of cells of a bend or twist module, round(angle / motion per cell), is relaxed to
a real number in the Jacobian (residuals interpolated between the neighbouring counts), so
the gradient sees the device length respond as the re-rounding trial evaluations will.

Limits: the peak stretch (safety factor) is held fixed in the Jacobian (the trial
evaluations see it); the derivative is that of the discrete estimators,
which differs from finite differences of re-traced Pc/Ph by a few per cent (the adaptive
path nodes move with the design; tested); a cell model without generalised coordinates
(e.g. FE or a closed-form stand-in) has no sensitivities, and the stage is skipped.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from multimorph.design._evaluate import Evaluation, evaluate_one
from multimorph.design._space import N_VARS, SearchSpace
from multimorph.response import Response, build_response

__all__ = ["GradientStep", "gradient_refine", "objective_jacobian", "residuals"]

#: Smallest Marquardt scale of a variable, relative to the largest (see gradient_refine).
MARQUARDT_FLOOR = 1e-2

#: Continuous coordinates of a stage (length … end wall, tilt); materials are discrete.
CONTINUOUS = (0, 1, 2, 3, 4, 5, 6, 9)


def residuals(ev: Evaluation, tolerance_pressure: float) -> dict[str, float]:
    """The residuals whose squares sum to the objective (penalties excluded)."""
    r = dict(ev.distances)
    for k, v in ev.violations.items():
        r[f"violation:{k}"] = 4.0 * max(v, 0.0) / tolerance_pressure
    return r


def _relaxed(target: Any, cand: Any, resps: Sequence[Any], tp: float) -> dict[str, float]:
    """Residuals with the cell counts relaxed to real numbers.

    A bend or twist module has n = round(angle / motion per cell) cells, a step function of
    the design. The relaxation uses the real n* = angle / motion (capped as the designer
    caps it) and interpolates the residuals multilinearly between the integer counts around
    it, so the Jacobian sees the device length grow as a cell moves less (and the magnitude
    error stay at its rounding value) as the trial evaluations, which re-round n, will.
    """
    probe = evaluate_one(target, cand, resps, fixed_cells=[1] * len(target.stages))
    con = target.constraints
    lo, frac = [], []
    for stage, found, cell in zip(target.stages, probe.stages, cand.cells, strict=True):
        cap = max(1, int(con.max_length // cell.length))
        if stage.kind == "stretch" or not (found.magnitude > 0 and np.isfinite(found.magnitude)):
            lo.append(1)
            frac.append(0.0)
            continue
        nstar = min(max(abs(stage.magnitude) / found.magnitude, 1.0), float(cap))
        n0 = min(int(np.floor(nstar)), cap - 1) if cap > 1 else 1
        lo.append(max(n0, 1))
        frac.append(nstar - lo[-1] if cap > 1 else 0.0)
    out: dict[str, float] = {}
    for bits in itertools.product((0, 1), repeat=len(lo)):
        w = float(np.prod([f if b else 1.0 - f for b, f in zip(bits, frac, strict=True)]))
        if w == 0.0:
            continue
        n = [a + b for a, b in zip(lo, bits, strict=True)]
        for k, v in residuals(evaluate_one(target, cand, resps, fixed_cells=n), tp).items():
            out[k] = out.get(k, 0.0) + w * v
    return out


def _lengths(cell: Any) -> np.ndarray:
    from multimorph.rom import LENGTHS

    return np.array([getattr(cell, k) for k in LENGTHS])


def objective_jacobian(space: SearchSpace, ev: Evaluation, variables: Sequence[int], *,
                       step: float = 1e-6) -> tuple[list[str], np.ndarray, np.ndarray] | None:
    """Residuals and their Jacobian over unit-cube ``variables`` of a scored design.

    Parameters
    ----------
    space : SearchSpace
    ev : Evaluation
        A design scored from reduced-model responses (paths with ``extra["q"]``).
    variables : sequence of int
        Indices into the design vector (continuous coordinates).
    step : float
        Central-difference step of the post-processing (unit-cube units).

    Returns
    -------
    (keys, r, J) or None
        Residual names, values (k,) and Jacobian (k, len(variables)); ``None`` when a stage
        has no reduced-model path (no sensitivities).
    """
    resps = list(ev.responses)
    if not all(isinstance(r, Response) and r.path.extra.get("q") is not None for r in resps):
        return None
    from multimorph.rom import path_sensitivity

    target = space.target
    cand = ev.candidate
    sens = [path_sensitivity(c, r.path) for c, r in zip(cand.cells, resps, strict=True)]
    g0 = [_lengths(c) for c in cand.cells]
    tp = target.tolerance.pressure

    def res_at(x: np.ndarray, stage: int) -> dict[str, float]:
        c = space.decode(x)
        cell = c.cells[stage]
        dg = _lengths(cell) - g0[stage]
        rs = list(resps)
        if np.any(dg != 0.0):
            path = sens[stage].perturbed(resps[stage].path, dg)
            rs[stage] = build_response(path, length=cell.length,
                                       shear_modulus=cell.mu, backend="rom",
                                       break_stretch=cell.material.break_stretch,
                                       signal=cell.signal)
        return _relaxed(target, c, rs, tp)

    r0 = _relaxed(target, cand, resps, tp)
    cols: list[tuple[dict[str, float], dict[str, float], float]] = []
    x = np.asarray(cand.x, float)
    for j in variables:
        xp, xm = x.copy(), x.copy()
        xp[j] = min(1.0, x[j] + step)
        xm[j] = max(0.0, x[j] - step)
        cols.append((res_at(xp, j // N_VARS), res_at(xm, j // N_VARS), xp[j] - xm[j]))
    keys = sorted(set(r0).union(*(set(a) | set(b) for a, b, _ in cols)))
    r = np.array([r0.get(k, 0.0) for k in keys])
    J = np.zeros((len(keys), len(cols)))
    for c_, (a, b, h) in enumerate(cols):
        J[:, c_] = [(a.get(k, 0.0) - b.get(k, 0.0)) / h for k in keys]
    return keys, r, J


@dataclass(frozen=True)
class GradientStep:
    """Log of one refinement iteration (objective before/after, damping, trust radius)."""

    objective_before: float
    objective_after: float
    damping: float
    radius: float
    trials: int


def gradient_refine(space: SearchSpace, ev: Evaluation,
                    run: Callable[[np.ndarray], list[Evaluation]],
                    can_afford: Callable[[int], bool], *, max_iter: int = 12,
                    dampings: Sequence[float] = (1e-3, 1e-2, 1e-1, 1.0),
                    radius: float = 0.1, min_radius: float = 1e-3,
                    ) -> tuple[Evaluation, list[GradientStep]]:
    """Bounded Levenberg–Marquardt refinement of a design's continuous variables.

    Parameters
    ----------
    space : SearchSpace
    ev : Evaluation
        The start design (its responses give the Jacobian; no model call for it).
    run : callable
        ``run(X) -> list[Evaluation]``: scores the trial designs ``X`` (n, dim) in one batched
        model call (and counts the evaluations).
    can_afford : callable
        ``can_afford(n_designs) -> bool``: whether the budget allows another call.
    max_iter : int
        Iterations (Jacobians) at most.
    dampings : sequence of float
        Marquardt dampings relative to the scale of JᵀJ, one trial design each per call.
    radius, min_radius : float
        Initial and smallest trust radius (largest step of any coordinate, unit cube).

    Returns
    -------
    (Evaluation, list of GradientStep)
        The best design found (``ev`` itself if nothing improved it) and the iteration log.
    """
    variables = [i * N_VARS + j for i in range(space.n_stages) for j in CONTINUOUS]
    best = ev
    log: list[GradientStep] = []
    lam = 1.0
    for _ in range(max_iter):
        if radius < min_radius or not can_afford(len(dampings)):
            break
        jac = objective_jacobian(space, best, variables)
        if jac is None:
            break
        _, r, J = jac
        x = np.asarray(best.candidate.x, float)
        xv = x[variables]
        grad = J.T @ r
        used = np.any(J != 0.0, axis=0)
        held = ((xv <= 0.0) & (grad > 0)) | ((xv >= 1.0) & (grad < 0))
        free = np.flatnonzero(used & ~held)
        if free.size == 0 or not np.any(grad[free]):
            break
        Jf = J[:, free]
        A = Jf.T @ Jf
        # Marquardt's scaling, floored: a variable the residuals barely feel (diagonal ≪ the
        # largest) would otherwise take a step ∝ 1/its sensitivity, fill the trust radius
        # alone and shrink every useful coordinate's step to nothing
        d = np.diag(A).copy()
        d = np.maximum(d, MARQUARDT_FLOOR * max(float(d.max()), 1e-300))
        trials = []
        for mu in dampings:
            dx = np.linalg.solve(A + lam * mu * np.diag(d) * 1.0 + 1e-14 * np.eye(len(free)),
                                 -Jf.T @ r)
            big = float(np.max(np.abs(dx)))
            if big > radius:
                dx *= radius / big
            xt = x.copy()
            xt[np.asarray(variables)[free]] = np.clip(xv[free] + dx, 0.0, 1.0)
            trials.append(xt)
        X = np.unique(np.round(np.array(trials), 12), axis=0)
        evs = run(X)
        k = int(np.argmin([e.objective for e in evs]))
        f0 = best.objective
        if evs[k].objective < f0 - 1e-12 * max(1.0, abs(f0)):
            best = evs[k]
            step = float(np.max(np.abs(np.asarray(best.candidate.x) - x)))
            lam = max(lam * 0.3, 1e-6)
            if step >= 0.99 * radius:
                radius *= 2.0
        else:
            lam *= 10.0
            radius *= 0.25
        log.append(GradientStep(f0, best.objective, lam, radius, len(X)))
    return best, log
