"""The run every FE analysis shares: mesh → problem → solver → recorder → path → statistics.

An analysis (a cell, a device, a twisting module) supplies its mesh and a :class:`Measure`
that turns a converged state into one row of numbers. :func:`run_path` builds the
nondimensional FE problem from the mesh, traces the path with the one driver
(:func:`~multimorph.fe.engine.trace_path`), records every point through the one
:class:`PathRecorder`, whose :class:`StopRules` end every analysis' path alike, and returns
the rows with the run's statistics. The analysis then reads its response from the rows.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, Protocol

import numpy as np

from multimorph.errors import MultimorphError
from multimorph.fe._deps import require
from multimorph.fe.analyses._measure import largest_stretch
from multimorph.fe.engine import (
    FESettings,
    PathCheckpoint,
    PathPoint,
    PathRun,
    PressureProblem,
    make_solver,
    path_end,
    trace_path,
)
from multimorph.fe.mesh import HexMesh
from multimorph.response import Response

__all__ = ["Measure", "Measured", "PathRecord", "PathRecorder", "Progress", "StopRules",
           "activation", "mesh_problem", "reached", "run_path"]

#: ``progress(pressure_Pa, n_points)``, called after every recorded point
Progress = Callable[[float, int], None]


@dataclass(frozen=True, eq=False)
class Measured:
    """What an analysis measured at one converged point.

    Attributes
    ----------
    row : dict
        The analysis' own numbers (SI units, angles in rad).
    displacement : ndarray (npoints, 3)
        The nodal displacements (m) to keep for this point.
    volume_ratio : ndarray (k,)
        Chamber volume over its initial volume, per chamber group (one group, or one per
        module of a device).
    """

    row: dict[str, Any]
    displacement: np.ndarray
    volume_ratio: np.ndarray


class Measure(Protocol):
    """Measures a converged state of one analysis (a cell, a device, a twisting module)."""

    def __call__(self, displacement: np.ndarray, stretch: np.ndarray,
                 previous: dict[str, Any] | None) -> Measured:
        """Measure the state with nodal ``displacement`` (m, a copy the measure may change)
        and largest principal ``stretch`` (quadrature points × elements); ``previous`` is
        the last recorded row (``None`` at the start), for angles continuous along the
        path."""
        ...


@dataclass(frozen=True)
class StopRules:
    """When a path ends, for every FE analysis: a chamber volume ratio or the peak stretch
    past its limit, or :func:`~multimorph.fe.engine.path_end` (past the limit point with
    ``after_limit``, at ``p_max`` on continuation, turned back, retraced).

    Parameters
    ----------
    p_max : float
        Highest pressure (Pa).
    max_volume_ratio : float
        Largest chamber volume over its initial volume (every chamber group).
    max_stretch : float or None
        Largest principal stretch anywhere.
    after_limit : bool
        Stop once the path has passed a pressure maximum.
    groups : tuple of str, optional
        Names of the chamber groups (a device's modules), for the stop reason.
    """

    p_max: float
    max_volume_ratio: float
    max_stretch: float | None
    after_limit: bool = False
    groups: tuple[str, ...] | None = None

    def reason(self, pressures: list[float], method: str, states: Sequence[np.ndarray],
               volume_ratio: np.ndarray, peak: float) -> str:
        """Why the path ends at its last point (``""``: it goes on)."""
        ratio = np.atleast_1d(volume_ratio)
        if ratio.max() > self.max_volume_ratio:
            where = f" of module {self.groups[int(np.argmax(ratio))]!r}" if self.groups else ""
            return f"chamber volume ratio{where} exceeded {self.max_volume_ratio:g}"
        if self.max_stretch is not None and peak > self.max_stretch:
            return f"peak stretch exceeded {self.max_stretch:g}"
        return path_end(pressures, method, self.p_max, self.after_limit, states)


class PathRecorder:
    """Records every converged point of a path and decides when it stops: the one recorder
    of every FE analysis.

    Each point is measured by the analysis' :class:`Measure`; the recorder keeps its row
    (with ``pressure`` in Pa, ``stable``, ``iterations`` and ``arc_length`` added), the
    displacements (m) and the elements' largest principal stretch (mean over their
    quadrature points), and asks :class:`StopRules` whether to stop (:attr:`stop_reason`).
    The undeformed state is recorded first.

    Parameters
    ----------
    problem : PressureProblem
    measure : Measure
    stops : StopRules
    length, stress : float
        The problem's units: length (m) and stress (Pa).
    progress : callable, optional
        ``progress(pressure_Pa, n_points)`` after every recorded point.
    """

    def __init__(self, problem: PressureProblem, measure: Measure, stops: StopRules, *,
                 length: float, stress: float, progress: Progress | None = None) -> None:
        self.problem, self.measure, self.stops = problem, measure, stops
        self.length, self.stress, self.progress = length, stress, progress
        self.rows: list[dict[str, Any]] = []
        self.displacements: list[np.ndarray] = []
        self.element_stretch: list[np.ndarray] = []
        self.stop_reason = ""
        self.add(PathPoint(0.0, problem.get_x(), 0, True, "start"))

    def add(self, point: PathPoint) -> bool:
        """Measure and keep a converged point; True when the path should stop there."""
        self.problem.set_x(point.x)
        displacement = self.problem.values.copy() * self.length
        stretch = largest_stretch(self.problem.deformation_gradient())  # (q, cells)
        measured = self.measure(displacement, stretch, self.rows[-1] if self.rows else None)
        pressure = point.pressure * self.stress
        self.rows.append({
            "pressure": pressure, **measured.row,
            "stable": bool(point.stable) if point.stable is not None else True,
            "iterations": point.iterations, "arc_length": point.method == "arc-length"})
        self.displacements.append(measured.displacement)
        self.element_stretch.append(stretch.mean(axis=0))
        if self.progress is not None:
            self.progress(pressure, len(self.rows))
        self.stop_reason = self.stops.reason([row["pressure"] for row in self.rows],
                                             point.method, self.displacements,
                                             measured.volume_ratio, float(stretch.max()))
        return bool(self.stop_reason)

    def truncate(self, n: int) -> None:
        """Keep the start and the first ``n`` path points (a continuation that walked back
        is restarted from its turning point)."""
        del self.rows[n + 1:]
        del self.displacements[n + 1:]
        del self.element_stretch[n + 1:]
        self.stop_reason = ""

    def column(self, key: str) -> np.ndarray:
        """One quantity at every recorded point, as an array (rows stacked)."""
        return np.array([row[key] for row in self.rows])


@dataclass(frozen=True, eq=False)
class PathRecord:
    """A traced and recorded path: the problem, the recorder (rows, displacements, element
    stretches), the driver's run and the statistics every FE result carries."""

    problem: PressureProblem
    recorder: PathRecorder
    run: PathRun
    stats: dict[str, Any] = field(default_factory=dict)


