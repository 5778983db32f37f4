"""Path drivers: Newton, pressure-controlled stepping with cutback, arc-length continuation.

All three work on a :class:`~multimorph.fe.engine.PressureProblem`, whose residual is a pure
function of the displacement (no hidden state), so a rejected step is undone by writing the
last converged displacement back, and contique's cycles need no state bookkeeping.
"""

from __future__ import annotations

import contextlib
import io
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from multimorph.fe._deps import require
from multimorph.fe.engine._linsolve import LinearSolver, NonFiniteSystemError
from multimorph.fe.engine._problem import PressureProblem
from multimorph.outcome import Outcome

__all__ = ["NewtonInfo", "PathPoint", "PathRun", "continuation", "newton",
           "pressure_control"]


@dataclass
class NewtonInfo:
    """Outcome of one Newton solve."""

    converged: bool
    iterations: int
    residuals: list[float]
    message: str = ""


@dataclass
class PathPoint:
    """One converged equilibrium state (nondimensional units of the problem)."""

    pressure: float
    x: np.ndarray
    iterations: int
    stable: bool | None
    method: str  # "pressure" or "arc-length"


@dataclass
class PathRun:
    """Result of a path driver: the converged points and how it ended."""

    points: list[PathPoint] = field(default_factory=list)
    #: how it ended: ``COMPLETED``, ``STOPPED``, ``STALLED`` or ``MAX_STEPS`` (``RUNNING``
    #: while it runs); ``message`` says more
    status: Outcome = Outcome.RUNNING
    message: str = ""
    attempts: int = 0
    cutbacks: int = 0
    newton_iterations: int = 0
    wall_time: float = 0.0
    #: tangents handed out again instead of assembled (continuation at converged points)
    tangents_reused: int = 0
    #: continuation iterations that reused the previous iterate's tangent (chord steps)
    chord_steps: int = 0
    #: continuations restarted past the point where they had turned round
    restarts: int = 0


def _inertia_stable(solver: LinearSolver) -> bool | None:
    if solver.inertia is None:
        return None
    return solver.inertia[1] == 0


def newton(problem: PressureProblem, x: np.ndarray, p: float, solver: LinearSolver, *,
           tol: float = 1e-8, maxiter: int = 10) -> tuple[np.ndarray, NewtonInfo]:
    """Solve ``r(x, p) = 0`` at fixed pressure.

    Converged when ``|r| <= tol * max(|p g|, |f_int|)`` (Euclidean norms, relative to the
    load). Stops early on NaN/inf or when the residual grows 1e4-fold (a divergent iterate;
    the caller cuts back). The problem's state must be synchronised with the converged point
    the iteration starts from (:meth:`PressureProblem.sync`); the residual at ``x`` then
    advances it by the linearised update.
    """
    x = np.array(x, dtype=float)
    norms: list[float] = []
    with np.errstate(all="ignore"):
        for it in range(maxiter + 1):
            r, g = problem.residual(x, p)
            nr = float(np.linalg.norm(r))
            norms.append(nr)
            scale = max(abs(p) * float(np.linalg.norm(g)), 1e-30)
            if not math.isfinite(nr):
                return x, NewtonInfo(False, it, norms, "residual is not finite")
            if nr <= tol * scale:
                return x, NewtonInfo(True, it, norms, "converged")
            if it == maxiter:
                break
            if it >= 2 and nr > 1e4 * max(norms[0], scale):
                return x, NewtonInfo(False, it, norms, "diverging")
            if it >= 4 and nr > 1e-4 * max(norms):
                # converging iterations are quadratic by now (typically 1e-3, 2e-1, 3e-3,
                # 3e-7, ...): give up early and let the step control cut back
                return x, NewtonInfo(False, it, norms, "not converging")
            try:
                K = problem.tangent(x, p)
                dx = solver.solve(K, -r)
            except NonFiniteSystemError as exc:
                return x, NewtonInfo(False, it, norms, str(exc))
            x = x + dx
    return x, NewtonInfo(False, maxiter, norms, f"no convergence in {maxiter} iterations")


