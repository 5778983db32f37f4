"""3D FE analysis of a unit cell or a module of cells in series: what is measured at every
converged point, and the response.

Internally the problem is nondimensional: lengths in units of the cell length d and stresses
in units of the wall shear modulus μ (``Material.scaled(1/μ)``), so Newton tolerances and
step sizes mean the same for every cell. Results are converted back to SI.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from multimorph.errors import SpecError
from multimorph.fe.analyses._measure import (
    bend_and_twist,
    chamber_volume,
    circle_fit_curvature,
    line_stretch,
    peak_element,
    strip_strain,
    unwrapped,
)
from multimorph.fe.analyses._run import Measured, mesh_problem, run_path
from multimorph.fe.engine import FESettings, PathCheckpoint, PressureProblem
from multimorph.fe.mesh import CellMesh, cell_mesh
from multimorph.geometry import CellGeometry
from multimorph.response import EquilibriumPath, Response, build_response

__all__ = ["CELL_ENDS", "STRIP_KEYS", "CellMeasure", "FEResult", "build_cell_problem",
           "simulate_cell"]

#: How the free end of a cell (or module) is held: ``"free"``, or ``"plate"``: its end face
#: tied to a rigid plate that may move and turn (a penalty multi-point constraint with a
#: rotation point): the end section moves and turns but keeps its shape, so no lone end wall
#: bulges under one-sided pressure (the FE reference sets before stop 31 used it for a cell
#: "as inside a module"; for one-elastomer cells it is up to 35 % too stiff on Pc).
#: ``"mirror"``: both end faces are mirror planes, the clamp face held on y = 0 and the end
#: face on a plane that moves and turns, both free to stretch in their planes (a straight
#: half model): the periodic cell of a long module, whose partitions and bottom layer
#: stretch sideways at the cell boundaries, which a plate's rigid section does not let them.
CELL_ENDS = ("free", "plate", "mirror")

#: the strip's mean in-plane strains a full model records (``path.extra``)
STRIP_KEYS = ("shear", "shear_slope", "strip_axial_strain", "strip_lateral_strain",
              "strip_rotation")


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


def end_plate(mesh: CellMesh) -> tuple[list[tuple[Any, ...]], float]:
    """The tie of a plated mesh's end face (:meth:`CellMesh.with_end_plate`: rigid, or a
    :class:`~multimorph.fe.engine.PlaneTie` for mirror ends) and its
    penalty stiffness (nondimensional): 10³ × the stiffest material's μ over the wall
    material's, times the smallest element edge over d (as the hubs of a device)."""
    if mesh.plate is None:
        return [], 0.0
    geometry = mesh.geometry
    corners = mesh.points[mesh.cells] / geometry.length
    edge = min(float(np.linalg.norm(corners[:, k] - corners[:, 0], axis=1).min())
               for k in (1, 3, 4))
    bottom = geometry.bottom_material
    stiff = max(geometry.material.shear_modulus,
                bottom.shear_modulus if bottom is not None else 0.0)
    kind = "plane" if mesh.slide else "rigid"
    return [(np.asarray(mesh.end_face), *mesh.plate, kind)], 1e3 * stiff / geometry.mu * edge


def build_cell_problem(mesh: CellMesh, end: str = "free",
                       ) -> tuple[PressureProblem, float, float]:
    """The nondimensional FE problem of a meshed cell; returns (problem, L, μ).

    With ``end="plate"`` the free end face is tied to a rigid plate, with ``end="mirror"``
    both end faces are mirror planes (:data:`CELL_ENDS`, :meth:`CellMesh.with_end_plate`:
    two more nodes after the mesh's)."""
    mesh = _with_end(mesh, end)
    length, mu = mesh.geometry.length, mesh.geometry.mu
    ties, stiffness = end_plate(mesh)
    return mesh_problem(mesh, length, mu, ties=ties, tie_stiffness=stiffness), length, mu


def _check_end(end: str) -> None:
    if end not in CELL_ENDS:
        raise SpecError(f"end: expected one of {', '.join(CELL_ENDS)}, got {end!r}")


def _with_end(mesh: CellMesh, end: str) -> CellMesh:
    """``mesh`` with the plate nodes its ``end`` needs (:data:`CELL_ENDS`)."""
    _check_end(end)
    return mesh if end == "free" else mesh.with_end_plate(slide=end == "mirror")


