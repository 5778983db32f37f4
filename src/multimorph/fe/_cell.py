"""3D FE analysis of a unit cell: mesh, model, path, measurements, :class:`Response`.

Internally the problem is nondimensional: lengths in units of the cell length d and stresses
in units of the wall shear modulus μ (``Material.scaled(1/μ)``), so Newton tolerances and
step sizes mean the same for every cell. Results are converted back to SI.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from multimorph.errors import MultimorphError, SpecError
from multimorph.fe._checkpoint import PathCheckpoint
from multimorph.fe._deps import require
from multimorph.fe._linsolve import LinearSolver, make_solver
from multimorph.fe._measure import (
    bend_and_twist,
    chamber_volume,
    circle_fit_curvature,
    largest_stretch,
    line_stretch,
    peak_element,
    strip_strain,
)
from multimorph.fe._mesh import BOTTOM, WALL, CellMesh, MeshDensity, cell_mesh
from multimorph.fe._problem import PressureProblem
from multimorph.fe._solve import PathPoint, PathRun, continuation, pressure_control
from multimorph.geometry import CellGeometry
from multimorph.response import EquilibriumPath, Response, build_response

__all__ = ["FEResult", "FESettings", "build_cell_problem", "simulate_cell"]


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


@dataclass(frozen=True, eq=False)
class FEResult:
    """An FE cell analysis: the shared :class:`Response` plus what the outputs need.

    Attributes
    ----------
    response : Response
        ``backend="fe"``; the path in SI units, observed curves, characteristic pressures.
    mesh : CellMesh
    displacements : ndarray (n, npoints, 3)
        Nodal displacements (m) at every path point (row 0: the undeformed state).
    stretch : ndarray (n, ncells)
        Largest principal stretch per cell (cell average) at every path point.
    stats : dict
        Solver statistics (DOF, steps, Newton iterations, times, solver name, status).
    """

    response: Response
    mesh: CellMesh
    displacements: np.ndarray
    stretch: np.ndarray
    stats: dict[str, Any] = field(default_factory=dict)


#: How the free end of a cell (or module) is held: ``"free"``, or ``"plate"`` — its end face
#: tied to a rigid plate that may move and turn (a penalty multi-point constraint with a
#: rotation point). A plate makes a lone cell behave as a cell inside a module: there the
#: mid-plane of every partition stays a plane section (mirror symmetry of uniform bending),
#: as the clamp holds the other end, and no lone end wall bulges under one-sided pressure.
CELL_ENDS = ("free", "plate")


def build_cell_problem(mesh: CellMesh, end: str = "free",
                       ) -> tuple[PressureProblem, float, float]:
    """The nondimensional FE problem of a meshed cell; returns (problem, L, μ).

    With ``end="plate"`` the problem has two extra nodes after the mesh's (the plate's centre
    at the end face's centroid and its rotation node); a half model turns its plate about
    x only and keeps its centre on the mirror plane.
    """
    if end not in CELL_ENDS:
        raise SpecError(f"end: expected one of {', '.join(CELL_ENDS)}, got {end!r}")
    fem = require("felupe")
    g = mesh.geometry
    L, mu = g.length, g.mu
    points = mesh.points / L
    n = len(points)
    ties: list[tuple[np.ndarray, int, int]] = []
    if end == "plate":
        centre = points[mesh.end_face].mean(axis=0)
        if mesh.half:
            centre[0] = g.width / 2 / L
        points = np.vstack([points, centre, centre])
        ties = [(np.asarray(mesh.end_face), n, n + 1)]
    fmesh = fem.Mesh(points, mesh.cells, "hexahedron")
    fixed = np.zeros((len(points), 3), dtype=bool)
    fixed[:n][mesh.clamped] = True
    fixed[:n][mesh.mirror, 0] = True
    if end == "plate" and mesh.half:
        fixed[n, 0] = True          # the centre stays on the mirror plane
        fixed[n + 1, 1:] = True     # the plate turns about x only
    assert g.bottom_material is not None
    bodies = [(np.flatnonzero(mesh.region == WALL), g.material.scaled(1.0 / mu)),
              (np.flatnonzero(mesh.region == BOTTOM), g.bottom_material.scaled(1.0 / mu))]
    bodies = [(c, m) for c, m in bodies if len(c)]
    stiffness = 0.0
    if ties:  # 10³ × the stiffest material's μ h over the smallest edge h (as device hubs)
        e = points[mesh.cells]
        h = min(float(np.linalg.norm(e[:, k] - e[:, 0], axis=1).min()) for k in (1, 3, 4))
        stiffness = 1e3 * max(g.material.shear_modulus,
                              g.bottom_material.shear_modulus) / mu * h
    mask = np.concatenate([mesh.chamber_points, np.zeros(len(points) - n, dtype=bool)])
    return PressureProblem(fmesh, bodies, mask, fixed, ties=ties,
                           tie_stiffness=stiffness), L, mu


_STRIP_KEYS = ("shear", "shear_slope", "strip_axial_strain", "strip_lateral_strain",
               "strip_rotation")


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


class _Recorder:
    """Measures every converged point and decides when to stop."""

    def __init__(self, mesh: CellMesh, problem: PressureProblem, L: float, mu: float,
                 p_max: float, max_volume_ratio: float, max_stretch: float | None,
                 progress: Callable[[float, int], None] | None,
                 stop_after_limit: bool = False) -> None:
        self.stop_after_limit = stop_after_limit
        self.mesh, self.problem, self.L, self.mu = mesh, problem, L, mu
        self.p_max = p_max
        self.max_volume_ratio = max_volume_ratio
        self.max_stretch = max_stretch
        self.progress = progress
        g = mesh.geometry
        self.V0 = g.wc * g.hc * g.dc * mesh.n_cells
        self.rows: list[dict[str, Any]] = []
        self.u: list[np.ndarray] = []
        self.cell_stretch: list[np.ndarray] = []
        self.stop_reason = ""
        # the strip's mean in-plane strain (full models), on the sections away from the clamp
        self.strip = None if mesh.half else mesh.strip_nodes()
        self.add(PathPoint(0.0, problem.get_x(), 0, True, "start"))

    def add(self, pt: PathPoint) -> bool:
        m, g = self.mesh, self.mesh.geometry
        self.problem.set_x(pt.x)
        u = self.problem.values[:len(m.points)].copy() * self.L
        x = m.points + u
        line = m.bend_line
        kappa = circle_fit_curvature(x[line, 1], x[line, 2])
        bend, twist = bend_and_twist(m.points[m.end_face], x[m.end_face])
        if m.half:
            twist = 0.0  # zero by the mirror symmetry (a half section's fit is not)
        if self.rows:
            # continuous along the path: a module may bend or twist past ±180°
            turn = 2.0 * math.pi
            bend += turn * round((self.rows[-1]["bend_angle"] - bend) / turn)
            twist += turn * round((self.rows[-1]["twist_angle"] - twist) / turn)
        vol = chamber_volume(x, m.chamber_faces, mirror_x=g.width / 2 if m.half else None)
        F = self.problem.deformation_gradient()
        ev = largest_stretch(F)  # (q, cells)
        cell = peak_element(ev)
        lam = float(ev.max())
        cs = ev.mean(axis=0)
        loc = m.points[m.cells[cell]].mean(axis=0)
        self.rows.append({
            "pressure": pt.pressure * self.mu, "curvature": kappa,
            "twist_rate": twist / m.length,
            "axial_stretch": line_stretch(m.points[line], x[line]),
            "volume": vol, "peak_stretch": lam,
            "stable": bool(pt.stable) if pt.stable is not None else True,
            "bend_angle": bend, "twist_angle": twist, "volume_ratio": vol / self.V0,
            "peak_x": loc[0], "peak_y": loc[1], "peak_z": loc[2],
            "peak_region": int(m.region[cell]), "newton_iterations": pt.iterations,
            "arc_length": pt.method == "arc-length",
        })
        if self.strip is not None:
            nodes, weights = self.strip
            st = strip_strain(m.points[nodes], x[nodes], weights)
            self.rows[-1].update({"shear": st.shear, "shear_slope": st.slope,
                                  "strip_axial_strain": st.axial,
                                  "strip_lateral_strain": st.lateral,
                                  "strip_rotation": st.rotation})
        self.u.append(u)
        self.cell_stretch.append(cs)
        if self.progress is not None:
            self.progress(pt.pressure * self.mu, len(self.rows))
        if vol / self.V0 > self.max_volume_ratio:
            self.stop_reason = f"chamber volume ratio exceeded {self.max_volume_ratio:g}"
            return True
        if self.max_stretch is not None and lam > self.max_stretch:
            self.stop_reason = f"peak stretch exceeded {self.max_stretch:g}"
            return True
        self.stop_reason = path_end([row["pressure"] for row in self.rows], pt.method,
                                    self.p_max, self.stop_after_limit, self.u)
        return bool(self.stop_reason)

    def path(self) -> EquilibriumPath:
        r = self.rows
        arr = {k: np.array([row[k] for row in r]) for k in r[0]}
        extra = {k: arr[k] for k in ("bend_angle", "twist_angle", "volume_ratio",
                                     "peak_region", "newton_iterations", "arc_length",
                                     *_STRIP_KEYS) if k in arr}
        extra["peak_location"] = np.column_stack([arr["peak_x"], arr["peak_y"], arr["peak_z"]])
        return EquilibriumPath(
            pressure=arr["pressure"], curvature=arr["curvature"],
            twist_rate=arr["twist_rate"], axial_stretch=arr["axial_stretch"],
            volume=arr["volume"], peak_stretch=arr["peak_stretch"],
            stable=arr["stable"].astype(bool), extra=extra)


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

    def accept(self, pt: PathPoint) -> None:
        self.pressures.append(pt.pressure)
        self.states.append(pt.x)

    def turns(self, pt: PathPoint) -> bool:
        return retraced([*self.pressures, pt.pressure], [*self.states, pt.x])

    def apex(self) -> int:
        """How many recorded points to keep: up to the last one where the path's direction
        reversed (the turning point), before the points that walk back."""
        s = [*self.states, self.pending.x] if self.pending is not None else self.states
        for m in range(len(s) - 2, self.floor - 1, -1):
            if float((s[m + 1] - s[m]) @ (s[m] - s[m - 1])) < 0.0:
                return m
        return max(len(self.states) - 3, self.floor)

    def cut(self, n: int) -> None:
        del self.pressures[n + 1:]
        del self.states[n + 1:]
        self.pending = None
        self.floor = n


def drop_points(recorder: Any, n: int) -> None:
    """Keep a recorder's start row and its first ``n`` path points (``rows``, ``u``,
    ``cell_stretch``)."""
    for name in ("rows", "u", "cell_stretch"):
        del getattr(recorder, name)[n + 1:]
    recorder.stop_reason = ""


def trace_path(problem: PressureProblem, solver: LinearSolver, settings: FESettings,
               p_end: float, on_point: Callable[[PathPoint], bool], *,
               checkpoint: PathCheckpoint | None = None,
               truncate: Callable[[int], None] | None = None) -> PathRun:
    """Trace a pressure path to ``p_end`` (units of the problem) as ``settings.method`` says.

    ``"auto"``: pressure steps (Δp from p_end/20, down to p_end/400, up to p_end/8), handing
    over to arc-length continuation at the first failed step (a limit point, a steep
    ballooning branch, or a trial state past the elastomer's lock-up: continuation bounds
    every increment, where halving pressure steps cost up to a second each and, on the
    medium reference mesh, a third more points); ``"pressure"``: steps only;
    ``"arc-length"``: continuation from 0.
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
    contique starts again there with the rising pressure in control (on
    ``examples/fe_device.toml`` this finds the stable rising branch that meets the falling
    one where contique turned); should that turn round too, from secant jumps ahead
    (:data:`RETRACE_RESTARTS`). After as many restarts the path ends there as retraced.
    """
    s = settings
    x_start = problem.get_x()
    saved = checkpoint.load(problem.nfree) if checkpoint is not None else []
    watch = _TurnWatch(x_start)

    def record(pt: PathPoint) -> bool:
        if (truncate is not None and pt.method == "arc-length"
                and watch.restarts < len(RETRACE_RESTARTS) and watch.turns(pt)):
            watch.pending = pt  # not recorded: the continuation stops, and restarts
            return True
        watch.accept(pt)
        if checkpoint is not None:
            checkpoint.save(pt)
        return on_point(pt)

    run = PathRun()
    for pt in saved:
        run.points.append(pt)
        watch.accept(pt)
        if on_point(pt):
            run.status = "stopped"
            return run
    p0, dp0, prev = 0.0, p_end / 20, None
    on_arc = s.method == "arc-length"
    if saved:
        last = saved[-1]
        before = (saved[-2].pressure, saved[-2].x) if len(saved) > 1 else (0.0, x_start)
        problem.set_x(last.x)
        p0, prev = last.pressure, before
        on_arc = on_arc or last.method == "arc-length"
        step = last.pressure - before[0]
        if step > 0:  # as pressure_control would go on: ×1.5 after an easy step
            dp0 = min(step * (1.5 if last.iterations <= 5 else 1.0), p_end / 8)
    if not on_arc:
        more = pressure_control(problem, p_end, solver, p_start=p0, dp0=dp0,
                                dp_min=p_end / 400, dp_max=p_end / 8, tol=s.tol,
                                max_steps=max(s.max_steps - len(run.points), 1), maxiter=8,
                                max_cutbacks=1 if s.method == "auto" else None,
                                on_point=record, prev=prev)
        run = _merge(run, more)
    if s.method == "arc-length" or (s.method == "auto" and (on_arc or run.status == "stalled")):
        p_start = run.points[-1].pressure if run.points else 0.0
        direction = None
        if run.points:
            problem.set_x(run.points[-1].x)
            if on_arc and saved and len(run.points) == len(saved):  # resumed on continuation
                a = run.points[-1]
                b_p, b_x = (run.points[-2].pressure, run.points[-2].x) if len(run.points) > 1 \
                    else (0.0, x_start)
                direction = np.append(a.x - b_x, a.pressure - b_p)
        more = continuation(problem, p_start, solver, dx_max=s.dx_max, dp_max=s.dp_max,
                            chord=s.chord, max_steps=max(s.max_steps - len(run.points), 1),
                            on_point=record, direction=direction)
        run = _merge(run, more)
        while watch.pending is not None and truncate is not None:
            keep = watch.apex()
            del run.points[keep:]
            watch.cut(keep)
            if checkpoint is not None:
                checkpoint.truncate(keep)
            truncate(keep)
            a = run.points[-1]
            b_x, b_p = ((run.points[-2].x, run.points[-2].pressure) if len(run.points) > 1
                        else (x_start, 0.0))
            jump = RETRACE_RESTARTS[watch.restarts]
            watch.restarts += 1
            run.restarts += 1
            if jump is None:   # from the turning point, rising pressure in control
                problem.set_x(a.x)
                p_from, direction = a.pressure, None
            else:              # from a secant jump ahead, the same way on
                problem.set_x(a.x + jump * (a.x - b_x))
                p_from = a.pressure + jump * (a.pressure - b_p)
                direction = np.append(a.x - b_x, a.pressure - b_p)
            more = continuation(problem, p_from, solver, dx_max=s.dx_max, dp_max=s.dp_max,
                                chord=s.chord, on_point=record, direction=direction,
                                max_steps=max(s.max_steps - len(run.points), 1))
            run = _merge(run, more)
    return run


def simulate_cell(geometry: CellGeometry, settings: FESettings | None = None, *,
                  progress: Callable[[float, int], None] | None = None,
                  n_cells: int = 1, tilt: float = 0.0,
                  checkpoint: PathCheckpoint | None = None, end: str = "free") -> FEResult:
    """Inflate a unit cell (or a module of cells in series) with FE and measure it like the
    reference paper.

    Parameters
    ----------
    geometry : CellGeometry
    settings : FESettings, optional
    progress : callable, optional
        ``progress(pressure_Pa, n_points)`` after every converged point.
    n_cells : int
        Cells in series along the axis (a bending or stretching module, mounted at y = 0):
        the curvature is then the circle fit of the bottom edge over the whole module, the
        volume that of all chambers, and the response's length ``n_cells · d``.
    tilt : float
        Chamber tilt β (rad, |β| < 80°) of a twisting strip's cells: the mesh is sheared in
        the strip plane (:func:`~multimorph.fe.cell_mesh`), clamped on its sheared end face.
        Needs a full model (``FESettings(half=False)``).
    checkpoint : PathCheckpoint, optional
        Save every converged point there and resume from the points an interrupted run
        with the same key saved (:func:`trace_path`); ``stats["resumed_points"]``.
    end : {"free", "plate"}
        How the free end is held (:data:`CELL_ENDS`): free, or tied to a rigid plate that
        moves and turns (a cell as inside a module: the FE reference data set of the
        calibrated model uses it).

    Notes
    -----
    A full model (``half=False``) also records the strip's mean in-plane strain in
    ``path.extra`` (:func:`~multimorph.fe._measure.strip_strain` over the cross-sections
    between cells, away from the clamp): ``shear`` γ = ∂u_x/∂y + ∂u_y/∂x, ``shear_slope``
    ∂u_x/∂y (the centre line's lateral slope), ``strip_axial_strain`` ∂u_y/∂y,
    ``strip_lateral_strain`` ∂u_x/∂x and ``strip_rotation`` (rad).

    Returns
    -------
    FEResult
        ``result.response`` is a :class:`~multimorph.response.Response` with
        ``backend="fe"``.

    Examples
    --------
    >>> from multimorph.materials import Material
    >>> g = CellGeometry(20e-3, 10e-3, 8e-3, 1e-3, 2e-3, 2e-3, 2e-3,
    ...                  material=Material("gent", {"mu": 1e5, "jm": 30.0}))
    >>> r = simulate_cell(g, FESettings(p_max=2e4))  # doctest: +SKIP
    >>> r.response.path.curvature[-1] > 0  # doctest: +SKIP
    True
    """
    s = settings or FESettings()
    t0 = time.perf_counter()
    mesh = cell_mesh(geometry, s.mesh, element_size=s.element_size, half=s.half,
                     n_cells=n_cells, tilt=tilt)
    problem, L, mu = build_cell_problem(mesh, end)
    solver = make_solver(s.solver)
    p_max = s.p_max if s.p_max is not None else mu
    max_stretch = s.max_stretch if s.max_stretch is not None else geometry.material.break_stretch
    rec = _Recorder(mesh, problem, L, mu, p_max, s.max_volume_ratio, max_stretch, progress,
                    s.stop_after_limit)
    try:
        run = trace_path(problem, solver, s, p_max / mu, rec.add, checkpoint=checkpoint,
                         truncate=lambda n: drop_points(rec, n))
    finally:
        solver.release()
    if len(rec.rows) < 2:
        raise MultimorphError(f"FE analysis found no equilibrium beyond P = 0: {run.message}")
    path = rec.path()
    stats = {
        "backend": "fe", "n_cells": int(mesh.n_cells), "tilt": float(mesh.tilt), "end": end,
        "ndof": int(mesh.ndof),
        "nfree": int(problem.nfree),
        "ncells": int(mesh.ncells), "points": len(rec.rows) - 1, "attempts": run.attempts,
        "cutbacks": run.cutbacks, "newton_iterations": run.newton_iterations,
        "status": run.status, "message": run.message, "stop_reason": rec.stop_reason,
        "solver": solver.name, "solve_time": solver.time, "solves": solver.calls,
        "analyses": solver.analyses, "factorisations": solver.factorisations,
        "tangents_reused": run.tangents_reused, "chord_steps": run.chord_steps,
        "restarts": run.restarts,
        "assembly_time": problem.stats.time, "wall_time": time.perf_counter() - t0,
        "resumed_points": checkpoint.resumed if checkpoint is not None else 0,
        "settings": {k: (v if not isinstance(v, MeshDensity) else asdict(v))
                     for k, v in asdict(s).items()},
    }
    resp = build_response(path, length=mesh.length, shear_modulus=mu, backend="fe",
                          break_stretch=geometry.material.break_stretch, meta=stats,
                          signal=geometry.signal)
    return FEResult(response=resp, mesh=mesh, displacements=np.array(rec.u),
                    stretch=np.array(rec.cell_stretch), stats=stats)