def pressure_control(problem: PressureProblem, p_end: float, solver: LinearSolver, *,
                     p_start: float = 0.0, dp0: float | None = None,
                     dp_min: float | None = None, dp_max: float | None = None,
                     tol: float = 1e-8, maxiter: int = 10, max_steps: int = 500,
                     max_cutbacks: int | None = None,
                     on_point: Callable[[PathPoint], bool] | None = None,
                     run: PathRun | None = None,
                     prev: tuple[float, np.ndarray] | None = None) -> PathRun:
    """Ramp the pressure from the problem's current state to ``p_end`` with cutbacks.

    Steps grow ×1.5 after an easy step (≤ 4 iterations) and halve on failure; the state of
    the last converged point is restored before a retry. A secant predictor extrapolates
    the displacement from the last two points. ``on_point`` is called for every converged
    point and may return True to stop. With ``max_cutbacks`` the ramp also counts as stalled
    after that many consecutive failures (hand over to continuation early instead of
    halving the step down to ``dp_min``). ``prev`` (pressure, x) is the converged point
    before the current one, for the secant predictor of the first step (a resumed path).

    Returns
    -------
    PathRun
        ``status`` is ``COMPLETED`` (reached ``p_end``), ``STOPPED`` (by ``on_point``),
        ``STALLED`` (step below ``dp_min``: a limit point, or lock-up) or ``MAX_STEPS``
        (:class:`~multimorph.outcome.Outcome`).
    """
    t0 = time.perf_counter()
    run = run if run is not None else PathRun()
    span = p_end - p_start
    dp = dp0 if dp0 is not None else span / 10
    dp_min = dp_min if dp_min is not None else span * 1e-4
    dp_max = dp_max if dp_max is not None else span / 4
    x = problem.get_x()
    problem.sync(x)
    p = p_start
    steps = 0
    in_row = 0
    while p < p_end * (1 - 1e-12) and steps < max_steps:
        p_try = min(p + dp, p_end)
        if prev is not None and p - prev[0] > 0:
            x_pred = x + (p_try - p) / (p - prev[0]) * (x - prev[1])
        else:
            x_pred = x
        run.attempts += 1
        problem.sync(x)
        x_new, info = newton(problem, x_pred, p_try, solver, tol=tol, maxiter=maxiter)
        run.newton_iterations += info.iterations
        if info.converged:
            in_row = 0
            prev = (p, x)
            x, p = x_new, p_try
            steps += 1
            pt = PathPoint(p, x.copy(), info.iterations, _inertia_stable(solver), "pressure")
            run.points.append(pt)
            problem.sync(x)
            if on_point is not None and on_point(pt):
                run.status = Outcome.STOPPED
                break
            if info.iterations <= 5:
                dp = min(dp * 1.5, dp_max)
        else:
            problem.sync(x)
            run.cutbacks += 1
            in_row += 1
            dp *= 0.5
            if dp < dp_min or (max_cutbacks is not None and in_row >= max_cutbacks):
                run.status = Outcome.STALLED
                run.message = (f"pressure step fell below {dp_min:.3g} at P = {p:.6g} "
                               f"({info.message})")
                break
    else:
        run.status = Outcome.COMPLETED if p >= p_end * (1 - 1e-12) else Outcome.MAX_STEPS
    problem.sync(x)
    run.wall_time += time.perf_counter() - t0
    return run


