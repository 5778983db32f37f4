"""ROM vs FE: Pc, Ph and κ(P) of one cell side by side with relative differences; the
in-plane shear of a strip of tilted (twisting) cells against the ROM's twisting kinematics;
every module of a device; a twisting module's twist and stretch."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from multimorph.device import Module, module_strains
from multimorph.errors import MultimorphError, SpecError
from multimorph.fe.analyses._cell import FEResult, simulate_cell
from multimorph.fe.analyses._device import FEDeviceResult
from multimorph.fe.analyses._run import activation
from multimorph.fe.analyses._twist import FETwistResult, tilt_sense
from multimorph.fe.engine import FESettings
from multimorph.geometry import CellGeometry
from multimorph.response import Response

__all__ = ["Comparison", "RomComparison", "ShearComparison", "bend_curvature", "compare_cell",
           "compare_cell_run", "compare_device", "compare_responses", "compare_shear",
           "compare_shear_responses", "compare_twisting", "model_label"]


def _rel(a: float | None, b: float | None) -> float | None:
    """The relative difference (a − b)/b, ``None`` where either is missing or b is 0."""
    if a is None or b is None or b == 0:
        return None
    return (a - b) / b


@dataclass(frozen=True)
class Comparison:
    """Reduced model against FE for one cell (SI units; relative differences (rom − fe)/fe).

    Attributes
    ----------
    pc_rom, pc_fe, ph_rom, ph_fe : float or None
        Critical and hardening pressures (Pa).
    pc_rel, ph_rel : float or None
    pressure : ndarray
        Common pressures of the κ comparison (Pa), within both observed loading curves.
    kappa_rom, kappa_fe : ndarray
        Curvature (1/m) on the observed loading curves at ``pressure``: the end rotation
        over the length where the response records one (an FE run; what the cell models'
        κ is), else the response's own curvature (:func:`bend_curvature`).
    kappa_rel_max : float or None
        Largest |κ_rom − κ_fe| relative to the largest |κ_fe| on the common range.
    signal : str
        What Pc and Ph were read on: ``"curvature"``, or ``"axial_stretch"`` for a
        mirror-symmetric (stretching) cell, which does not bend.
    stretch_rom, stretch_fe : ndarray
        Axial stretch on the observed loading curves at ``pressure``.
    stretch_rel_max : float or None
        Largest |λ_rom − λ_fe| relative to the largest |λ_fe − 1|.
    """

    pc_rom: float | None
    pc_fe: float | None
    ph_rom: float | None
    ph_fe: float | None
    pc_rel: float | None
    ph_rel: float | None
    pressure: np.ndarray
    kappa_rom: np.ndarray
    kappa_fe: np.ndarray
    kappa_rel_max: float | None
    meta: dict[str, Any] = field(default_factory=dict)
    signal: str = "curvature"
    stretch_rom: np.ndarray = field(default_factory=lambda: np.zeros(0))
    stretch_fe: np.ndarray = field(default_factory=lambda: np.zeros(0))
    stretch_rel_max: float | None = None
    #: what κ is on each side (:func:`bend_curvature`)
    kappa_measure: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "critical_pressure": {"rom": self.pc_rom, "fe": self.pc_fe, "rel": self.pc_rel},
            "hardening_pressure": {"rom": self.ph_rom, "fe": self.ph_fe, "rel": self.ph_rel},
            "kappa": {"pressure": self.pressure.tolist(), "rom": self.kappa_rom.tolist(),
                      "fe": self.kappa_fe.tolist(), "rel_max": self.kappa_rel_max,
                      "measure": self.kappa_measure},
            "signal": self.signal,
            "axial_stretch": {"pressure": self.pressure.tolist(),
                              "rom": self.stretch_rom.tolist(), "fe": self.stretch_fe.tolist(),
                              "rel_max": self.stretch_rel_max},
            "meta": self.meta,
        }


def model_label(response: Response) -> str:
    """Which cell model made a (non-FE) response: ``"calibrated"``, ``"ritz"`` or its own
    name."""
    name = str(response.meta.get("model", response.backend))
    return "ritz" if name in ("rom", "ritz", "cell-ritz") else name


def _thin(values: np.ndarray, most: int = 80) -> list[float]:
    """At most ``most`` evenly spread values of a curve (both ends kept), for JSON."""
    values = np.asarray(values, float)
    if len(values) <= most:
        return values.tolist()
    return values[np.unique(np.linspace(0, len(values) - 1, most).round().astype(int))
                  ].tolist()


def _module_curves(module: Module, fe: Response, rom: Any) -> dict[str, Any]:
    """A device module's motion against pressure on both observed loading curves, in the
    quantity of its kind: bend angle (deg; toward its stiff layer in both), axial stretch,
    or the twist angle's magnitude (deg; the two senses are not the same convention)."""
    load = fe.loading
    if module.kind == "bending":
        quantity, fe_y, rom_y = ("bend_angle_deg", np.degrees(load.extra["bend_angle"]),
                                 np.degrees(rom.measure))
    elif module.kind == "stretching":
        quantity, fe_y, rom_y = "axial_stretch", load.axial_stretch, rom.stretch
    else:
        quantity, fe_y, rom_y = ("twist_angle_abs_deg",
                                 np.abs(np.degrees(load.extra["twist_angle"])),
                                 np.abs(np.degrees(rom.measure)))
    return {"quantity": quantity, "pressure_pa_fe": _thin(load.pressure),
            "fe": _thin(fe_y), "pressure_pa_rom": _thin(rom.pressure), "rom": _thin(rom_y)}