def mesh_problem(mesh: HexMesh, length: float, stress: float, *,
                 ties: Sequence[tuple[Any, ...]] = (),
                 tie_stiffness: float = 0.0) -> PressureProblem:
    """The nondimensional FE problem of a mesh: lengths in units of ``length`` (m), stresses
    in units of ``stress`` (Pa); its bodies (empty ones left out), the chamber faces under
    pressure, its clamped and mirror DOF fixed, and rigid ``ties``
    (:class:`~multimorph.fe.engine.PressureProblem`)."""
    fem = require("felupe")
    bodies = [(cells, material.scaled(1.0 / stress)) for cells, material in mesh.bodies()]
    return PressureProblem(fem.Mesh(mesh.points / length, mesh.cells, "hexahedron"),
                           [(cells, material) for cells, material in bodies if len(cells)],
                           mesh.chamber_points, mesh.fixed(), ties=ties,
                           tie_stiffness=tie_stiffness)


def run_path(mesh: HexMesh, measure: Measure, settings: FESettings, *, p_max: float,
             length: float, stress: float, max_stretch: float | None, started: float,
             groups: tuple[str, ...] | None = None, progress: Progress | None = None,
             checkpoint: PathCheckpoint | None = None,
             ties: Sequence[tuple[Any, ...]] = (), tie_stiffness: float = 0.0,
             head: dict[str, Any] | None = None, tail: dict[str, Any] | None = None,
             ) -> PathRecord:
    """Build the FE problem of ``mesh``, trace and record its pressure path up to ``p_max``.

    Parameters
    ----------
    mesh : HexMesh
    measure : Measure
        What the analysis measures at every point.
    settings : FESettings
        Path method, solver, tolerances and stop limits.
    p_max : float
        Highest pressure (Pa).
    length, stress : float
        The problem's units (m, Pa; :func:`mesh_problem`).
    max_stretch : float or None
        Stop past this largest principal stretch.
    started : float
        ``time.perf_counter()`` when the analysis began (for ``wall_time``).
    groups : tuple of str, optional
        Names of the chamber groups (:class:`StopRules`).
    progress : callable, optional
        ``progress(pressure_Pa, n_points)`` after every recorded point.
    checkpoint : PathCheckpoint, optional
        Save every converged point there; resume from an interrupted run's points.
    ties, tie_stiffness
        Rigid joints of the mesh (:func:`mesh_problem`).
    head, tail : dict, optional
        The analysis' own statistics, before and after the common ones.

    Returns
    -------
    PathRecord

    Raises
    ------
    MultimorphError
        When no equilibrium beyond P = 0 was found.
    """
    problem = mesh_problem(mesh, length, stress, ties=ties, tie_stiffness=tie_stiffness)
    solver = make_solver(settings.solver)
    stops = StopRules(p_max, settings.max_volume_ratio, max_stretch, settings.stop_after_limit,
                      groups)
    recorder = PathRecorder(problem, measure, stops, length=length, stress=stress,
                            progress=progress)
    try:
        run = trace_path(problem, solver, settings, p_max / stress, recorder.add,
                         checkpoint=checkpoint, truncate=recorder.truncate)
    finally:
        solver.release()
    if len(recorder.rows) < 2:
        raise MultimorphError(f"FE analysis found no equilibrium beyond P = 0: {run.message}")
    stats = {
        "backend": "fe", **(head or {}), "ndof": int(mesh.ndof), "nfree": int(problem.nfree),
        "ncells": int(mesh.ncells), "points": len(recorder.rows) - 1,
        "attempts": run.attempts, "cutbacks": run.cutbacks,
        "newton_iterations": run.newton_iterations, "status": run.status,
        "message": run.message, "stop_reason": recorder.stop_reason, "solver": solver.name,
        "solve_time": solver.time, "solves": solver.calls, "analyses": solver.analyses,
        "factorisations": solver.factorisations, "tangents_reused": run.tangents_reused,
        "chord_steps": run.chord_steps, "restarts": run.restarts,
        "assembly_time": problem.stats.time, "wall_time": time.perf_counter() - started,
        "resumed_points": checkpoint.resumed if checkpoint is not None else 0,
        **(tail or {}), "settings": asdict(settings),
    }
    return PathRecord(problem, recorder, run, stats)


def reached(value: float | None, response: Response) -> float | None:
    """``value`` unless it sits at either end of the loading curve: a steepest rise read at
    the highest pressure traced is a curve still steepening, one read at P ≈ 0 a curve with
    no activation in range (within 1 % of the range)."""
    if value is None:
        return None
    top = float(np.max(response.loading.pressure))
    return value if 0.01 * top < value < 0.99 * top else None


def activation(response: Response) -> tuple[float | None, float | None]:
    """A response's Pc and Ph (Pa), ``None`` where not reached (:func:`reached`); a Ph
    without a Pc is none."""
    c = response.characteristic
    pc = reached(c.critical, response)
    return pc, (None if pc is None else reached(c.hardening, response))
