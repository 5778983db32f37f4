"""3D FE of a twisting module: tilted-chamber strips around a shaft, clamped at one end.

The mesh is :func:`~multimorph.fe._twist_mesh.twisting_module_mesh`; the path is traced by
:func:`~multimorph.fe._cell.trace_path` on a :class:`~multimorph.fe.PressureProblem` (one
nearly incompressible body per material; every chamber of every strip on one pressure line),
like :func:`~multimorph.fe.simulate_device`.

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
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from multimorph.device import Module
from multimorph.errors import MultimorphError
from multimorph.fe._cell import FESettings, drop_points, path_end, trace_path
from multimorph.fe._checkpoint import PathCheckpoint
from multimorph.fe._deps import require
from multimorph.fe._linsolve import make_solver
from multimorph.fe._measure import (
    bend_and_twist,
    chamber_volume,
    largest_stretch,
    peak_element,
    peak_summary,
)
from multimorph.fe._mesh import MeshDensity
from multimorph.fe._problem import PressureProblem
from multimorph.fe._solve import PathPoint
from multimorph.fe._twist_mesh import TwistMesh, twisting_module_mesh
from multimorph.response import EquilibriumPath, Response, build_response

__all__ = ["FETwistResult", "compare_twisting", "plot_twist", "simulate_twisting_module",
           "write_twist_csv", "write_twist_vtu"]


def _sense(beta: float) -> float:
    """sign(β) (1 for β = 0): a tilt β > 0 twists the module left-handed about +y (the
    strips' cells lengthen along (−sin β, cos β) in the strip frame, a negative shear of the
    shaft's surface)."""
    return -1.0 if beta < 0 else 1.0


class _TwistRecorder:
    """Measures the module at every converged point and decides when to stop."""

    def __init__(self, mesh: TwistMesh, problem: PressureProblem, L: float, mu: float,
                 p_max: float, s: FESettings, max_stretch: float | None,
                 progress: Callable[[float, int], None] | None, tilt: float) -> None:
        self.mesh, self.problem, self.L, self.mu = mesh, problem, L, mu
        self.p_max, self.s, self.max_stretch, self.progress = p_max, s, max_stretch, progress
        self.V0 = chamber_volume(mesh.points, mesh.chamber_faces)
        self.tilt = tilt
        end = mesh.end_section
        w = mesh.section_weights(end)
        self.weights = w / np.sum(w)
        self.rows: list[dict[str, Any]] = []
        self.u: list[np.ndarray] = []
        self.cell_stretch: list[np.ndarray] = []
        self.stop_reason = ""
        self.add(PathPoint(0.0, problem.get_x(), 0, True, "start"))

    def add(self, pt: PathPoint) -> bool:
        m = self.mesh
        self.problem.set_x(pt.x)
        u = self.problem.values.copy() * self.L
        x = m.points + u
        end = m.end_section
        bend, twist = bend_and_twist(m.points[end], x[end])
        if self.rows:  # continuous along the path (a module may twist past ±180°)
            turn = 2.0 * math.pi
            twist += turn * round((self.rows[-1]["twist_angle"] - twist) / turn)
        uy = float(self.weights @ u[end, 1])
        vol = chamber_volume(x, m.chamber_faces)
        F = self.problem.deformation_gradient()
        ev = largest_stretch(F)  # (q, cells)
        cell = peak_element(ev)
        self.rows.append({
            "pressure": pt.pressure * self.mu, "twist_angle": twist, "bend_angle": bend,
            "axial_stretch": 1.0 + uy / m.length, "volume": vol,
            "peak": float(ev.max()), "tip": (self.weights @ x[end]),
            "peak_location": m.points[m.cells[cell]].mean(axis=0),  # reference centroid
            "peak_region": int(m.region[cell]),
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
        if r["volume"] / self.V0 > self.s.max_volume_ratio:
            self.stop_reason = f"chamber volume ratio exceeded {self.s.max_volume_ratio:g}"
            return True
        if self.max_stretch is not None and r["peak"] > self.max_stretch:
            self.stop_reason = f"peak stretch exceeded {self.max_stretch:g}"
            return True
        self.stop_reason = path_end([row["pressure"] for row in self.rows], pt.method,
                                    self.p_max, self.s.stop_after_limit, self.u)
        return bool(self.stop_reason)

    def path(self) -> EquilibriumPath:
        r = self.rows
        mod = self.mesh.module
        angle = np.array([row["twist_angle"] for row in r])
        sense = -_sense(self.tilt)
        vol = np.array([row["volume"] for row in r])
        return EquilibriumPath(
            pressure=np.array([row["pressure"] for row in r]),
            curvature=np.zeros(len(r)),
            twist_rate=sense * angle / mod.length,
            axial_stretch=np.array([row["axial_stretch"] for row in r]),
            volume=vol, peak_stretch=np.array([row["peak"] for row in r]),
            stable=np.array([row["stable"] for row in r], dtype=bool),
            extra={"twist_angle": angle,
                   "bend_angle": np.array([row["bend_angle"] for row in r]),
                   "volume_ratio": vol / self.V0,
                   "peak_location": np.array([row["peak_location"] for row in r]),
                   "peak_region": np.array([row["peak_region"] for row in r]),
                   "arc_length": np.array([row["arc_length"] for row in r])})


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
        from multimorph.fe._device import _reached

        c = self.response.characteristic
        pc = _reached(c.critical, self.response)
        return pc, (None if pc is None else _reached(c.hardening, self.response))

    def to_dict(self, paths: bool = True) -> dict[str, Any]:
        """JSON-able summary (SI units, angles in degrees)."""
        r = self.response
        m = self.module
        out: dict[str, Any] = {
            "name": m.name, "kind": m.kind, "cells": m.n_cells, "strips": m.strips,
            "tilt_deg": math.degrees(m.tilt), "shaft_radius_m": m.shaft_radius,
            "length_m": m.length, "shear_modulus_pa": r.shear_modulus,
            **r.characteristic.to_dict(),
            "activated": [v is not None for v in self.activation()],
            "max_pressure_pa": float(np.max(self.pressure)),
            "final": {"pressure_pa": float(self.pressure[-1]),
                      "twist_angle_deg": math.degrees(self.twist_angle[-1]),
                      "twist_rate_rad_per_m": float(self.twist_angle[-1] / m.length),
                      "axial_stretch": float(self.axial_stretch[-1]),
                      "volume_ratio": float(r.path.extra["volume_ratio"][-1]),
                      **peak_summary(r.path)},
            "stats": self.stats,
        }
        if paths:
            p = r.path
            out["path"] = {"pressure_pa": p.pressure.tolist(),
                           "twist_angle_deg": np.degrees(self.twist_angle).tolist(),
                           "axial_stretch": p.axial_stretch.tolist(),
                           "volume_ratio": p.extra["volume_ratio"].tolist(),
                           "peak_stretch": p.peak_stretch.tolist(),
                           "stable": p.stable.tolist()}
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
    s = settings or FESettings()
    t0 = time.perf_counter()
    mesh = twisting_module_mesh(module, s.mesh, element_size=s.element_size, tilt=tilt)
    t_mesh = time.perf_counter() - t0
    fem = require("felupe")
    g = module.cell
    L, mu = g.length, g.mu
    fixed = np.zeros((len(mesh.points), 3), dtype=bool)
    fixed[mesh.clamped] = True
    bodies = [(np.flatnonzero(mesh.material == i), mat.scaled(1.0 / mu))
              for i, mat in enumerate(mesh.materials)]
    problem = PressureProblem(fem.Mesh(mesh.points / L, mesh.cells, "hexahedron"),
                              [(c, m) for c, m in bodies if len(c)], mesh.chamber_points, fixed)
    solver = make_solver(s.solver)
    p_end = float(p_max if p_max is not None else (s.p_max if s.p_max is not None else mu))
    max_stretch = s.max_stretch if s.max_stretch is not None else g.material.break_stretch
    beta = float(module.tilt if tilt is None else tilt)
    rec = _TwistRecorder(mesh, problem, L, mu, p_end, s, max_stretch, progress, beta)
    try:
        run = trace_path(problem, solver, s, p_end / mu, rec.add, checkpoint=checkpoint,
                         truncate=lambda n: drop_points(rec, n))
    finally:
        solver.release()
    if len(rec.rows) < 2:
        raise MultimorphError(f"FE analysis found no equilibrium beyond P = 0: {run.message}")
    stats = {
        "backend": "fe", "ndof": int(mesh.ndof), "nfree": int(problem.nfree),
        "ncells": int(mesh.ncells), "points": len(rec.rows) - 1, "attempts": run.attempts,
        "cutbacks": run.cutbacks, "newton_iterations": run.newton_iterations,
        "status": run.status, "message": run.message, "stop_reason": rec.stop_reason,
        "solver": solver.name, "solve_time": solver.time, "solves": solver.calls,
        "analyses": solver.analyses, "factorisations": solver.factorisations,
        "tangents_reused": run.tangents_reused, "chord_steps": run.chord_steps,
        "restarts": run.restarts,
        "assembly_time": problem.stats.time, "mesh_time": t_mesh,
        "wall_time": time.perf_counter() - t0, "p_max": p_end, "length_unit_m": L,
        "stress_unit_pa": mu, "tilt": beta,
        "resumed_points": checkpoint.resumed if checkpoint is not None else 0,
        "settings": {k: (v if not isinstance(v, MeshDensity) else asdict(v))
                     for k, v in asdict(s).items()},
    }
    resp = build_response(rec.path(), length=module.length, shear_modulus=mu, backend="fe",
                          break_stretch=g.material.break_stretch,
                          meta={"module": module.name, "kind": module.kind},
                          signal="twist_rate")
    rows = rec.rows
    return FETwistResult(
        module=module, mesh=mesh, response=resp,
        pressure=np.array([r["pressure"] for r in rows]),
        twist_angle=np.array([r["twist_angle"] for r in rows]),
        axial_stretch=np.array([r["axial_stretch"] for r in rows]),
        tip=np.array([r["tip"] for r in rows]), displacements=np.array(rec.u),
        stretch=np.array(rec.cell_stretch), stats=stats)


def compare_twisting(result: FETwistResult, module: Module | None = None, *,
                     rom: Response | None = None, rom_p_max: float | None = None,
                     points: int = 6) -> dict[str, Any]:
    """FE against the reduced model of a twisting module: twist angle and axial stretch at
    common pressures, Pc and Ph, relative differences (rom − fe)/fe.

    The reduced model's module strains come from :func:`multimorph.device._modules.
    module_strains` on its cell response (as :func:`~multimorph.fe.compare_device` does): the
    strip's mid-height strain ε gives τ = ε sin 2β / R and the axial stretch 1 + ε cos²β.
    Both angles are in the sense of the tilt (FE: −sign(β) times the signed angle about +y;
    the reduced model: sign(β) τ L, its formula has no handedness of its own). Its Pc and
    Ph are those of its cell response (read on the cell's curvature), FE's on the module's
    twist rate.

    Parameters
    ----------
    result : FETwistResult
    module : Module, optional
        Default ``result.module``.
    rom : Response, optional
        The reduced model's cell response; default :func:`multimorph.rom.solve_cell` on the
        module's cell to ``rom_p_max``.
    rom_p_max : float, optional
        Highest pressure of the reduced model (Pa); default twice the highest FE pressure
        (the reduced model is stiffer than FE and cheap).
    points : int
        Common pressures: evenly spaced up to the highest FE pressure on the FE loading curve.

    Returns
    -------
    dict
        ``pressure_pa``, ``twist_deg_fe``, ``twist_deg_rom``, ``twist_rel``,
        ``stretch_fe``, ``stretch_rom``, ``stretch_rel`` (lists; ``stretch_rel`` compares
        the elongations λ − 1), ``pc_fe``, ``pc_rom``,
        ``pc_rel``, ``ph_fe``, ``ph_rom``, ``ph_rel`` (Pa, relative or None), ``rom_p_max``.
    """
    from multimorph.device._modules import module_strains
    from multimorph.fe._device import _reached, _rel

    mod = module or result.module
    p_rom = float(rom_p_max if rom_p_max is not None else 2.0 * np.max(result.pressure))
    if rom is None:
        from multimorph.rom import solve_cell

        rom = solve_cell(mod.cell, p_rom)
    ms = module_strains(mod, rom)
    sense = _sense(mod.tilt)
    lo = result.response.loading
    top = float(np.max(lo.pressure))
    P = np.linspace(top / points, top, points)
    fe_angle = np.interp(P, lo.pressure, lo.twist_rate) * mod.length
    fe_stretch = np.interp(P, lo.pressure, lo.axial_stretch)
    rom_angle = sense * np.interp(P, ms.pressure, ms.twist) * mod.length
    rom_stretch = np.interp(P, ms.pressure, ms.stretch)
    cr = rom.characteristic
    pc_f, ph_f = result.activation()
    pc_r = _reached(cr.critical, rom)
    ph_r = None if pc_r is None else _reached(cr.hardening, rom)

    def rel(a: np.ndarray, b: np.ndarray) -> list[float | None]:
        return [_rel(float(x), float(y)) for x, y in zip(a, b, strict=True)]

    return {"module": mod.name, "rom_p_max": p_rom, "pressure_pa": P.tolist(),
            "twist_deg_fe": np.degrees(fe_angle).tolist(),
            "twist_deg_rom": np.degrees(rom_angle).tolist(),
            "twist_rel": rel(rom_angle, fe_angle),
            "stretch_fe": fe_stretch.tolist(), "stretch_rom": rom_stretch.tolist(),
            "stretch_rel": rel(rom_stretch - 1.0, fe_stretch - 1.0),
            "pc_fe": pc_f, "pc_rom": pc_r, "pc_rel": _rel(pc_r, pc_f),
            "ph_fe": ph_f, "ph_rom": ph_r, "ph_rel": _rel(ph_r, ph_f),
            "signal_fe": "twist_rate", "signal_rom": cr.signal}


def write_twist_vtu(result: FETwistResult, folder: Any, stem: str = "module") -> list[str]:
    """The module's VTU series (:func:`~multimorph.fe._output.write_hex_series`), tagged by
    region (0 wall, 1 bottom layer, 2 shaft), strip (−1: the shaft) and material."""
    from multimorph.fe._output import write_hex_series

    m = result.mesh
    return write_hex_series(folder, stem, m.points, m.cells, result.displacements,
                            result.stretch, result.pressure,
                            {"region": m.region, "strip": m.strip, "material": m.material})


def write_twist_csv(result: FETwistResult, path: Any) -> None:
    """The path as CSV: pressure, signed twist angle and rate, axial stretch, chamber volume,
    volume ratio, peak stretch, stability, arc-length step (SI, angles in degrees)."""
    import csv

    p = result.response.path
    cols = {"pressure_pa": p.pressure, "twist_angle_deg": np.degrees(result.twist_angle),
            "twist_rate_rad_per_m": result.twist_angle / result.module.length,
            "axial_stretch": p.axial_stretch, "chamber_volume_m3": p.volume,
            "volume_ratio": p.extra["volume_ratio"], "peak_stretch": p.peak_stretch}
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow([*cols, "stable", "arc_length_step"])
        for i in range(len(p)):
            w.writerow([*(f"{c[i]:.8g}" for c in cols.values()), int(p.stable[i]),
                        int(p.extra["arc_length"][i])])


def plot_twist(result: FETwistResult, folder: Any) -> list[str]:
    """``curves.png`` (pressure against twist angle, axial stretch, V/V0 and peak stretch,
    Pc and Ph marked) and ``snapshots.png`` (the free end third seen along the axis,
    coloured by stretch) in ``folder``; returns the file names."""
    from pathlib import Path

    from multimorph.fe._output import plot_hex_snapshots, plot_path_panels

    folder = Path(folder)
    p = result.response.path
    pc, ph = result.activation()
    marks = [(v, k) for v, k in ((pc, "Pc"), (ph, "Ph")) if v is not None]
    plot_path_panels(
        result.pressure, p.stable,
        [("twist angle (°, right-handed about +y)", {"twist": np.degrees(result.twist_angle)}),
         ("axial stretch (-)", {"stretch": p.axial_stretch}),
         ("V / V0 (-)", {"V/V0": p.extra["volume_ratio"]}),
         ("peak principal stretch (-)", {"peak": p.peak_stretch})],
        folder / "curves.png", marks=marks,
        title=f"FE twisting module {result.module.name} ({result.stats.get('nfree', '?')} DOF)")
    m = result.mesh
    plot_hex_snapshots(m.points, m.cells, result.displacements, result.stretch,
                       result.pressure, folder / "snapshots.png", view=(0, 2), slab=1,
                       slab_side="high", title="free-end third seen along the axis (x–z)")
    return ["curves.png", "snapshots.png"]