def _rom_cell_model() -> Any:
    """:func:`multimorph.rom.simulate_cell`, or an error that says the ROM is missing."""
    try:
        from multimorph.rom import simulate_cell
    except ImportError as exc:
        raise MultimorphError(f"the reduced model (multimorph.rom) is not available: {exc}"
                              ) from exc
    return simulate_cell


def bend_curvature(response: Response) -> tuple[np.ndarray, str]:
    """The curvature of a response's observed loading curve as the cell models define it:
    its end rotation over its length where the path records one (an FE cell or module:
    ``extra["bend_angle"]``; the cell models' κd is the end rotation per cell, what their
    FE data measure), else its own curvature (an FE cell's is the circle fit of its
    bottom edge, which bends about half as much as the end face turns: the examples' cells
    0.44-0.48 of it). Returns the curvature (1/m) and which measure it is."""
    lo = response.loading
    bend = (lo.extra or {}).get("bend_angle")
    if bend is not None and response.length > 0 and len(bend) == len(lo.pressure):
        return np.asarray(bend, float) / response.length, "end rotation / length"
    return np.asarray(lo.curvature, float), "curvature"


def compare_responses(rom: Response, fe: Response, n: int = 25) -> Comparison:
    """Compare two responses of the same cell (any two backends); κ(P) on the end rotation
    where a response records one (:func:`bend_curvature`; Pc and Ph stay each response's
    own)."""
    cr, cf = rom.characteristic, fe.characteristic
    lr, lf = rom.loading, fe.loading
    hi = min(float(np.max(lr.pressure)), float(np.max(lf.pressure)))
    P = np.linspace(0.0, hi, n)
    (kr_path, kr_how), (kf_path, kf_how) = bend_curvature(rom), bend_curvature(fe)
    kr = np.interp(P, lr.pressure, kr_path)
    kf = np.interp(P, lf.pressure, kf_path)
    scale = float(np.max(np.abs(kf))) if len(kf) else 0.0
    krel = float(np.max(np.abs(kr - kf)) / scale) if scale > 0 else None
    sr = np.interp(P, lr.pressure, lr.axial_stretch)
    sf = np.interp(P, lf.pressure, lf.axial_stretch)
    s_scale = float(np.max(np.abs(sf - 1.0))) if len(sf) else 0.0
    srel = float(np.max(np.abs(sr - sf)) / s_scale) if s_scale > 0 else None
    return Comparison(cr.critical, cf.critical, cr.hardening, cf.hardening,
                      _rel(cr.critical, cf.critical), _rel(cr.hardening, cf.hardening),
                      P, kr, kf, krel, signal=cr.signal, stretch_rom=sr, stretch_fe=sf,
                      stretch_rel_max=srel, kappa_measure={"rom": kr_how, "fe": kf_how})


