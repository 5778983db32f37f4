"""3D FE of a device: bending, stretching and twisting modules in series and in parallel
branches, on one pressure line.

One structured hexahedral grid holds each run of bending and stretching modules of a branch
(:func:`~multimorph.fe.device_mesh`: cross-sections centred on a common axis, the modules'
cells in series from the branch's start, every chamber on the one pressure line); a twisting
module is a strip-and-shaft mesh of its own. Pieces of a branch and parallel branches
(fingers on a hub), placed as the reduced model places them, are tied together by rigid
hubs.

Each module is measured from node coordinates at every converged point, as the reference
paper measured its FE devices: the bend angle is the rotation about x of its end section
relative to its start section (best-fit rotations of the sections' nodes, in the frame of
the module's branch copy), the axial stretch is the length of the circular arc through the
section centroids with that angle, over the module length. A module's Pc and Ph come from
:func:`~multimorph.response.build_response` on its own signal (bending: curvature = angle /
length in the module's frame; stretching: the axial stretch).

Scaling: inside, lengths are in units of the first module's cell length and stresses in
units of the softest module's wall shear modulus (a device of one module is then the same
nondimensional problem as :func:`~multimorph.fe.simulate_cell`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from multimorph.device import Device
from multimorph.fe.analyses._measure import (
    chamber_volume,
    peak_element,
    peak_summary,
    section_motion,
    unwrapped,
)
from multimorph.fe.analyses._run import Measured, activation, run_path
from multimorph.fe.analyses._twist import tilt_sense
from multimorph.fe.engine import FESettings, PathCheckpoint
from multimorph.fe.mesh import DeviceMesh, device_mesh, flipped, in_grid
from multimorph.response import EquilibriumPath, Response, build_response

__all__ = ["DeviceMeasure", "FEDeviceResult", "simulate_device"]


class DeviceMeasure:
    """What a device analysis measures at every converged point
    (:class:`~multimorph.fe.analyses.Measure`): per module the bend and twist of its end
    section relative to its start section, its centroid-arc stretch, chamber volume and
    peak stretch; the tip and the hubs' rotations.

    Parameters
    ----------
    mesh : DeviceMesh
    length : float
        The problem's length unit (m): a hub's rotation node carries a rotation vector, not
        a displacement.
    """

    def __init__(self, mesh: DeviceMesh, length: float) -> None:
        self.mesh, self.length = mesh, length
        count = len(mesh.modules)
        self.mirror_x = mesh.width / 2 if mesh.half else None
        self.faces = [mesh.chamber_faces[mesh.face_module == i] for i in range(count)]
        self.elements = [np.flatnonzero(mesh.module == i) for i in range(count)]
        self.V0 = np.array([chamber_volume(mesh.points, faces, mirror_x=self.mirror_x)
                            for faces in self.faces])
        self.chord0 = np.array([
            section_motion(mesh.points, mesh.points, start, end, None, frame[1])[2]
            for start, end, frame in zip(mesh.start_sections, mesh.end_sections, mesh.frames,
                                         strict=True)])
        self.rotation_nodes = np.array([hub.rotation for hub in mesh.hubs], dtype=int)
        self.centers = [hub.center for hub in mesh.hubs]
        # a module turned by 180° inside a grid bends towards −z of the grid's frame; a
        # module placed turned (its own piece) is measured in its own turned frame
        self.sign = np.array([-1.0 if in_grid(module) and flipped(module) else 1.0
                              for module in mesh.modules])
        # a twisting module's own sense: positive twist rate for its tilt (as the twisting
        # module FE and the reduced model read it)
        self.twist_sense = np.array([-tilt_sense(module.tilt) if module.kind == "twisting"
                                     else 1.0 for module in mesh.modules])

    def __call__(self, displacement: np.ndarray, stretch: np.ndarray,
                 previous: dict[str, Any] | None) -> Measured:
        mesh = self.mesh
        u = displacement
        hub_rotation = [float(np.linalg.norm(u[hub.rotation])) / self.length
                        for hub in mesh.hubs]
        u[self.rotation_nodes] = u[self.centers]
        x = mesh.points + u
        count = len(mesh.modules)
        bend, twist, lam, volume, peak = (np.zeros(count) for _ in range(5))
        where = np.zeros((count, 3))
        region = np.zeros(count, dtype=int)
        for i in range(count):
            b, t, chord = section_motion(mesh.points, x, mesh.start_sections[i],
                                         mesh.end_sections[i], self.mirror_x, mesh.frames[i][1])
            if mesh.half:
                t = 0.0  # zero by the mirror symmetry
            if previous is not None:  # continuous along the path (a module may curl past 180°)
                b = unwrapped(b, previous["rel_bend"][i])
                t = unwrapped(t, previous["twist"][i])
            bend[i], twist[i] = b, t
            half = 0.5 * b
            arc = chord * (half / math.sin(half)) if abs(math.sin(half)) > 1e-12 else chord
            lam[i] = arc / self.chord0[i]
            volume[i] = chamber_volume(x, self.faces[i], mirror_x=self.mirror_x)
            j = peak_element(stretch, self.elements[i])
            peak[i] = float(stretch[:, j].max())
            where[i] = mesh.points[mesh.cells[j]].mean(axis=0)  # reference centroid
            region[i] = int(mesh.region[j])
        tip_bend = section_motion(mesh.points, x, mesh.start_sections[0],
                                  mesh.end_sections[mesh.tip_entry], self.mirror_x)[0]
        if previous is not None:
            tip_bend = unwrapped(tip_bend, previous["tip_angle"])
        tip = x[mesh.end_sections[mesh.tip_entry]].mean(axis=0)
        if mesh.half:
            tip[0] = mesh.width / 2  # the whole section's centroid, by symmetry
        row = {"rel_bend": bend, "twist": twist, "stretch": lam, "volume": volume,
               "peak": peak, "peak_location": where, "peak_region": region, "tip": tip,
               "tip_angle": tip_bend, "hub_rotation": hub_rotation}
        return Measured(row, u, volume / self.V0)

    def module_path(self, column: Callable[[str], np.ndarray], i: int) -> EquilibriumPath:
        """Module ``i``'s path: curvature = bend angle in the module's frame / its length."""
        module = self.mesh.modules[i]
        bend = self.sign[i] * column("rel_bend")[:, i]
        twist = column("twist")[:, i]
        volume = column("volume")[:, i]
        return EquilibriumPath(
            pressure=column("pressure"), curvature=bend / module.length,
            twist_rate=self.twist_sense[i] * twist / module.length,
            axial_stretch=column("stretch")[:, i], volume=volume,
            peak_stretch=column("peak")[:, i], stable=column("stable").astype(bool),
            extra={"bend_angle": bend,
                   "bend_angle_device": self.sign[i] * bend,
                   "twist_angle": twist,
                   "volume_ratio": volume / self.V0[i],
                   "peak_location": column("peak_location")[:, i],
                   "peak_region": column("peak_region")[:, i],
                   "arc_length": column("arc_length")})


@dataclass(frozen=True, eq=False)
class FEDeviceResult:
    """An FE analysis of a device: per-module responses, the tip, the states for output.

    Attributes
    ----------
    device : Device
    mesh : DeviceMesh
    responses : dict of str to Response
        Per module (``backend="fe"``), read on the module's signal. ``path.curvature`` is
        the bend angle over the module length in the module's own frame (positive towards
        its stiff layer), ``path.axial_stretch`` the centroid-arc stretch; ``path.extra``
        holds ``bend_angle`` (module frame, rad), ``bend_angle_device`` (device frame: a
        module turned by 180° in a grid bends negative; a module turned by another angle
        bends about its own turned axis, and this is its module-frame angle),
        ``twist_angle`` (rad, about the axis) and ``volume_ratio``.
    pressure : ndarray (n,)
        Pressure at every path point (Pa).
    stable : ndarray (n,) of bool
    tip : ndarray (n, 3)
        Centroid of the free end section (m).
    tip_angle : ndarray (n,)
        Rotation of the free end section about x (rad; positive towards −z).
    displacements : ndarray (n, npoints, 3)
        Nodal displacements (m) at every path point.
    stretch : ndarray (n, ncells)
        Largest principal stretch per element (mean over its Gauss points).
    stats : dict
    hub_rotation : ndarray (n, hubs)
        Rotation angle (rad) of every rigid hub (``mesh.hubs``) from its undeformed state;
        empty columns for a series device.
    """

    device: Device
    mesh: DeviceMesh
    responses: dict[str, Response]
    pressure: np.ndarray
    stable: np.ndarray
    tip: np.ndarray
    tip_angle: np.ndarray
    displacements: np.ndarray
    stretch: np.ndarray
    stats: dict[str, Any] = field(default_factory=dict)
    hub_rotation: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    def module_at(self, name: str, pressure: float | None = None) -> dict[str, float]:
        """Bend angle (rad, module frame) and axial stretch of a module on its observed
        loading curve at ``pressure`` (Pa; default the highest pressure reached)."""
        loading = self.responses[name].loading
        at = float(np.max(loading.pressure)) if pressure is None else pressure

        def read(values: np.ndarray) -> float:
            return float(np.interp(at, loading.pressure, values))

        return {"pressure": at, "bend_angle": read(loading.extra["bend_angle"]),
                "twist_angle": read(loading.extra["twist_angle"]),
                "axial_stretch": read(loading.axial_stretch)}

    def activation(self, name: str) -> tuple[float | None, float | None]:
        """A module's Pc and Ph (Pa), ``None`` where not reached: a value read at either end
        of the traced range (a curve still steepening at the top, or steepest at P = 0) is
        not an activation, and a Ph without a Pc is none."""
        return activation(self.responses[name])

    def to_dict(self, paths: bool = True) -> dict[str, Any]:
        """JSON-able summary: per-module characteristic pressures and state at the highest
        pressure, the final tip, statistics (SI units); with ``paths`` also every module's
        whole path and the tip path."""
        mods: dict[str, Any] = {}
        for module, src in zip(self.mesh.modules, self.mesh.source, strict=True):
            response = self.responses[module.name]
            path = response.path
            at = self.module_at(module.name)
            mods[module.name] = {
                "kind": module.kind, "module": src,
                "orientation_deg": math.degrees(module.orientation), "cells": module.n_cells,
                "length_m": module.length, "shear_modulus_pa": response.shear_modulus,
                **response.characteristic.to_dict(),
                "activated": [v is not None for v in self.activation(module.name)],
                "at_max_pressure": {"pressure_pa": at["pressure"],
                                    "bend_angle_deg": math.degrees(at["bend_angle"]),
                                    "twist_angle_deg": math.degrees(at["twist_angle"]),
                                    "axial_stretch": at["axial_stretch"]},
                "final": {"pressure_pa": float(path.pressure[-1]), **peak_summary(path)},
            }
            if paths:
                mods[module.name]["path"] = {
                    "pressure_pa": path.pressure.tolist(),
                    "bend_angle_deg": np.degrees(path.extra["bend_angle"]).tolist(),
                    "axial_stretch": path.axial_stretch.tolist(),
                    "volume_ratio": path.extra["volume_ratio"].tolist(),
                    "peak_stretch": path.peak_stretch.tolist(), "stable": path.stable.tolist()}
        out = {"name": self.device.name, "modules": mods,
               "max_pressure_pa": float(np.max(self.pressure)),
               "final_tip": {"pressure_pa": float(self.pressure[-1]),
                             "position_m": self.tip[-1].tolist(),
                             "angle_deg": math.degrees(self.tip_angle[-1])},
               "stats": self.stats}
        if self.mesh.hubs:
            names = [module.name for module in self.mesh.modules]
            out["hubs"] = [{"parent": names[hub.parent],
                            "children": [names[c] for c in hub.children],
                            "tied_nodes": len(hub.points),
                            "final_rotation_deg": math.degrees(float(self.hub_rotation[-1, k]))}
                           for k, hub in enumerate(self.mesh.hubs)]
        if paths:
            out["tip"] = {"pressure_pa": self.pressure.tolist(), "position_m": self.tip.tolist(),
                          "angle_deg": np.degrees(self.tip_angle).tolist()}
        return out


def simulate_device(device: Device, settings: FESettings | None = None,
                    progress: Callable[[float, int], None] | None = None, *,
                    checkpoint: PathCheckpoint | None = None) -> FEDeviceResult:
    """Inflate a device (modules in series on one pressure line) with 3D FE and measure
    every module from node coordinates.

    Parameters
    ----------
    device : Device
        Branches of bending, stretching and twisting modules: one clamped series,
        parallel branches tied to their parent's end by rigid hubs
        (:func:`fe_device_branches`; anything else raises :class:`SpecError`). A device
        with a twisting module, a module turned by an angle other than 0° or 180°, or a
        parallel branch is modelled whole (``settings.half`` applies to one series grid of
        bending and stretching modules only).
    settings : FESettings, optional
        As for a cell; ``p_max`` defaults to the device's design pressure ``device.pmax``
        (Pa); the volume-ratio stop applies to each module's chambers, the stretch stop
        (default the smallest break stretch of the wall materials) to all walls.
    progress : callable, optional
        ``progress(pressure_Pa, n_points)`` after every converged point.
    checkpoint : PathCheckpoint, optional
        Save every converged point there; resume from an interrupted run's points.

    Returns
    -------
    FEDeviceResult

    Examples
    --------
    >>> from multimorph.device import device_from_spec
    >>> from multimorph.io import load_toml
    >>> dev = device_from_spec(load_toml("examples/fe_device.toml"))  # doctest: +SKIP
    >>> r = simulate_device(dev, FESettings(p_max=40e3))  # doctest: +SKIP
    >>> sorted(r.responses)  # doctest: +SKIP
    ['seal', 'stalk']
    """
    settings = settings or FESettings()
    started = time.perf_counter()
    mesh = device_mesh(device, settings.mesh, element_size=settings.element_size,
                       half=settings.half)
    modules = mesh.modules
    length = modules[0].cell.length
    mu = min(module.cell.mu for module in modules)
    p_max = settings.p_max if settings.p_max is not None else device.pmax
    breaks = [module.cell.material.break_stretch for module in modules
              if module.cell.material.break_stretch is not None]
    measure = DeviceMeasure(mesh, length)
    record = run_path(
        mesh, measure, settings, p_max=p_max, length=length, stress=mu,
        max_stretch=(settings.max_stretch if settings.max_stretch is not None
                     else min(breaks, default=None)),
        started=started, groups=tuple(module.name for module in modules), progress=progress,
        checkpoint=checkpoint, ties=[(hub.points, hub.center, hub.rotation) for hub in mesh.hubs],
        tie_stiffness=_hub_stiffness(mesh, length, mu), head={"modules": len(modules)},
        tail={"p_max": p_max, "length_unit_m": length, "stress_unit_pa": mu})
    column = record.recorder.column
    responses = {
        module.name: build_response(
            measure.module_path(column, i), length=module.length,
            shear_modulus=module.cell.mu, backend="fe",
            break_stretch=module.cell.material.break_stretch,
            meta={"module": module.name, "kind": module.kind},
            signal="twist_rate" if module.kind == "twisting" else module.cell.signal)
        for i, module in enumerate(modules)}
    rows = record.recorder.rows
    return FEDeviceResult(
        device=device, mesh=mesh, responses=responses, pressure=column("pressure"),
        stable=column("stable").astype(bool), tip=column("tip"), tip_angle=column("tip_angle"),
        displacements=np.array(record.recorder.displacements),
        stretch=np.array(record.recorder.element_stretch), stats=record.stats,
        hub_rotation=column("hub_rotation").reshape(len(rows), -1))


def _hub_stiffness(mesh: DeviceMesh, L: float, mu: float) -> float:
    """Penalty of the rigid hubs (scaled units: force per length in μ L): 10³ times the
    stiffness μ_max h of the stiffest material over the smallest element edge h, so a tied
    node moves ~10⁻³ of what the elastic neighbourhood would allow."""
    if not mesh.hubs:
        return 0.0
    e = mesh.points[mesh.cells]
    h = min(float(np.linalg.norm(e[:, k] - e[:, 0], axis=1).min()) for k in (1, 3, 4))
    mu_max = max(mat.shear_modulus for mat in mesh.materials) / mu
    return 1e3 * mu_max * h / L