class _Bordered:
    """contique callbacks: residual, Jacobian blocks and a bordered linear solve.

    contique extends ``f(x, λ) = 0`` by one control equation and solves the (n+1) system
    ``[[K, f_λ], [e_c, d]]``. We solve it by bordering with two right-hand sides of the
    symmetric ``K``, so PARDISO's symmetric mode still applies.

    contique starts the pre-identification and every cycle of a step from the last converged
    point, each with a fresh Jacobian there. The tangent at the converged point is therefore
    kept and handed out again (it is a function of that point alone: the dual fields are
    synchronised there), and the linear solver sees the identical matrix and skips the
    factorisation.

    Chord step: when the residual of the current iterate fell below ``chord`` times the
    previous iterate's, Newton is in its quadratic regime and the previous iterate's tangent
    (whose factors the solver keeps) is handed out again instead of a new one. The next
    error then shrinks by about the previous relative error (≈ 10⁻³ or better), which is
    enough to pass the tolerance, for a residual evaluation and a triangular solve instead
    of a tangent assembly and a factorisation. Convergence is still judged on the true
    residual, so the converged points are the same equilibria. With chord steps on, the
    predictor at a new converged point also takes the last tangent of the cycle that
    converged there (its iterate is within a quadratic step of the point) instead of a fresh
    one; contique's pre-identification and first cycle iteration then share it as before.
    """

    #: hand out contique's repeated residuals and solves again (off only to test it)
    memo = True

    def __init__(self, problem: PressureProblem, solver: LinearSolver, *,
                 chord: float = 0.0) -> None:
        self.problem = problem
        self.solver = solver
        self._x: np.ndarray | None = None
        self._g: np.ndarray | None = None
        self.evaluations = 0
        self.converged_x = problem.get_x()
        self._K: sp.csr_matrix | None = None           # tangent at the converged point
        self._K_at: tuple[np.ndarray, float] | None = None
        self.tangents_reused = 0
        self.chord = chord
        self.chord_steps = 0
        self._norms: list[float] = []                   # residual norms of this cycle
        self._K_last: sp.csr_matrix | None = None       # tangent of the previous iterate
        self._K_end: sp.csr_matrix | None = None        # last tangent of a converged cycle
        self._K_solve: sp.csr_matrix | None = None      # tangent of the pending solve
        self._proxy: sp.csr_matrix | None = None        # what contique sees of it
        # contique 1.1 runs a one-iteration "pre-identification" from the converged point
        # and discards it, then starts the cycle from the same point: the residuals there
        # and at the first iterate (with the state it leaves), and the bordered solve, are
        # kept and handed out again instead of recomputed
        self._memo0: tuple[Any, ...] | None = None
        self._memo1: tuple[Any, ...] | None = None
        self._from_converged = False
        self._solved: tuple[Any, ...] | None = None
        self.memo_hits = 0
        self.interrupted = False

    def fun(self, x: np.ndarray, lpf: float, *_: Any) -> np.ndarray:
        if self.interrupted:
            raise KeyboardInterrupt
        if not (math.isfinite(lpf) and np.all(np.isfinite(x))):
            # a failed solve (contique turns it into NaN and iterates on): nothing to evaluate
            self._from_converged = False
            return self._record(x, np.full_like(x, np.nan), np.full_like(x, np.nan))
        first = False                    # the first iterate away from the converged point
        if np.array_equal(x, self.converged_x):
            # every contique cycle starts from the last converged point: restore its state
            self.problem.sync(x)
            self._norms = []
            new_point = self._K_at is None or not np.array_equal(self._K_at[0], x)
            if self.chord > 0 and self._K_last is not None and new_point:
                # a new converged point: the cycle that reached it left its last tangent
                self._K_end = self._K_last
            self._K_last = None
            memo = self._memo0
            if (self.memo and memo is not None and memo[0] == lpf
                    and np.array_equal(memo[1], x)):
                # synced state = the state this residual leaves; the tangent, if asked
                # for here, evaluates it afresh (sync clears the problem's last x)
                self._from_converged = True
                self.memo_hits += 1
                return self._record(x, memo[2], memo[3])
            self._memo1 = None
        elif self._from_converged and self.memo:
            first = True
            memo = self._memo1
            if memo is not None and memo[0] == lpf and np.array_equal(memo[1], x):
                self.problem.restore(memo[4])
                self._from_converged = False
                self.memo_hits += 1
                return self._record(x, memo[2], memo[3])
        with np.errstate(all="ignore"):
            r, g = self.problem.residual(x, lpf)
        self.evaluations += 1
        if np.array_equal(x, self.converged_x):
            self._memo0 = (float(lpf), x.copy(), r, g)
            self._from_converged = True
        else:
            if first:
                self._memo1 = (float(lpf), x.copy(), r, g, self.problem.snapshot())
            self._from_converged = False
        return self._record(x, r, g)

    def _record(self, x: np.ndarray, r: np.ndarray, g: np.ndarray) -> np.ndarray:
        self._x, self._g = x.copy(), g
        if not np.all(np.isfinite(r)):
            self._norms.append(math.inf)
            return np.full_like(r, np.nan)
        self._norms.append(float(np.linalg.norm(r)))
        return r.copy()

    def dfdx(self, x: np.ndarray, lpf: float, *_: Any) -> sp.csr_matrix:
        """The tangent for contique's Jacobian: kept for :meth:`solve`, which is the only
        user of contique's bordered matrix. contique is handed an empty matrix of the same
        shape instead, so its sparse stacking into the (n+1) system and our slicing it
        apart again (≈ 12 ms per iteration at 10k DOF) handle only the border."""
        n = len(x)
        failed = bool(self._norms) and not math.isfinite(self._norms[-1])
        # a non-finite residual (a trial state past lock-up, or a failed solve before it)
        # gets no tangent: the bordered solve refuses, and contique's cycle fails at once
        self._K_solve = None if failed else self._tangent(x, lpf)
        if self._proxy is None or self._proxy.shape[0] != n:
            self._proxy = sp.csr_matrix((n, n))
        return self._proxy

    def _tangent(self, x: np.ndarray, lpf: float) -> sp.csr_matrix:
        at = self._K_at
        if (self._K is not None and at is not None and at[1] == lpf
                and np.array_equal(at[0], x)):
            self.tangents_reused += 1
            return self._K
        n = self._norms
        if (self.chord > 0 and self._K_last is not None and len(n) >= 2
                and n[-1] <= self.chord * n[-2]):
            self.chord_steps += 1
            return self._K_last
        at_converged = np.array_equal(x, self.converged_x)
        if at_converged and self._K_end is not None:
            # the predictor's tangent at a new converged point: the last tangent of the
            # cycle that converged there (its iterate is within the tolerance's reach of
            # the point), instead of a fresh assembly and factorisation
            K, self._K_end = self._K_end, None
            self._K, self._K_at = K, (x.copy(), float(lpf))
            self.tangents_reused += 1
            return K
        with np.errstate(all="ignore"):
            K = self.problem.tangent(x, lpf)
        if at_converged:
            self._K, self._K_at = K, (x.copy(), float(lpf))
        else:
            self._K_last = K
        return K

    def dfdl(self, x: np.ndarray, lpf: float, *_: Any) -> np.ndarray:
        if self._x is None or not np.array_equal(self._x, x):
            self.fun(x, lpf)
        assert self._g is not None
        return -self._g

    def solve(self, A: sp.spmatrix, b: np.ndarray) -> np.ndarray:
        A = A.tocsr()
        n = A.shape[0] - 1
        K = self._K_solve
        head = A.indices[:A.indptr[n]]
        if K is None:
            raise NonFiniteSystemError("no tangent at a non-finite residual")
        if K.shape[0] != n or not np.all(head == n):
            raise RuntimeError("bordered solve: contique's matrix is not the one dfdx handed out")
        c = np.asarray(A[:n, n].toarray()).ravel()
        row = np.asarray(A[n, :].toarray()).ravel()
        e, d = row[:n], row[n]
        rhs = np.column_stack([b[:n], c])
        memo = self._solved
        if self.memo and memo is not None and memo[0] is K and np.array_equal(memo[1], rhs):
            sol = memo[2]
            self.memo_hits += 1
        else:
            try:
                sol = self.solver.solve(K, rhs)
            except KeyboardInterrupt:
                # contique 1.1 wraps this call in a bare ``except:`` and iterates on NaN,
                # which would swallow Ctrl-C: raise it again from the next residual call
                self.interrupted = True
                raise
            self._solved = (K, rhs, sol)
        a, z = sol[:, 0], sol[:, 1]
        den = d - e @ z
        if den == 0 or not math.isfinite(den):
            raise NonFiniteSystemError("singular bordered system")
        y = (b[n] - e @ a) / den
        return np.append(a - z * y, y)