def compare_cell(geometry: CellGeometry, p_max: float, fe_settings: Any = None,
                 n_cells: int = 1) -> Comparison:
    """Run the reduced model (:func:`multimorph.rom.simulate_cell`) and FE on ``geometry``.

    With ``n_cells`` > 1 FE inflates a module of that many cells in series; the reduced
    model's cell curvature is the module's (every cell of a module bends alike there), so
    the comparison tests that assumption too.
    """
    rom_simulate = _rom_cell_model()
    t = time.perf_counter()
    rom = rom_simulate(geometry, p_max)
    t_rom = time.perf_counter() - t
    settings = fe_settings if fe_settings is not None else FESettings()
    t = time.perf_counter()
    fe = simulate_cell(geometry, replace(settings, p_max=p_max), n_cells=n_cells)
    t_fe = time.perf_counter() - t
    c = compare_responses(rom, fe.response)
    return Comparison(**{**c.__dict__, "meta": {"model": model_label(rom),
                                                  "rom_time": t_rom, "fe_time": t_fe,
                                                  "fe_dof": fe.stats["nfree"],
                                                  "fe_status": fe.stats["stop_reason"]
                                                  or fe.stats["status"]}})


@dataclass(frozen=True)
class ShearComparison:
    """In-plane shear γ(P) of a tilted strip: FE against the ROM's twisting kinematics.

    Both curves are in the FE mesh's frame (x across the strip, y along it; chamber axis
    n = (−sin β, cos β), see :func:`~multimorph.fe.cell_mesh`): the ROM's natural strain
    ε = λ_mid − 1 of the straight cell along n gives γ_xy = −ε sin 2β and an axial strain
    ε cos²β (:mod:`multimorph.device._modules`, whose twisting module uses the magnitude
    ε sin 2β). The FE values are the strip's mean strain away from the clamp
    (``extra["shear"]``, ``extra["strip_axial_strain"]``).

    Attributes
    ----------
    tilt : float
        β (rad).
    pressure : ndarray
        Common pressures (Pa), within both observed loading curves, P = 0 left out.
    shear_rom, shear_fe : ndarray
        γ_xy (-) at ``pressure``.
    axial_rom, axial_fe : ndarray
        Axial strain of the strip (-) at ``pressure``.
    ratio : ndarray
        γ_fe / γ_rom (NaN where the ROM's shear is 0).
    shear_rel_max : float or None
        Largest |γ_rom − γ_fe| relative to the largest |γ_fe|.
    """

    tilt: float
    pressure: np.ndarray
    shear_rom: np.ndarray
    shear_fe: np.ndarray
    axial_rom: np.ndarray
    axial_fe: np.ndarray
    ratio: np.ndarray
    shear_rel_max: float | None
    meta: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"tilt_deg": math.degrees(self.tilt), "pressure": self.pressure.tolist(),
                "shear": {"rom": self.shear_rom.tolist(), "fe": self.shear_fe.tolist(),
                          "ratio_fe_rom": self.ratio.tolist(),
                          "rel_max": self.shear_rel_max},
                "axial_strain": {"rom": self.axial_rom.tolist(),
                                 "fe": self.axial_fe.tolist()},
                "meta": self.meta}


