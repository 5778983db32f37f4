"""The FE path driver: trace a pressure path, hand every converged point to a recorder.

:func:`trace_path` is the one driver of every FE analysis (a cell, a device, a twisting
module). It steps the pressure (:func:`~multimorph.fe.engine.pressure_control`), hands over
to arc-length continuation (:func:`~multimorph.fe.engine.continuation`) where the steps
stall, saves every converged point to a :class:`~multimorph.fe.engine.PathCheckpoint` and
resumes from one, and restarts a continuation that turns round at a branch point. The caller
records: ``on_point`` measures each point and says when to stop (:func:`path_end` holds the
rules that end a path), ``truncate`` drops the points that walked back.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from multimorph.errors import SpecError
from multimorph.fe.engine._checkpoint import PathCheckpoint
from multimorph.fe.engine._linsolve import LinearSolver
from multimorph.fe.engine._problem import PressureProblem
from multimorph.fe.engine._solve import PathPoint, PathRun, continuation, pressure_control
from multimorph.outcome import Outcome

if TYPE_CHECKING:
    from multimorph.fe.mesh import MeshDensity

__all__ = ["RETRACE_RESTARTS", "FESettings", "path_end", "retraced", "trace_path"]


@dataclass(frozen=True)
class FESettings:
    """Settings of a cell analysis (SI units; ``None`` picks the default noted).

    Parameters
    ----------
    mesh : {"coarse", "medium", "fine"} or MeshDensity
    element_size : float, optional
        Explicit element edge length (m).
    half : bool
        Mesh half the cell (mirror plane x = w/2); for a device, half of a single series
        of bending and stretching modules (a device with a twisting module or a parallel
        branch is always meshed whole).
    p_max : float, optional
        Highest pressure (Pa); default the wall shear modulus μ.
    method : {"auto", "pressure", "arc-length"}
        ``"auto"``: pressure control, switching to arc-length continuation where the pressure
        steps stall (a limit point or a steep ballooning branch).
    solver : {"auto", "pardiso", "superlu"}
    tol : float
        Relative Newton tolerance on the residual norm.
    max_steps : int
        Largest number of converged points.
    max_volume_ratio : float
        Stop when the chamber volume exceeds this multiple of its initial volume.
    max_stretch : float, optional
        Stop when the peak principal stretch exceeds this; default the wall material's break
        stretch if it has one.
    dx_max, dp_max : float
        Continuation increments: displacement (fraction of d) and pressure (fraction of μ).
    stop_after_limit : bool
        Stop once the path has passed a pressure maximum (the pressure fell 0.5 % below it);
        enough to measure a limit-point Pc.
    chord : float
        Continuation: reuse the previous iterate's tangent once the residual fell below this
        fraction of the previous one (a chord step: no assembly, no factorisation; the
        equilibria are judged on the true residual), and start each step's predictor from
        the last tangent of the cycle that converged there. 0 assembles every tangent.
    """

    mesh: str | MeshDensity = "coarse"
    element_size: float | None = None
    half: bool = True
    p_max: float | None = None
    method: str = "auto"
    solver: str = "auto"
    tol: float = 1e-8
    max_steps: int = 400
    max_volume_ratio: float = 60.0
    max_stretch: float | None = None
    dx_max: float = 0.01
    dp_max: float = 0.02
    stop_after_limit: bool = False
    chord: float = 1e-3

    def __post_init__(self) -> None:
        if self.method not in ("auto", "pressure", "arc-length"):
            raise SpecError(f"method: expected auto, pressure or arc-length, got {self.method!r}")
        if self.p_max is not None and not (math.isfinite(self.p_max) and self.p_max > 0):
            raise SpecError(f"p_max: must be a positive pressure, got {self.p_max!r}")
        if not (math.isfinite(self.chord) and 0 <= self.chord < 1):
            raise SpecError(f"chord: expected a residual ratio in [0, 1), got {self.chord!r}")



def retraced(pressures: Sequence[float], states: Sequence[np.ndarray], *, rel: float = 0.1,
             skip: int = 4) -> bool:
    """Whether the last two points lie back on the path already traced: each within
    ``rel`` of its own step length from a segment between two earlier points (not among
    its ``skip`` predecessors) whose pressure range holds its pressure.

    Continuation retraces a path when it turns round at a branch point (e.g. two equal
    chambers on one line past their limit point); a fold does not trigger it (past a limit
    point the states go on changing)."""
    k = len(states) - 1
    if k < skip + 2:
        return False
    for i in (k, k - 1):
        x, p = np.ravel(states[i]), pressures[i]
        step = float(np.linalg.norm(x - np.ravel(states[i - 1])))
        if step == 0.0:
            return False
        near = False
        for j in range(i - skip):
            lo, hi = sorted((pressures[j], pressures[j + 1]))
            if not lo - 1e-12 * abs(p) <= p <= hi + 1e-12 * abs(p):
                continue
            a, b = np.ravel(states[j]), np.ravel(states[j + 1])
            d = b - a
            dd = float(d @ d)
            t = min(max(float((x - a) @ d) / dd, 0.0), 1.0) if dd > 0 else 0.0
            if np.linalg.norm(a + t * d - x) < rel * step:
                near = True
                break
        if not near:
            return False
    return True


def path_end(pressures: list[float], method: str, p_max: float, after_limit: bool,
             states: Sequence[np.ndarray] | None = None) -> str:
    """Why a path ends at its last recorded point ("" to go on): with ``after_limit``, once
    the pressure fell 0.5 % below its maximum with three points past it; on a continuation
    point at or above ``p_max`` (Pa) with the pressure still rising; at a negative pressure
    (an inflation path that came back through P = 0 is continuation retracing its steps,
    which it can do at a branch point such as two equal chambers past their limit point);
    on a continuation point back on the path already traced (:func:`retraced`, given the
    recorded ``states``).
    """
    if len(pressures) > 1 and pressures[-1] < 0.0 < max(pressures):
        return "turned back through P = 0 (the continuation retraced the path)"
    if states is not None and method == "arc-length" and retraced(pressures, states):
        return "retraced the path (continuation turned round, e.g. at a branch point)"
    if after_limit:
        top = int(np.argmax(pressures))
        if pressures[-1] < 0.995 * pressures[top] and len(pressures) - top >= 3:
            return "passed the limit point"
    if (method == "arc-length" and pressures[-1] >= p_max and len(pressures) > 2
            and pressures[-1] >= pressures[-2]):
        return "reached p_max"
    return ""


def _merge(a: PathRun, b: PathRun) -> PathRun:
    a.points += b.points
    a.attempts += b.attempts
    a.cutbacks += b.cutbacks
    a.newton_iterations += b.newton_iterations
    a.wall_time += b.wall_time
    a.tangents_reused += b.tangents_reused
    a.chord_steps += b.chord_steps
    a.restarts += b.restarts
    a.status, a.message = b.status, b.message
    return a


#: how a path that turned round is restarted from its turning point, in turn: rising
#: pressure in control (contique's start), then secant jumps of one and two steps ahead in
#: the direction of the step that reached it
RETRACE_RESTARTS: tuple[float | None, ...] = (None, 1.0, 2.0)


class _TurnWatch:
    """The states of a path as recorded, to catch continuation turning round (see
    :func:`retraced`) before the point that shows it is recorded."""

    def __init__(self, x_start: np.ndarray) -> None:
        self.pressures = [0.0]
        self.states = [np.asarray(x_start)]
        self.pending: PathPoint | None = None
        self.restarts = 0
        self.floor = 1  # the last restart's point: a later turn never cuts behind it

    def accept(self, point: PathPoint) -> None:
        self.pressures.append(point.pressure)
        self.states.append(point.x)

    def turns(self, point: PathPoint) -> bool:
        return retraced([*self.pressures, point.pressure], [*self.states, point.x])

    def apex(self) -> int:
        """How many recorded points to keep: up to the last one where the path's direction
        reversed (the turning point), before the points that walk back."""
        states = [*self.states, self.pending.x] if self.pending is not None else self.states
        for k in range(len(states) - 2, self.floor - 1, -1):
            if float((states[k + 1] - states[k]) @ (states[k] - states[k - 1])) < 0.0:
                return k
        return max(len(self.states) - 3, self.floor)

    def cut(self, n: int) -> None:
        del self.pressures[n + 1:]
        del self.states[n + 1:]
        self.pending = None
        self.floor = n


def _last_step(points: list[PathPoint], x_start: np.ndarray,
               ) -> tuple[PathPoint, np.ndarray, float]:
    """The last point and the state and pressure of the point before it (the start)."""
    last = points[-1]
    if len(points) > 1:
        return last, points[-2].x, points[-2].pressure
    return last, x_start, 0.0


def _resume_steps(saved: list[PathPoint], x_start: np.ndarray, p_end: float,
                  ) -> tuple[float, float, tuple[float, np.ndarray] | None]:
    """Where pressure stepping goes on from: the start pressure, the first step and the
    previous point of the secant predictor (none saved: from 0 with p_end/20)."""
    if not saved:
        return 0.0, p_end / 20, None
    last, x_before, p_before = _last_step(saved, x_start)
    dp0 = p_end / 20
    step = last.pressure - p_before
    if step > 0:  # as pressure_control would go on: ×1.5 after an easy step
        dp0 = min(step * (1.5 if last.iterations <= 5 else 1.0), p_end / 8)
    return last.pressure, dp0, (p_before, x_before)


def trace_path(problem: PressureProblem, solver: LinearSolver, settings: FESettings,
               p_end: float, on_point: Callable[[PathPoint], bool], *,
               checkpoint: PathCheckpoint | None = None,
               truncate: Callable[[int], None] | None = None) -> PathRun:
    """Trace a pressure path to ``p_end`` (units of the problem) as ``settings.method`` says.

    ``"auto"``: pressure steps (Δp from p_end/20, down to p_end/400, up to p_end/8), handing
    over to arc-length continuation at the first failed step (a limit point, a steep
    ballooning branch, or a trial state past the elastomer's lock-up: continuation bounds
    every increment, where halving pressure steps would crowd the path with points);
    ``"pressure"``: steps only; ``"arc-length"``: continuation from 0.
    ``on_point`` sees every converged point and may stop the path (returns True).

    With a ``checkpoint`` every converged point is saved before ``on_point`` sees it, and
    the points a previous (interrupted) run saved there are handed to ``on_point`` first;
    the path then goes on from the last of them: pressure steps with the step size and
    secant predictor they would have had, or, once the path was on continuation, contique
    in the direction of the last step and with increments as large as its (contique's
    step-control history is not kept, so the points that follow may differ).

    With ``truncate`` (the caller drops all but its first ``n`` recorded points), a
    continuation that turns round and walks back down its own path (:func:`retraced`; it
    can at a branch point, where contique's next step converges on the path behind) is
    restarted from the turning point: the points that walked back are dropped, and
    contique starts again there with the rising pressure in control (which can find a
    stable rising branch that meets the falling one where contique turned); should that
    turn round too, from secant jumps ahead (:data:`RETRACE_RESTARTS`). After as many
    restarts the path ends there as retraced.
    """
    x_start = problem.get_x()
    saved = checkpoint.load(problem.nfree) if checkpoint is not None else []
    watch = _TurnWatch(x_start)

    def record(point: PathPoint) -> bool:
        if (truncate is not None and point.method == "arc-length"
                and watch.restarts < len(RETRACE_RESTARTS) and watch.turns(point)):
            watch.pending = point  # not recorded: the continuation stops, and restarts
            return True
        watch.accept(point)
        if checkpoint is not None:
            checkpoint.save(point)
        return on_point(point)

    run = PathRun()
    for point in saved:
        run.points.append(point)
        watch.accept(point)
        if on_point(point):
            run.status = Outcome.STOPPED
            return run
    on_arc = settings.method == "arc-length" or bool(saved and saved[-1].method == "arc-length")

    def steps_left() -> int:
        return max(settings.max_steps - len(run.points), 1)

    def go_on(p_from: float, direction: np.ndarray | None) -> PathRun:
        return continuation(problem, p_from, solver, dx_max=settings.dx_max,
                            dp_max=settings.dp_max, chord=settings.chord,
                            max_steps=steps_left(), on_point=record, direction=direction)

    if not on_arc:
        p0, dp0, prev = _resume_steps(saved, x_start, p_end)
        if saved:
            problem.set_x(saved[-1].x)
        more = pressure_control(problem, p_end, solver, p_start=p0, dp0=dp0,
                                dp_min=p_end / 400, dp_max=p_end / 8, tol=settings.tol,
                                max_steps=steps_left(), maxiter=8,
                                max_cutbacks=1 if settings.method == "auto" else None,
                                on_point=record, prev=prev)
        run = _merge(run, more)
    if settings.method == "arc-length" or (
            settings.method == "auto" and (on_arc or run.status == Outcome.STALLED)):
        p_start = run.points[-1].pressure if run.points else 0.0
        direction = None
        if run.points:
            problem.set_x(run.points[-1].x)
            if on_arc and saved and len(run.points) == len(saved):  # resumed on continuation
                last, x_before, p_before = _last_step(run.points, x_start)
                direction = np.append(last.x - x_before, last.pressure - p_before)
        run = _merge(run, go_on(p_start, direction))
        while watch.pending is not None and truncate is not None:
            keep = watch.apex()
            del run.points[keep:]
            watch.cut(keep)
            if checkpoint is not None:
                checkpoint.truncate(keep)
            truncate(keep)
            last, x_before, p_before = _last_step(run.points, x_start)
            jump = RETRACE_RESTARTS[watch.restarts]
            watch.restarts += 1
            run.restarts += 1
            if jump is None:   # from the turning point, rising pressure in control
                problem.set_x(last.x)
                p_from, direction = last.pressure, None
            else:              # from a secant jump ahead, the same way on
                problem.set_x(last.x + jump * (last.x - x_before))
                p_from = last.pressure + jump * (last.pressure - p_before)
                direction = np.append(last.x - x_before, last.pressure - p_before)
            run = _merge(run, go_on(p_from, direction))
    return run