def _silenced(gen: Iterator[Any], sink: io.StringIO | None) -> Iterator[Any]:
    """The items of ``gen`` with its own printing (contique's step table) sent to ``sink``;
    the caller's code between items (progress callbacks) still prints normally."""
    while True:
        with contextlib.redirect_stdout(sink) if sink is not None else contextlib.nullcontext():
            try:
                item = next(gen)
            except StopIteration:
                return
        yield item


def continuation(problem: PressureProblem, p_start: float, solver: LinearSolver, *,
                 dx_max: float, dp_max: float, max_steps: int = 200, tol: float = 1e-7,
                 maxiter: int = 8, on_point: Callable[[PathPoint], bool] | None = None,
                 run: PathRun | None = None, quiet: bool = True,
                 overshoot: float = 1.25, chord: float = 1e-3,
                 direction: np.ndarray | None = None) -> PathRun:
    """Arc-length-like continuation with contique from the problem's current state.

    contique (local parameterisation with switching control components) follows the path
    through limit points. The falling branch is reported with ``stable=False`` (from the
    inertia of the tangent with PARDISO, else from the sign of dP along the path).

    Parameters
    ----------
    dx_max, dp_max : float
        Largest increment of any displacement component and of the pressure per step
        (problem units); contique rebalances them within [1e-6, 10] times these.
    max_steps : int
    tol : float
        Residual tolerance relative to the load ``|g| max(P_start, 10 dp_max)`` (contique
        tests an absolute norm; too tight a value sits below the round-off floor and stalls).
    on_point : callable
        Called per converged point; return True to stop (e.g. at the target pressure).
    overshoot : float
        contique accepts a converged cycle whose largest normalised increment of another
        component exceeds its limit by up to this factor, instead of repeating the whole
        Newton cycle with that component in control. 1.25 saved 22 % of the factorisations
        on the reference cell's fine path (same points, Pc and Ph to 3e-5); 1.0 is
        contique's strict default.
    chord : float
        Reuse the previous iterate's tangent (a chord step, no new factorisation) once the
        residual fell below this fraction of the previous one (see :class:`_Bordered`);
        0 always assembles a fresh tangent.
    direction : ndarray, optional
        The increment (x, P) of the step that reached the current point (a resumed path):
        the first step goes on the same way, controlled by its largest component relative
        to the increment limits, as contique would pick it, with increments as large as
        that step's (over ``overshoot``, within contique's bounds of 1e-6…10 times
        ``dx_max``, ``dp_max``). Default: increasing pressure from ``dx_max``, ``dp_max``.
    """
    contique = require("contique")
    t0 = time.perf_counter()
    run = run if run is not None else PathRun()
    cb = _Bordered(problem, solver, chord=chord)
    x0 = problem.get_x()
    problem.sync(x0)
    _, g0 = problem.residual(x0, p_start)
    tol_abs = tol * float(np.linalg.norm(g0)) * max(abs(p_start), 10 * dp_max)
    control0, scale = (-1, 1), 1.0
    if direction is not None and np.all(np.isfinite(direction)) and np.any(direction):
        scaled = np.abs(direction) / np.append(np.full(len(x0), dx_max), dp_max)
        c = int(np.argmax(scaled))
        control0 = (c, 1 if direction[c] > 0 else -1)
        # the increments contique had grown to: the last step's, within its 10× bound
        scale = float(np.clip(scaled[c] / overshoot, 1.0, 10.0))
    last_p = p_start
    sink = io.StringIO()
    gen = contique.solve(fun=cb.fun, jac=(cb.dfdx, cb.dfdl), x0=x0, lpf0=p_start,
                         dxmax=dx_max * scale, dlpfmax=dp_max * scale, maxsteps=max_steps,
                         maxiter=maxiter, tol=tol_abs, rebalance=True, solve=cb.solve,
                         control0=control0, overshoot=overshoot, high=10.0 / scale,
                         low=1e-6 / scale)
    first = True
    x_last = x0
    try:
        for res in _silenced(gen, sink if quiet else None):
            if first:
                first = False
                continue
            run.attempts += 1
            run.newton_iterations += int(res.niterations)
            if not res.success:
                continue
            x, p = res.x[:-1].copy(), float(res.x[-1])
            cb.converged_x = res.x[:-1].copy()
            stable = _inertia_stable(solver)
            if stable is None:
                stable = p >= last_p
            last_p = p
            x_last = x
            pt = PathPoint(p, x, int(res.niterations), stable, "arc-length")
            run.points.append(pt)
            if on_point is not None and on_point(pt):
                run.status = Outcome.STOPPED
                break
        else:
            run.status = Outcome.MAX_STEPS if len(run.points) else Outcome.STALLED
    except NonFiniteSystemError as exc:
        run.status = Outcome.STALLED
        run.message = f"continuation failed: {exc}"
    if run.status == Outcome.RUNNING:
        run.status = Outcome.STALLED
    run.tangents_reused += cb.tangents_reused
    run.chord_steps += cb.chord_steps
    problem.sync(x_last)
    run.wall_time += time.perf_counter() - t0
    return run