def compare_shear_responses(rom: Response, fe: Response, geometry: CellGeometry,
                            tilt: float, n: int = 25) -> ShearComparison:
    """Compare a tilted strip's FE shear with the ROM's on the straight cell ``geometry``.

    Parameters
    ----------
    rom : Response
        A cell model's response: the straight cell's (the Ritz twisting kinematics is
        applied to it), or the tilted cell's with its own strip shear
        (``path.extra["shear"]``, a model that answers tilted cells), as
        :func:`multimorph.device.module_strains` reads either.
    fe : Response
        A full-model FE response of a strip of ``geometry`` cells tilted by ``tilt``
        (:func:`~multimorph.fe.simulate_cell` with ``tilt``): ``extra["shear"]`` is read.
    geometry : CellGeometry
    tilt : float
        β (rad), 0 < |β| < 80°.
    n : int
        Number of common pressures.
    """
    if not 0.0 < abs(tilt) < math.radians(80.0):
        raise SpecError(f"tilt: compare_shear needs 0 < |tilt| < 80 degrees, got "
                        f"{math.degrees(tilt):.4g} deg")
    lf = fe.loading
    if "shear" not in lf.extra:
        raise SpecError("fe: the response records no strip shear (a full-model FE response "
                        "of a tilted strip is needed)")
    # the device's own twisting kinematics: γ = τ R on any shaft; its sign is that of sin 2β
    radius = geometry.height
    module = Module("strip", "twisting", geometry, tilt=tilt, shaft_radius=radius)
    ms = module_strains(module, rom)
    R = radius + 0.5 * geometry.height
    hi = min(float(np.max(ms.pressure)), float(np.max(lf.pressure)))
    P = np.linspace(hi / n, hi, n)
    g_rom = -np.interp(P, ms.pressure, ms.twist * R)  # mesh frame: γ_xy = −ε sin 2β
    a_rom = np.interp(P, ms.pressure, ms.stretch) - 1.0
    g_fe = np.interp(P, lf.pressure, lf.extra["shear"])
    a_fe = np.interp(P, lf.pressure, lf.extra["strip_axial_strain"])
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(g_rom != 0.0, g_fe / g_rom, np.nan)
    scale = float(np.max(np.abs(g_fe)))
    rel = float(np.max(np.abs(g_rom - g_fe)) / scale) if scale > 0 else None
    return ShearComparison(tilt, P, g_rom, g_fe, a_rom, a_fe, ratio, rel)


def compare_cell_run(rom: Response, fe: FEResult) -> Comparison | ShearComparison:
    """ROM vs FE of one cell run: a tilted strip's shear (:func:`compare_shear_responses`),
    else Pc, Ph and κ(P) (:func:`compare_responses`); ``rom`` is a cell model's response
    (for a tilted strip: the straight cell's or the tilted cell's, see
    :func:`compare_shear_responses`)."""
    tilt = fe.mesh.tilt
    if tilt:
        c: Comparison | ShearComparison = compare_shear_responses(rom, fe.response,
                                                                  fe.mesh.geometry, tilt)
    else:
        c = compare_responses(rom, fe.response)
    return replace(c, meta={**c.meta, "model": model_label(rom)})


def compare_shear(geometry: CellGeometry, tilt: float, p_max: float, fe_settings: Any = None,
                  n_cells: int = 2) -> ShearComparison:
    """Run the ROM on the straight cell and FE on a strip of ``n_cells`` tilted cells.

    The FE model is full (``half=False``, forced), clamped on its sheared end face; its
    shear is measured on the sections away from the clamp, so ``n_cells`` ≥ 2 is advised.

    Parameters
    ----------
    geometry : CellGeometry
    tilt : float
        Chamber tilt β (rad).
    p_max : float
        Highest pressure of both runs (Pa).
    fe_settings : FESettings, optional
    n_cells : int
        Cells in the FE strip.
    """
    rom_simulate = _rom_cell_model()
    settings = fe_settings if fe_settings is not None else FESettings()
    t = time.perf_counter()
    fe = simulate_cell(geometry, replace(settings, p_max=p_max, half=False), n_cells=n_cells,
                       tilt=tilt)
    t_fe = time.perf_counter() - t
    t = time.perf_counter()
    rom = rom_simulate(geometry, p_max)
    t_rom = time.perf_counter() - t
    c = compare_shear_responses(rom, fe.response, geometry, tilt)
    return replace(c, meta={"model": model_label(rom), "rom_time": t_rom, "fe_time": t_fe,
                            "fe_dof": fe.stats["nfree"],
                            "n_cells": n_cells,
                            "fe_status": fe.stats["stop_reason"] or fe.stats["status"]})


