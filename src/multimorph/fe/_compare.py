"""ROM vs FE on one cell: Pc, Ph and κ(P) side by side with relative differences; and the
in-plane shear of a strip of tilted (twisting) cells against the ROM's twisting kinematics."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from multimorph.errors import MultimorphError, SpecError
from multimorph.geometry import CellGeometry
from multimorph.response import Response

__all__ = ["Comparison", "ShearComparison", "compare_cell", "compare_responses",
           "compare_shear", "compare_shear_responses"]


def _rel(a: float | None, b: float | None) -> float | None:
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
        Curvature (1/m) on the observed loading curves at ``pressure``.
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

    def to_dict(self) -> dict[str, Any]:
        return {
            "critical_pressure": {"rom": self.pc_rom, "fe": self.pc_fe, "rel": self.pc_rel},
            "hardening_pressure": {"rom": self.ph_rom, "fe": self.ph_fe, "rel": self.ph_rel},
            "kappa": {"pressure": self.pressure.tolist(), "rom": self.kappa_rom.tolist(),
                      "fe": self.kappa_fe.tolist(), "rel_max": self.kappa_rel_max},
            "signal": self.signal,
            "axial_stretch": {"pressure": self.pressure.tolist(),
                              "rom": self.stretch_rom.tolist(), "fe": self.stretch_fe.tolist(),
                              "rel_max": self.stretch_rel_max},
            "meta": self.meta,
        }


def compare_responses(rom: Response, fe: Response, n: int = 25) -> Comparison:
    """Compare two responses of the same cell (any two backends)."""
    cr, cf = rom.characteristic, fe.characteristic
    lr, lf = rom.loading, fe.loading
    hi = min(float(np.max(lr.pressure)), float(np.max(lf.pressure)))
    P = np.linspace(0.0, hi, n)
    kr = np.interp(P, lr.pressure, lr.curvature)
    kf = np.interp(P, lf.pressure, lf.curvature)
    scale = float(np.max(np.abs(kf))) if len(kf) else 0.0
    krel = float(np.max(np.abs(kr - kf)) / scale) if scale > 0 else None
    sr = np.interp(P, lr.pressure, lr.axial_stretch)
    sf = np.interp(P, lf.pressure, lf.axial_stretch)
    s_scale = float(np.max(np.abs(sf - 1.0))) if len(sf) else 0.0
    srel = float(np.max(np.abs(sr - sf)) / s_scale) if s_scale > 0 else None
    return Comparison(cr.critical, cf.critical, cr.hardening, cf.hardening,
                      _rel(cr.critical, cf.critical), _rel(cr.hardening, cf.hardening),
                      P, kr, kf, krel, signal=cr.signal, stretch_rom=sr, stretch_fe=sf,
                      stretch_rel_max=srel)


def compare_cell(geometry: CellGeometry, p_max: float, fe_settings: Any = None,
                 n_cells: int = 1) -> Comparison:
    """Run the reduced model (:func:`multimorph.rom.simulate_cell`) and FE on ``geometry``.

    With ``n_cells`` > 1 FE inflates a module of that many cells in series; the reduced
    model's cell curvature is the module's (every cell of a module bends alike there), so
    the comparison tests that assumption too.
    """
    import time

    from multimorph.fe._cell import FESettings, simulate_cell

    try:
        from multimorph.rom import simulate_cell as rom_simulate
    except ImportError as exc:
        raise MultimorphError(f"the reduced model (multimorph.rom) is not available: {exc}"
                              ) from exc
    t = time.perf_counter()
    rom = rom_simulate(geometry, p_max)
    t_rom = time.perf_counter() - t
    from dataclasses import replace

    s = fe_settings if fe_settings is not None else FESettings()
    s = replace(s, p_max=p_max)
    t = time.perf_counter()
    fe = simulate_cell(geometry, s, n_cells=n_cells)
    t_fe = time.perf_counter() - t
    c = compare_responses(rom, fe.response)
    return Comparison(**{**c.__dict__, "meta": {"rom_time": t_rom, "fe_time": t_fe,
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
        The straight cell's reduced-model response.
    fe : Response
        A full-model FE response of a strip of ``geometry`` cells tilted by ``tilt``
        (:func:`~multimorph.fe.simulate_cell` with ``tilt``): ``extra["shear"]`` is read.
    geometry : CellGeometry
    tilt : float
        β (rad), 0 < |β| < 80°.
    n : int
        Number of common pressures.
    """
    from multimorph.device import Module, module_strains

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
    import time
    from dataclasses import replace

    from multimorph.fe._cell import FESettings, simulate_cell

    try:
        from multimorph.rom import simulate_cell as rom_simulate
    except ImportError as exc:
        raise MultimorphError(f"the reduced model (multimorph.rom) is not available: {exc}"
                              ) from exc
    s = fe_settings if fe_settings is not None else FESettings()
    s = replace(s, p_max=p_max, half=False)
    t = time.perf_counter()
    fe = simulate_cell(geometry, s, n_cells=n_cells, tilt=tilt)
    t_fe = time.perf_counter() - t
    t = time.perf_counter()
    rom = rom_simulate(geometry, p_max)
    t_rom = time.perf_counter() - t
    c = compare_shear_responses(rom, fe.response, geometry, tilt)
    return replace(c, meta={"rom_time": t_rom, "fe_time": t_fe, "fe_dof": fe.stats["nfree"],
                            "n_cells": n_cells,
                            "fe_status": fe.stats["stop_reason"] or fe.stats["status"]})
