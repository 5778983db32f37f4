"""3D FE of a twisting module: tilted-chamber strips around a shaft, clamped at one end.

The mesh is :func:`~multimorph.fe.twisting_module_mesh`; the path is traced and
recorded like every FE analysis (:func:`~multimorph.fe.analyses.run_path`: one nearly
incompressible body per material; every chamber of every strip on one pressure line).

Measured at every converged point from node coordinates:

* **twist angle** of the free end section relative to the clamp (which does not move): the
  rotation about the deformed axis of the section's best-fit rotation
  (:func:`~multimorph.fe.bend_and_twist`), positive right-handed about +y, unwrapped along
  the path; the twist rate τ = angle / L;
* **axial stretch** 1 + ū_y / L, with ū_y the displacement along the shaft axis of the end
  section's area centroid;
* the chambers' volume and the peak principal stretch.

The module's :class:`~multimorph.response.Response` is read on the twist rate *in the sense
of the tilt*, −sign(β) · τ (positive for the twist that the tilt drives: a tilt β > 0 twists
the module left-handed about +y), so that a module and its mirror image have the same Pc
and Ph.

Scaling: lengths in units of the cell length, stresses in units of the wall shear modulus.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from multimorph.device import Module
from multimorph.fe.analyses._measure import (
    bend_and_twist,
    chamber_volume,
    peak_element,
    peak_summary,
    unwrapped,
)
from multimorph.fe.analyses._run import Measured, activation, run_path
from multimorph.fe.engine import FESettings, PathCheckpoint
from multimorph.fe.mesh import TwistMesh, twisting_module_mesh
from multimorph.response import EquilibriumPath, Response, build_response

__all__ = ["FETwistResult", "TwistMeasure", "simulate_twisting_module", "tilt_sense"]


def tilt_sense(beta: float) -> float:
    """sign(β) (1 for β = 0): a tilt β > 0 twists the module left-handed about +y (the
    strips' cells lengthen along (−sin β, cos β) in the strip frame, a negative shear of the
    shaft's surface)."""
    return -1.0 if beta < 0 else 1.0


class TwistMeasure:
    """What a twisting-module analysis measures at every converged point
    (:class:`~multimorph.fe.analyses.Measure`): the free end's twist and bend angle, its
    area centroid (axial stretch), the chamber volume and the peak stretch."""

    def __init__(self, mesh: TwistMesh, tilt: float) -> None:
        self.mesh, self.tilt = mesh, tilt
        self.V0 = chamber_volume(mesh.points, mesh.chamber_faces)
        weights = mesh.section_weights(mesh.end_section)
        self.weights = weights / np.sum(weights)

    def __call__(self, displacement: np.ndarray, stretch: np.ndarray,
                 previous: dict[str, Any] | None) -> Measured:
        mesh = self.mesh
        x = mesh.points + displacement
        end = mesh.end_section
        bend, twist = bend_and_twist(mesh.points[end], x[end])
        if previous is not None:  # continuous along the path (it may twist past ±180°)
            twist = unwrapped(twist, previous["twist_angle"])
        uy = float(self.weights @ displacement[end, 1])
        volume = chamber_volume(x, mesh.chamber_faces)
        cell = peak_element(stretch)
        row = {"twist_angle": twist, "bend_angle": bend,
               "axial_stretch": 1.0 + uy / mesh.length, "volume": volume,
               "peak": float(stretch.max()), "tip": (self.weights @ x[end]),
               "peak_location": mesh.points[mesh.cells[cell]].mean(axis=0),  # reference
               "peak_region": int(mesh.region[cell])}
        return Measured(row, displacement, np.atleast_1d(volume / self.V0))

    def path(self, column: Callable[[str], np.ndarray]) -> EquilibriumPath:
        """The recorded path, read on the twist rate in the sense of the tilt."""
        angle = column("twist_angle")
        volume = column("volume")
        return EquilibriumPath(
            pressure=column("pressure"), curvature=np.zeros(len(angle)),
            twist_rate=-tilt_sense(self.tilt) * angle / self.mesh.module.length,
            axial_stretch=column("axial_stretch"), volume=volume,
            peak_stretch=column("peak"), stable=column("stable").astype(bool),
            extra={"twist_angle": angle, "bend_angle": column("bend_angle"),
                   "volume_ratio": volume / self.V0,
                   "peak_location": column("peak_location"),
                   "peak_region": column("peak_region"),
                   "arc_length": column("arc_length")})


@dataclass(frozen=True, eq=False)
class FETwistResult:
    """An FE analysis of a twisting module.

    Attributes
    ----------
    module : Module
    mesh : TwistMesh
    response : Response
        ``backend="fe"``, read on ``signal="twist_rate"``: ``path.twist_rate`` is the twist
        rate in the sense of the tilt, −sign(β) · angle / L (rad/m); ``path.extra`` holds
        ``twist_angle`` (signed, right-handed about +y, rad), ``bend_angle`` (rad, zero by
        symmetry up to the solver's accuracy) and ``volume_ratio``.
    pressure : ndarray (n,)
        Pressure at every path point (Pa).
    twist_angle : ndarray (n,)
        Signed twist angle of the free end (rad, right-handed about +y).
    axial_stretch : ndarray (n,)
    tip : ndarray (n, 3)
        Area centroid of the free end section (m).
    displacements : ndarray (n, npoints, 3)
        Nodal displacements (m).
    stretch : ndarray (n, ncells)
        Largest principal stretch per element (mean over its Gauss points).
    stats : dict
        DOF, points, Newton iterations, solver, times (``wall_time``, ``mesh_time``, s).
    """

    module: Module
    mesh: TwistMesh
    response: Response
    pressure: np.ndarray
    twist_angle: np.ndarray
    axial_stretch: np.ndarray
    tip: np.ndarray
    displacements: np.ndarray
    stretch: np.ndarray
    stats: dict[str, Any] = field(default_factory=dict)

    def activation(self) -> tuple[float | None, float | None]:
        """Pc and Ph (Pa) on the twist rate, ``None`` where not reached (a value at either
        end of the traced range is not an activation)."""
        return activation(self.response)

    def to_dict(self, paths: bool = True) -> dict[str, Any]:
        """JSON-able summary (SI units, angles in degrees)."""
        response = self.response
        module = self.module
        out: dict[str, Any] = {
            "name": module.name, "kind": module.kind, "cells": module.n_cells,
            "strips": module.strips, "tilt_deg": math.degrees(module.tilt),
            "shaft_radius_m": module.shaft_radius, "length_m": module.length,
            "shear_modulus_pa": response.shear_modulus,
            **response.characteristic.to_dict(),
            "activated": [v is not None for v in self.activation()],
            "max_pressure_pa": float(np.max(self.pressure)),
            "final": {"pressure_pa": float(self.pressure[-1]),
                      "twist_angle_deg": math.degrees(self.twist_angle[-1]),
                      "twist_rate_rad_per_m": float(self.twist_angle[-1] / module.length),
                      "axial_stretch": float(self.axial_stretch[-1]),
                      "volume_ratio": float(response.path.extra["volume_ratio"][-1]),
                      **peak_summary(response.path)},
            "stats": self.stats,
        }
        if paths:
            path = response.path
            out["path"] = {"pressure_pa": path.pressure.tolist(),
                           "twist_angle_deg": np.degrees(self.twist_angle).tolist(),
                           "axial_stretch": path.axial_stretch.tolist(),
                           "volume_ratio": path.extra["volume_ratio"].tolist(),
                           "peak_stretch": path.peak_stretch.tolist(),
                           "stable": path.stable.tolist()}
        return out


def simulate_twisting_module(module: Module, settings: FESettings | None = None, *,
                             p_max: float | None = None,
                             progress: Callable[[float, int], None] | None = None,
                             tilt: float | None = None,
                             checkpoint: PathCheckpoint | None = None) -> FETwistResult:
    """Inflate a twisting module (strips around a shaft, clamped at y = 0) with 3D FE.

    Parameters
    ----------
    module : Module
        ``kind="twisting"`` (see :func:`~multimorph.fe.twisting_module_mesh`).
    settings : FESettings, optional
        Mesh density, solver and stops as for a cell; ``half`` is ignored (a twisting module
        has no mirror plane).
    p_max : float, optional
        Highest pressure (Pa); default ``settings.p_max``, else the wall shear modulus.
    progress : callable, optional
        ``progress(pressure_Pa, n_points)`` after every converged point.
    tilt : float, optional
        Override the module's tilt β (rad); ``0.0`` runs the straight reference module.
    checkpoint : PathCheckpoint, optional
        Save every converged point there; resume from an interrupted run's points.

    Returns
    -------
    FETwistResult

    Examples
    --------
    >>> from multimorph.device import device_from_spec
    >>> from multimorph.io import load_toml
    >>> dev = device_from_spec(load_toml("examples/gripper.toml"))  # doctest: +SKIP
    >>> r = simulate_twisting_module(dev.module("twister"), p_max=20e3)  # doctest: +SKIP
    >>> r.twist_angle[-1] < 0  # doctest: +SKIP
    True
    """
    settings = settings or FESettings()
    started = time.perf_counter()
    mesh = twisting_module_mesh(module, settings.mesh, element_size=settings.element_size,
                                tilt=tilt)
    t_mesh = time.perf_counter() - started
    cell = module.cell
    length, mu = cell.length, cell.mu
    p_end = float(p_max if p_max is not None else
                  (settings.p_max if settings.p_max is not None else mu))
    beta = float(module.tilt if tilt is None else tilt)
    measure = TwistMeasure(mesh, beta)
    record = run_path(
        mesh, measure, settings, p_max=p_end, length=length, stress=mu,
        max_stretch=(settings.max_stretch if settings.max_stretch is not None
                     else cell.material.break_stretch),
        started=started, progress=progress, checkpoint=checkpoint,
        tail={"mesh_time": t_mesh, "p_max": p_end, "length_unit_m": length,
              "stress_unit_pa": mu, "tilt": beta})
    column = record.recorder.column
    response = build_response(measure.path(column), length=module.length, shear_modulus=mu,
                              backend="fe", break_stretch=cell.material.break_stretch,
                              meta={"module": module.name, "kind": module.kind},
                              signal="twist_rate")
    return FETwistResult(
        module=module, mesh=mesh, response=response, pressure=column("pressure"),
        twist_angle=column("twist_angle"), axial_stretch=column("axial_stretch"),
        tip=column("tip"), displacements=np.array(record.recorder.displacements),
        stretch=np.array(record.recorder.element_stretch), stats=record.stats)