#: what a comparison with the reduced model returns: of a cell run, of a device or twisting
#: module (a dict)
RomComparison = Comparison | ShearComparison | dict[str, Any]


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
        to reach (the reduced model is stiffer than FE, docs/fe-formulation.md §6, and is
        cheap).

    Returns
    -------
    dict
        Per module: ``pc_fe``, ``pc_rom``, ``pc_rel``, ``ph_fe``, ``ph_rom``, ``ph_rel``
        (Pa, relative or None), the ``signal`` read, ``rom_p_max``, the reduced ``model``
        (calibrated or ritz) and ``curves``: the module's motion against pressure from
        both (``quantity``: ``bend_angle_deg``, ``axial_stretch`` or
        ``twist_angle_abs_deg``; ``pressure_pa_fe``, ``fe``, ``pressure_pa_rom``, ``rom``;
        at most 80 points each).
    """
    p_rom = float(rom_p_max if rom_p_max is not None else 2.0 * fe.stats["p_max"])
    if rom is None:
        from multimorph.device import simulate_device as rom_device

        rom = rom_device(fe.device, p_rom)
    out: dict[str, dict[str, Any]] = {}
    for module, src in zip(fe.mesh.modules, fe.mesh.source, strict=True):
        reduced = rom.strains[src].response
        pc_f, ph_f = fe.activation(module.name)
        pc_r, ph_r = activation(reduced)
        out[module.name] = {"kind": module.kind, "signal": reduced.characteristic.signal,
                            "rom_p_max": p_rom, "pc_fe": pc_f, "pc_rom": pc_r,
                            "pc_rel": _rel(pc_r, pc_f), "ph_fe": ph_f, "ph_rom": ph_r,
                            "ph_rel": _rel(ph_r, ph_f), "model": model_label(reduced),
                            "curves": _module_curves(module, fe.responses[module.name],
                                                     rom.strains[src])}
    return out


def compare_twisting(result: FETwistResult, module: Module | None = None, *,
                     rom: Response | None = None, rom_p_max: float | None = None,
                     points: int = 6) -> dict[str, Any]:
    """FE against the reduced model of a twisting module: twist angle and axial stretch at
    common pressures, Pc and Ph, relative differences (rom − fe)/fe.

    The reduced model's module strains come from :func:`multimorph.device.module_strains`
    on its cell response (as :func:`~multimorph.fe.compare_device` does): the strip's
    mid-height strain ε gives τ = ε sin 2β / R and the axial stretch 1 + ε cos²β. Both angles
    are in the sense of the tilt (FE: −sign(β) times the signed angle about +y; the reduced
    model: sign(β) τ L, its formula has no handedness of its own). Its Pc and Ph are those
    of its cell response: read on the cell's curvature for a straight cell's response (the
    Ritz model), on the tilted cell's twist rate for a model that answers tilted cells
    (its strip shear is then the module's, ``path.extra["shear"]``); FE's on the module's
    twist rate.

    Parameters
    ----------
    result : FETwistResult
    module : Module, optional
        Default ``result.module``.
    rom : Response, optional
        The cell model's response (the straight cell's, or the tilted cell's); default
        :func:`multimorph.rom.solve_cell` on the module's straight cell to ``rom_p_max``.
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
        ``pc_rel``, ``ph_fe``, ``ph_rom``, ``ph_rel`` (Pa, relative or None), ``rom_p_max``,
        the reduced ``model`` (ritz).
    """
    mod = module or result.module
    p_rom = float(rom_p_max if rom_p_max is not None else 2.0 * np.max(result.pressure))
    if rom is None:
        from multimorph.rom import solve_cell

        rom = solve_cell(mod.cell, p_rom)
    ms = module_strains(mod, rom)
    sense = tilt_sense(mod.tilt)
    lo = result.response.loading
    top = float(np.max(lo.pressure))
    P = np.linspace(top / points, top, points)
    fe_angle = np.interp(P, lo.pressure, lo.twist_rate) * mod.length
    fe_stretch = np.interp(P, lo.pressure, lo.axial_stretch)
    rom_angle = sense * np.interp(P, ms.pressure, ms.twist) * mod.length
    rom_stretch = np.interp(P, ms.pressure, ms.stretch)
    pc_f, ph_f = result.activation()
    pc_r, ph_r = activation(rom)

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
            "signal_fe": "twist_rate", "signal_rom": rom.characteristic.signal,
            "model": model_label(rom)}
