"""3D FE of a device: bending, stretching and twisting modules in series and in parallel
branches, on one pressure line.

One structured hexahedral grid holds each run of bending and stretching modules of a branch
(:mod:`._device_mesh`: cross-sections centred on a common axis, the modules' cells in series
from the branch's start, every chamber on the one pressure line); a twisting module is a
strip-and-shaft mesh of its own. Pieces of a branch and parallel branches (fingers on a
hub), placed as the reduced model places them, are tied together by rigid hubs.

Each module is measured from node coordinates at every converged point, as the reference
paper measured its FE devices: the bend angle is the rotation about x of its end section
relative to its start section (best-fit rotations of the sections' nodes, in the frame of
the module's branch copy), the axial stretch
is the length of the circular arc through the section centroids with that angle, over the
module length. A module's Pc and Ph come from :func:`~multimorph.response.build_response` on
its own signal (bending: curvature = angle / length in the module's frame; stretching: the
axial stretch).

Scaling: inside, lengths are in units of the first module's cell length and stresses in
units of the softest module's wall shear modulus (a device of one module is then the same
nondimensional problem as :func:`~multimorph.fe.simulate_cell`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from multimorph.device import Device
from multimorph.errors import MultimorphError
from multimorph.fe._cell import FESettings, drop_points, path_end, trace_path
from multimorph.fe._checkpoint import PathCheckpoint
from multimorph.fe._deps import require
from multimorph.fe._device_mesh import (
    FE_MODULE_KINDS,
    DeviceMesh,
    _flipped,
    _in_grid,
    device_mesh,
    fe_device_branches,
    fe_device_modules,
)
from multimorph.fe._linsolve import make_solver
from multimorph.fe._measure import (
    _kabsch,
    bend_and_twist,
    chamber_volume,
    largest_stretch,
    peak_element,
    peak_summary,
)
from multimorph.fe._mesh import MeshDensity
from multimorph.fe._problem import PressureProblem
from multimorph.fe._solve import PathPoint
from multimorph.fe._twist import _sense
from multimorph.response import EquilibriumPath, Response, build_response

__all__ = ["FE_MODULE_KINDS", "DeviceMesh", "FEDeviceResult", "compare_device", "device_mesh",
           "fe_device_branches", "fe_device_modules", "plot_device", "simulate_device"]


def _section_motion(X: np.ndarray, x: np.ndarray, s: np.ndarray, e: np.ndarray,
                    mirror_x: float | None, Q: np.ndarray | None = None,
                    ) -> tuple[float, float, float]:
    """Bend and twist (rad) of section ``e`` relative to section ``s`` and the y–z chord of
    their node centroids (m), in the frame whose axes are the columns of ``Q`` (default the
    mesh frame).

    A half model's sections are completed by the mirror images (x → 2 x_m − x) of their nodes
    off the mirror plane, so the best-fit rotations are those of the whole sections, node
    for node: exactly about x, composing additively along the device, and equal to the
    whole model's.
    """
    def whole(P: np.ndarray, nodes: np.ndarray) -> np.ndarray:
        if Q is not None:
            P = P @ Q  # rows: coordinates along Q's columns
        if mirror_x is None:
            return P
        off = np.abs(X[nodes, 0] - mirror_x) > 1e-9 * max(abs(mirror_x), 1e-3)
        return np.concatenate([P, P[off] * [-1.0, 1.0, 1.0] + [2.0 * mirror_x, 0.0, 0.0]])

    Xs, xs = whole(X[s], s), whole(x[s], s)
    Xe, xe = whole(X[e], e), whole(x[e], e)
    Rs = _kabsch(Xs, xs)
    bend, twist = bend_and_twist(Xe, xe @ Rs)  # rows rotated by Rsᵀ: Rsᵀ R_e
    chord = float(np.linalg.norm(xe[:, 1:].mean(0) - xs[:, 1:].mean(0)))
    return bend, twist, chord


class _DeviceRecorder:
    """Measures every module at every converged point and decides when to stop."""

    def __init__(self, mesh: DeviceMesh, problem: PressureProblem, L: float, mu: float,
                 p_max: float, s: FESettings, max_stretch: float | None,
                 progress: Callable[[float, int], None] | None) -> None:
        self.mesh, self.problem, self.L, self.mu = mesh, problem, L, mu
        self.p_max, self.s, self.max_stretch, self.progress = p_max, s, max_stretch, progress
        m = mesh
        self.mirror_x = m.width / 2 if m.half else None
        self.V0 = np.array([chamber_volume(m.points, m.chamber_faces[m.face_module == i],
                                           mirror_x=self.mirror_x)
                            for i in range(len(m.modules))])
        self.chord0 = np.array([_section_motion(m.points, m.points, s_, e_, None, f[1])[2]
                                for s_, e_, f in zip(m.start_sections, m.end_sections,
                                                     m.frames, strict=True)])
        # a hub's rotation node carries a rotation vector, not a displacement
        self.rotation_nodes = np.array([h.rotation for h in m.hubs], dtype=int)
        # a module turned by 180° inside a grid bends towards −z of the grid's frame; a
        # module placed turned (its own piece) is measured in its own turned frame
        self.sign = np.array([-1.0 if _in_grid(mod) and _flipped(mod) else 1.0
                              for mod in m.modules])
        # a twisting module's own sense: positive twist rate for its tilt (as the twisting
        # module FE and the reduced model read it)
        self.twist_sense = np.array([-_sense(mod.tilt) if mod.kind == "twisting" else 1.0
                                     for mod in m.modules])
        self.rows: list[dict[str, Any]] = []
        self.u: list[np.ndarray] = []
        self.cell_stretch: list[np.ndarray] = []
        self.stop_reason = ""
        self.add(PathPoint(0.0, problem.get_x(), 0, True, "start"))

    def add(self, pt: PathPoint) -> bool:
        m = self.mesh
        self.problem.set_x(pt.x)
        u = self.problem.values.copy() * self.L
        hub_rotation = [float(np.linalg.norm(u[h.rotation])) / self.L for h in m.hubs]
        u[self.rotation_nodes] = u[[h.center for h in m.hubs]]
        x = m.points + u
        k = len(m.modules)
        bend, twist, lam, vol, peak = (np.zeros(k) for _ in range(5))
        prev = self.rows[-1] if self.rows else None
        turn = 2.0 * math.pi
        for i in range(k):
            b, t, chord = _section_motion(m.points, x, m.start_sections[i], m.end_sections[i],
                                          self.mirror_x, m.frames[i][1])
            if m.half:
                t = 0.0  # zero by the mirror symmetry
            if prev is not None:  # continuous along the path (a module may curl past 180°)
                b += turn * round((prev["rel_bend"][i] - b) / turn)
                t += turn * round((prev["twist"][i] - t) / turn)
            bend[i], twist[i] = b, t
            half = 0.5 * b
            arc = chord * (half / math.sin(half)) if abs(math.sin(half)) > 1e-12 else chord
            lam[i] = arc / self.chord0[i]
            vol[i] = chamber_volume(x, m.chamber_faces[m.face_module == i],
                                    mirror_x=self.mirror_x)
        F = self.problem.deformation_gradient()
        ev = largest_stretch(F)  # (q, cells)
        where = np.zeros((k, 3))
        region = np.zeros(k, dtype=int)
        for i in range(k):
            j = peak_element(ev, np.flatnonzero(m.module == i))
            peak[i] = float(ev[:, j].max())
            where[i] = m.points[m.cells[j]].mean(axis=0)  # reference centroid
            region[i] = int(m.region[j])
        tip_bend = _section_motion(m.points, x, m.start_sections[0],
                                   m.end_sections[m.tip_entry], self.mirror_x)[0]
        if prev is not None:
            tip_bend += turn * round((prev["tip_angle"] - tip_bend) / turn)
        tip = x[m.end_sections[m.tip_entry]].mean(axis=0)
        if m.half:
            tip[0] = m.width / 2  # the whole section's centroid, by symmetry
        self.rows.append({
            "pressure": pt.pressure * self.mu, "rel_bend": bend, "twist": twist,
            "stretch": lam, "volume": vol, "peak": peak, "peak_location": where,
            "peak_region": region, "tip": tip, "tip_angle": tip_bend,
            "hub_rotation": hub_rotation,
            "stable": bool(pt.stable) if pt.stable is not None else True,
            "iterations": pt.iterations, "arc_length": pt.method == "arc-length",
        })
        self.u.append(u)
        self.cell_stretch.append(ev.mean(axis=0))
        if self.progress is not None:
            self.progress(pt.pressure * self.mu, len(self.rows))
        return self._stop(pt)

    def _stop(self, pt: PathPoint) -> bool:
        r = self.rows[-1]
        ratio = r["volume"] / self.V0
        if ratio.max() > self.s.max_volume_ratio:
            i = int(np.argmax(ratio))
            self.stop_reason = (f"chamber volume ratio of module {self.mesh.modules[i].name!r}"
                                f" exceeded {self.s.max_volume_ratio:g}")
            return True
        if self.max_stretch is not None and r["peak"].max() > self.max_stretch:
            self.stop_reason = f"peak stretch exceeded {self.max_stretch:g}"
            return True
        self.stop_reason = path_end([row["pressure"] for row in self.rows], pt.method,
                                    self.p_max, self.s.stop_after_limit, self.u)
        return bool(self.stop_reason)

    def module_path(self, i: int) -> EquilibriumPath:
        """Module ``i``'s path: curvature = bend angle in the module's frame / its length."""
        r = self.rows
        mod = self.mesh.modules[i]
        bend = self.sign[i] * np.array([row["rel_bend"][i] for row in r])
        twist = np.array([row["twist"][i] for row in r])
        vol = np.array([row["volume"][i] for row in r])
        return EquilibriumPath(
            pressure=np.array([row["pressure"] for row in r]),
            curvature=bend / mod.length,
            twist_rate=self.twist_sense[i] * twist / mod.length,
            axial_stretch=np.array([row["stretch"][i] for row in r]),
            volume=vol, peak_stretch=np.array([row["peak"][i] for row in r]),
            stable=np.array([row["stable"] for row in r], dtype=bool),
            extra={"bend_angle": bend,
                   "bend_angle_device": self.sign[i] * bend,
                   "twist_angle": twist,
                   "volume_ratio": vol / self.V0[i],
                   "peak_location": np.array([row["peak_location"][i] for row in r]),
                   "peak_region": np.array([row["peak_region"][i] for row in r]),
                   "arc_length": np.array([row["arc_length"] for row in r])})


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
        lo = self.responses[name].loading
        p = float(np.max(lo.pressure)) if pressure is None else pressure
        return {"pressure": p,
                "bend_angle": float(np.interp(p, lo.pressure, lo.extra["bend_angle"])),
                "twist_angle": float(np.interp(p, lo.pressure, lo.extra["twist_angle"])),
                "axial_stretch": float(np.interp(p, lo.pressure, lo.axial_stretch))}

    def activation(self, name: str) -> tuple[float | None, float | None]:
        """A module's Pc and Ph (Pa), ``None`` where not reached: a value read at either end
        of the traced range (a curve still steepening at the top, or steepest at P = 0) is
        not an activation, and a Ph without a Pc is none."""
        r = self.responses[name]
        c = r.characteristic
        pc = _reached(c.critical, r)
        return pc, (None if pc is None else _reached(c.hardening, r))

    def to_dict(self, paths: bool = True) -> dict[str, Any]:
        """JSON-able summary: per-module characteristic pressures and state at the highest
        pressure, the final tip, statistics (SI units); with ``paths`` also every module's
        whole path and the tip path."""
        mods: dict[str, Any] = {}
        for m, src in zip(self.mesh.modules, self.mesh.source, strict=True):
            r = self.responses[m.name]
            p = r.path
            at = self.module_at(m.name)
            mods[m.name] = {
                "kind": m.kind, "module": src, "orientation_deg": math.degrees(m.orientation),
                "cells": m.n_cells, "length_m": m.length, "shear_modulus_pa": r.shear_modulus,
                **r.characteristic.to_dict(),
                "activated": [v is not None for v in self.activation(m.name)],
                "at_max_pressure": {"pressure_pa": at["pressure"],
                                    "bend_angle_deg": math.degrees(at["bend_angle"]),
                                    "twist_angle_deg": math.degrees(at["twist_angle"]),
                                    "axial_stretch": at["axial_stretch"]},
                "final": {"pressure_pa": float(p.pressure[-1]), **peak_summary(p)},
            }
            if paths:
                mods[m.name]["path"] = {
                    "pressure_pa": p.pressure.tolist(),
                    "bend_angle_deg": np.degrees(p.extra["bend_angle"]).tolist(),
                    "axial_stretch": p.axial_stretch.tolist(),
                    "volume_ratio": p.extra["volume_ratio"].tolist(),
                    "peak_stretch": p.peak_stretch.tolist(), "stable": p.stable.tolist()}
        out = {"name": self.device.name, "modules": mods,
               "max_pressure_pa": float(np.max(self.pressure)),
               "final_tip": {"pressure_pa": float(self.pressure[-1]),
                             "position_m": self.tip[-1].tolist(),
                             "angle_deg": math.degrees(self.tip_angle[-1])},
               "stats": self.stats}
        if self.mesh.hubs:
            names = [m.name for m in self.mesh.modules]
            out["hubs"] = [{"parent": names[h.parent],
                            "children": [names[c] for c in h.children],
                            "tied_nodes": len(h.points),
                            "final_rotation_deg": math.degrees(float(self.hub_rotation[-1, k]))}
                           for k, h in enumerate(self.mesh.hubs)]
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
    s = settings or FESettings()
    t0 = time.perf_counter()
    mesh = device_mesh(device, s.mesh, element_size=s.element_size, half=s.half)
    mods = mesh.modules
    fem = require("felupe")
    L = mods[0].cell.length
    mu = min(m.cell.mu for m in mods)
    fixed = np.zeros((len(mesh.points), 3), dtype=bool)
    fixed[mesh.clamped] = True
    fixed[mesh.mirror, 0] = True
    bodies = [(np.flatnonzero(mesh.material == i), mat.scaled(1.0 / mu))
              for i, mat in enumerate(mesh.materials)]
    ties = [(h.points, h.center, h.rotation) for h in mesh.hubs]
    problem = PressureProblem(fem.Mesh(mesh.points / L, mesh.cells, "hexahedron"),
                              [(c, m) for c, m in bodies if len(c)], mesh.chamber_points, fixed,
                              ties=ties, tie_stiffness=_hub_stiffness(mesh, L, mu))
    solver = make_solver(s.solver)
    p_max = s.p_max if s.p_max is not None else device.pmax
    breaks = [m.cell.material.break_stretch for m in mods
              if m.cell.material.break_stretch is not None]
    max_stretch = s.max_stretch if s.max_stretch is not None else min(breaks, default=None)
    rec = _DeviceRecorder(mesh, problem, L, mu, p_max, s, max_stretch, progress)
    try:
        run = trace_path(problem, solver, s, p_max / mu, rec.add, checkpoint=checkpoint,
                         truncate=lambda n: drop_points(rec, n))
    finally:
        solver.release()
    if len(rec.rows) < 2:
        raise MultimorphError(f"FE analysis found no equilibrium beyond P = 0: {run.message}")
    stats = {
        "backend": "fe", "modules": len(mods), "ndof": int(mesh.ndof),
        "nfree": int(problem.nfree), "ncells": int(mesh.ncells), "points": len(rec.rows) - 1,
        "attempts": run.attempts, "cutbacks": run.cutbacks,
        "newton_iterations": run.newton_iterations, "status": run.status,
        "message": run.message, "stop_reason": rec.stop_reason, "solver": solver.name,
        "solve_time": solver.time, "solves": solver.calls, "analyses": solver.analyses,
        "factorisations": solver.factorisations, "tangents_reused": run.tangents_reused,
        "chord_steps": run.chord_steps, "restarts": run.restarts,
        "assembly_time": problem.stats.time,
        "wall_time": time.perf_counter() - t0,
        "resumed_points": checkpoint.resumed if checkpoint is not None else 0,
        "p_max": p_max, "length_unit_m": L, "stress_unit_pa": mu,
        "settings": {k: (v if not isinstance(v, MeshDensity) else asdict(v))
                     for k, v in asdict(s).items()},
    }
    responses = {
        m.name: build_response(rec.module_path(i), length=m.length, shear_modulus=m.cell.mu,
                               backend="fe", break_stretch=m.cell.material.break_stretch,
                               meta={"module": m.name, "kind": m.kind},
                               signal="twist_rate" if m.kind == "twisting" else m.cell.signal)
        for i, m in enumerate(mods)}
    rows = rec.rows
    return FEDeviceResult(
        device=device, mesh=mesh, responses=responses,
        pressure=np.array([r["pressure"] for r in rows]),
        stable=np.array([r["stable"] for r in rows], dtype=bool),
        tip=np.array([r["tip"] for r in rows]),
        tip_angle=np.array([r["tip_angle"] for r in rows]),
        displacements=np.array(rec.u), stretch=np.array(rec.cell_stretch), stats=stats,
        hub_rotation=np.array([r["hub_rotation"] for r in rows]).reshape(len(rows), -1))


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


def _rel(a: float | None, b: float | None) -> float | None:
    return None if a is None or b is None or b == 0 else (a - b) / b


def _reached(value: float | None, response: Response) -> float | None:
    """``value`` unless it sits at either end of the loading curve: a steepest rise read at
    the highest pressure traced is a curve still steepening, one read at P ≈ 0 a curve with
    no activation in range (within 1 % of the range)."""
    if value is None:
        return None
    top = float(np.max(response.loading.pressure))
    return value if 0.01 * top < value < 0.99 * top else None


def compare_device(fe: FEDeviceResult, rom: Any = None, *, rom_p_max: float | None = None,
                   ) -> dict[str, dict[str, Any]]:
    """Each module's Pc and Ph from FE and from the reduced-model device, relative
    differences (rom − fe)/fe.

    A Pc or Ph at either end of a backend's traced range (e.g. the steepest rise read at the
    highest pressure) counts as not reached (``None``), so it never enters a difference.

    Parameters
    ----------
    fe : FEDeviceResult
    rom : multimorph.device.DeviceResult, optional
        Default: :func:`multimorph.device.simulate_device` on the same device to
        ``rom_p_max``.
    rom_p_max : float, optional
        Highest pressure of the reduced model (Pa); default twice the pressure FE was asked
        to reach (the reduced model is stiffer than FE, docs/fe.md "ROM vs FE", and is cheap).

    Returns
    -------
    dict
        Per module: ``pc_fe``, ``pc_rom``, ``pc_rel``, ``ph_fe``, ``ph_rom``, ``ph_rel``
        (Pa, relative or None), the ``signal`` read and ``rom_p_max``.
    """
    p_rom = float(rom_p_max if rom_p_max is not None else 2.0 * fe.stats["p_max"])
    if rom is None:
        from multimorph.device import simulate_device as rom_device

        rom = rom_device(fe.device, p_rom)
    out: dict[str, dict[str, Any]] = {}
    for m, src in zip(fe.mesh.modules, fe.mesh.source, strict=True):
        rr = rom.strains[src].response
        cr = rr.characteristic
        pc_f, ph_f = fe.activation(m.name)
        pc_r = _reached(cr.critical, rr)
        ph_r = None if pc_r is None else _reached(cr.hardening, rr)
        out[m.name] = {"kind": m.kind, "signal": cr.signal, "rom_p_max": p_rom,
                       "pc_fe": pc_f, "pc_rom": pc_r, "pc_rel": _rel(pc_r, pc_f),
                       "ph_fe": ph_f, "ph_rom": ph_r, "ph_rel": _rel(ph_r, ph_f)}
    return out


def write_device_vtu(result: FEDeviceResult, folder: Any, stem: str = "device") -> list[str]:
    """The device's VTU series (:func:`~multimorph.fe._output.write_hex_series`), tagged by
    region, module and material."""
    from multimorph.fe._output import write_hex_series

    m = result.mesh
    return write_hex_series(folder, stem, m.points, m.cells, result.displacements,
                            result.stretch, result.pressure,
                            {"region": m.region, "module": m.module, "material": m.material})


def plot_device(result: FEDeviceResult, folder: Any) -> list[str]:
    """``curves.png`` (pressure against every module's bend angle, centroid stretch and
    V/V0, twisting modules' twist angle, and the tip angle; each module's Pc marked) and
    ``snapshots.png`` (side views of the deformed device, coloured by stretch) in
    ``folder``; returns the file names."""
    from pathlib import Path

    from multimorph.fe._output import plot_hex_snapshots, plot_path_panels

    folder = Path(folder)
    paths = {name: r.path for name, r in result.responses.items()}
    marks = [(pc, f"Pc {name}") for name in paths
             if (pc := result.activation(name)[0]) is not None]
    panels = [("bend angle (°, module frame)",
               {n: np.degrees(p.extra["bend_angle"]) for n, p in paths.items()}),
              ("centroid stretch (-)", {n: p.axial_stretch for n, p in paths.items()}),
              ("V / V0 (-)", {n: p.extra["volume_ratio"] for n, p in paths.items()}),
              ("tip angle (°)", {"tip": np.degrees(result.tip_angle)})]
    twisting = [m.name for m in result.mesh.modules if m.kind == "twisting"]
    if twisting:
        panels.insert(1, ("twist angle (°, about the axis)",
                          {n: np.degrees(paths[n].extra["twist_angle"]) for n in twisting}))
    plot_path_panels(
        result.pressure, result.stable, panels,
        folder / "curves.png", marks=marks,
        title=f"FE device {result.device.name} ({result.stats.get('nfree', '?')} DOF)")
    m = result.mesh
    plot_hex_snapshots(m.points, m.cells, result.displacements, result.stretch,
                       result.pressure, folder / "snapshots.png",
                       title="side view (outer third of the half model)" if m.half
                       else "side view (the third of the model at the smallest x)")
    return ["curves.png", "snapshots.png"]