class CellMeasure:
    """What a cell analysis measures at every converged point
    (:class:`~multimorph.fe.analyses.Measure`): the bottom edge's circle-fit curvature and
    arc stretch (at a free tip without the part under its end wall), the end face's bend
    and twist, the chamber volume, the peak stretch and where it is, and, for a full
    model, the strip's mean in-plane strain."""

    def __init__(self, mesh: CellMesh) -> None:
        geometry = mesh.geometry
        self.mesh = mesh
        self.V0 = geometry.wc * geometry.hc * geometry.dc * mesh.n_cells
        self.mirror_x = geometry.width / 2 if mesh.half else None
        # the strip's mean in-plane strain (full models), on the sections away from the clamp
        self.strip = None if mesh.half else mesh.strip_nodes()
        # the bend line: the bottom edge, without the part under a free tip's end wall,
        # which that wall pulls as it bulges (on a 2-cell module a bend of -0.8 rad at a
        # 0.1 % stretch, against -0.1 rad on the rest of the edge); a plate holds it
        line = np.asarray(mesh.bend_line)
        if mesh.plate is None:
            y = mesh.points[line, 1]
            inner = line[y <= mesh.length - geometry.df * (1 - 1e-9)]
            if inner.size >= 3:
                line = inner
        self.line = line

    def __call__(self, displacement: np.ndarray, stretch: np.ndarray,
                 previous: dict[str, Any] | None) -> Measured:
        mesh = self.mesh
        x = mesh.points + displacement[:len(mesh.points)]
        line = self.line
        bend, twist = bend_and_twist(mesh.points[mesh.end_face], x[mesh.end_face])
        if mesh.half:
            twist = 0.0  # zero by the mirror symmetry (a half section's fit is not)
        if previous is not None:
            bend = unwrapped(bend, previous["bend_angle"])
            twist = unwrapped(twist, previous["twist_angle"])
        volume = chamber_volume(x, mesh.chamber_faces, mirror_x=self.mirror_x)
        cell = peak_element(stretch)
        row = {
            "curvature": circle_fit_curvature(x[line, 1], x[line, 2]),
            "twist_rate": twist / mesh.length,
            "axial_stretch": line_stretch(mesh.points[line], x[line]),
            "volume": volume, "peak_stretch": float(stretch.max()),
            "bend_angle": bend, "twist_angle": twist, "volume_ratio": volume / self.V0,
            "peak_location": mesh.points[mesh.cells[cell]].mean(axis=0),  # reference centroid
            "peak_region": int(mesh.region[cell]),
        }
        if self.strip is not None:
            nodes, weights = self.strip
            strain = strip_strain(mesh.points[nodes], x[nodes], weights)
            row.update({"shear": strain.shear, "shear_slope": strain.slope,
                        "strip_axial_strain": strain.axial,
                        "strip_lateral_strain": strain.lateral,
                        "strip_rotation": strain.rotation})
        return Measured(row, displacement, np.atleast_1d(volume / self.V0))

    def path(self, column: Callable[[str], np.ndarray]) -> EquilibriumPath:
        """The recorded path (``column(key)``: one quantity at every point)."""
        extra = {key: column(key) for key in ("bend_angle", "twist_angle", "volume_ratio",
                                              "peak_region")}
        extra["newton_iterations"] = column("iterations")
        extra["arc_length"] = column("arc_length")
        if self.strip is not None:
            extra.update({key: column(key) for key in STRIP_KEYS})
        extra["peak_location"] = column("peak_location")
        return EquilibriumPath(
            pressure=column("pressure"), curvature=column("curvature"),
            twist_rate=column("twist_rate"), axial_stretch=column("axial_stretch"),
            volume=column("volume"), peak_stretch=column("peak_stretch"),
            stable=column("stable").astype(bool), extra=extra)


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
        with the same key saved (:func:`~multimorph.fe.engine.trace_path`);
        ``stats["resumed_points"]``.
    end : {"free", "plate"}
        How the free end is held (:data:`CELL_ENDS`): free, or tied to a rigid plate that
        moves and turns (a cell as inside a module: the FE reference data set of the
        calibrated model uses it).

    Notes
    -----
    A full model (``half=False``) also records the strip's mean in-plane strain in
    ``path.extra`` (:func:`~multimorph.fe.strip_strain` over the cross-sections
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
    _check_end(end)
    settings = settings or FESettings()
    started = time.perf_counter()
    mesh = cell_mesh(geometry, settings.mesh, element_size=settings.element_size,
                     half=settings.half, n_cells=n_cells, tilt=tilt)
    mesh = _with_end(mesh, end)
    ties, stiffness = end_plate(mesh)
    mu = geometry.mu
    p_max = settings.p_max if settings.p_max is not None else mu
    measure = CellMeasure(mesh)
    record = run_path(
        mesh, measure, settings, p_max=p_max, length=geometry.length, stress=mu,
        max_stretch=(settings.max_stretch if settings.max_stretch is not None
                     else geometry.material.break_stretch),
        started=started, progress=progress, checkpoint=checkpoint, ties=ties,
        tie_stiffness=stiffness,
        head={"n_cells": int(mesh.n_cells), "tilt": float(mesh.tilt), "end": end})
    recorder = record.recorder
    response = build_response(measure.path(recorder.column), length=mesh.length,
                              shear_modulus=mu, backend="fe",
                              break_stretch=geometry.material.break_stretch, meta=record.stats,
                              signal=geometry.signal)
    return FEResult(response=response, mesh=mesh, displacements=np.array(recorder.displacements),
                    stretch=np.array(recorder.element_stretch), stats=record.stats)
