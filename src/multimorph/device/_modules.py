r"""Modules: rows of cells along a rod, each turning a cell response into rod strains.

A module is ``n_cells`` identical cells in series along its axis (reference length
``n_cells · d``). From one cell response (κ, axial stretch, along pressure) it gives the
module's strains per unit length in its body frame (see :mod:`._kinematics`):

- **bending**: the cells' curvature κ(P) bends the module about its x axis, toward the stiff
  bottom layer. ``orientation`` rotates the bending plane about the axis (180°: the stiff
  layer on the other side, so the module bends the opposite way).
- **stretching**: cells without a stiff layer (symmetric walls) lengthen. The module marks its
  cell mirror-symmetric (``CellGeometry.symmetric``), so the reduced model bulges the bottom
  wall like the top one, holds κ = 0 and reads Pc/Ph on the axial stretch; the module's
  stretch is the cell's axial stretch λ = λ0 (1 + κ h/2) (κ = 0 here; the FE backend measures
  it on the mesh). Its radial bulge is reported too.
- **twisting**: cells tilted by β to the strip axis on strips around a central shaft
  (``strips`` of them, equally spaced). Each strip's chambers expand along the cell axis,
  which makes an angle β with the strip axis; the strip's natural strain at its mid-height
  ε = λ − 1 (as for stretching) splits into an axial part ε cos²β and an in-surface shear
  γ = ε sin 2β on the shaft's surface of radius R (shaft radius + half the strip height).
  Bending of the strips cancels by symmetry; the shear gives a twist rate τ = γ / R and the
  axial part an axial stretch 1 + ε cos²β. Assumption: the shaft is compliant in torsion
  compared with the strips' expansion (it transmits, not resists, the twist), as for the
  reference device's soft central shaft.

Multi-chamber bending (the double-curvature device) is several bending modules in series with
different cells and orientations.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from multimorph.errors import SpecError
from multimorph.geometry import CellGeometry
from multimorph.response import Response

__all__ = ["MODULE_KINDS", "Module", "ModuleStrains", "module_strains", "path_strains"]

MODULE_KINDS = ("bending", "stretching", "twisting")
MODE_OF_KIND = {"bending": "bend", "stretching": "stretch", "twisting": "twist"}


@dataclass(frozen=True)
class Module:
    """A module of the device (lengths in m, angles in rad).

    Parameters
    ----------
    name : str
    kind : {"bending", "stretching", "twisting"}
    cell : CellGeometry
    n_cells : int
        Cells in series along the module axis.
    branch : str
        Name of the branch of the backbone it sits on (modules of one branch are in series).
    attach_to : str or None
        Module whose end this branch starts from (parallel branches such as fingers);
        ``None`` for the base.
    start : float
        Distance of the module's start along its branch (m).
    count : int
        Identical copies spaced equally around the axis of the parent (e.g. 3 fingers).
    radius : float
        Radial offset of the copies from the parent axis (m).
    orientation : float
        Rotation of the module's bending plane about its own axis (rad).
    tilt : float
        Twisting modules: chamber tilt β to the strip axis (rad).
    shaft_radius : float
        Twisting modules: radius of the central shaft (m).
    strips : int
        Twisting modules: number of strips around the shaft.
    """

    name: str
    kind: str
    cell: CellGeometry
    n_cells: int = 1
    branch: str = "main"
    attach_to: str | None = None
    start: float = 0.0
    count: int = 1
    radius: float = 0.0
    orientation: float = 0.0
    tilt: float = 0.0
    shaft_radius: float = 0.0
    strips: int = 3

    def __post_init__(self) -> None:
        where = f"module {self.name!r}"
        if not self.name:
            raise SpecError("module: 'name' must be a non-empty string")
        if self.kind not in MODULE_KINDS:
            raise SpecError(f"{where}: kind must be one of {', '.join(MODULE_KINDS)}, "
                            f"got {self.kind!r}")
        for key in ("n_cells", "count", "strips"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise SpecError(f"{where}: {key} must be a positive integer, got {v!r}")
        for key in ("start", "radius", "shaft_radius"):
            v = getattr(self, key)
            if not (math.isfinite(v) and v >= 0):
                raise SpecError(f"{where}: {key} must be a non-negative length, got {v!r}")
        if self.kind == "twisting":
            if not 0 < abs(self.tilt) < math.pi / 2:
                raise SpecError(f"{where}: tilt must lie strictly between 0 and 90 degrees, "
                                f"got {math.degrees(self.tilt):.4g} deg")
            if not self.shaft_radius > 0:
                raise SpecError(f"{where}: twisting modules need shaft_radius > 0")
        if self.kind == "stretching":
            c = self.cell
            if c.bottom_material != c.material or not math.isclose(c.bottom_wall, c.top_wall):
                raise SpecError(
                    f"{where}: a stretching module has symmetric walls: bottom_wall must equal "
                    f"top_wall and bottom_material must equal material")
            if not c.symmetric:
                # the reduced model traces it as a mirror-symmetric cell (bulging bottom wall)
                object.__setattr__(self, "cell", c.mirrored())

    @property
    def length(self) -> float:
        """Reference length n_cells · d (m)."""
        return self.n_cells * self.cell.length

    @property
    def end(self) -> float:
        return self.start + self.length

    @property
    def mode(self) -> str:
        return MODE_OF_KIND[self.kind]

    def translated(self, start: float) -> Module:
        return replace(self, start=start)


@dataclass(frozen=True, eq=False)
class ModuleStrains:
    """A module's strains along the observed loading curve (arrays (n,), SI).

    ``bend`` κ (1/m, toward the stiff layer), ``twist`` τ (rad/m), ``stretch`` λ (-),
    ``bulge`` radial bulge of the top wall (m, 0 when not modelled); ``measure`` is the
    module's motion magnitude for sequence analysis: bend angle (rad), twist angle (rad) or
    λ − 1.
    """

    module: Module
    pressure: np.ndarray
    bend: np.ndarray
    twist: np.ndarray
    stretch: np.ndarray
    bulge: np.ndarray
    measure: np.ndarray
    unloading_pressure: np.ndarray
    unloading_measure: np.ndarray
    response: Response

    def at(self, pressure: float) -> dict[str, float]:
        """Strains interpolated at ``pressure`` (Pa) on the loading curve."""
        p = self.pressure
        return {k: float(np.interp(pressure, p, getattr(self, k)))
                for k in ("bend", "twist", "stretch", "bulge", "measure")}


def _mid_stretch(path: Any, cell: CellGeometry) -> np.ndarray:
    return np.asarray(path.axial_stretch) * (1.0 + np.asarray(path.curvature)
                                             * 0.5 * cell.height)


def path_strains(module: Module, path: Any) -> dict[str, np.ndarray]:
    """The module's strains per unit length along one path of its cell (an
    :class:`~multimorph.response.EquilibriumPath` or an observed curve): ``bend`` (1/m),
    ``twist`` (rad/m), ``stretch``, ``bulge`` and ``measure`` (bend angle, twist angle or
    stretch − 1, the module's motion), by the kinematics of the module docstring."""
    cell = module.cell
    kappa = np.asarray(path.curvature, float)
    zero = np.zeros_like(kappa)
    bulge = np.asarray(path.extra.get("top_bulge", zero), float) if path.extra else zero
    if bulge.shape != kappa.shape:
        bulge = zero
    if module.kind == "bending":
        return {"bend": kappa, "twist": zero, "stretch": np.asarray(path.axial_stretch, float),
                "bulge": bulge, "measure": kappa * module.length}
    lam = _mid_stretch(path, cell)
    if module.kind == "stretching":
        return {"bend": zero, "twist": zero, "stretch": lam, "bulge": bulge,
                "measure": lam - 1.0}
    eps = lam - 1.0
    beta = module.tilt
    R = module.shaft_radius + 0.5 * cell.height
    shear = path.extra.get("shear") if path.extra else None
    if shear is not None and np.shape(shear) == kappa.shape:
        # a tilted cell's own strip shear (calibrated model, FE), in the sense of its tilt:
        # τ = γ / R in the module's sense; the axial part by the same chamber-axis rule,
        # ε = γ / sin 2|β| along the chamber axis gives ε cos²β along the strip
        gamma = np.asarray(shear, float)
        tau = math.copysign(1.0, beta) * gamma / R
        stretch = 1.0 + gamma * math.cos(beta) ** 2 / math.sin(2.0 * abs(beta))
        return {"bend": zero, "twist": tau, "stretch": stretch, "bulge": bulge,
                "measure": tau * module.length}
    tau = eps * math.sin(2.0 * beta) / R
    return {"bend": zero, "twist": tau, "stretch": 1.0 + eps * math.cos(beta) ** 2,
            "bulge": bulge, "measure": tau * module.length}


def module_strains(module: Module, response: Response) -> ModuleStrains:
    """Turn a cell :class:`Response` into the module's strains on the observed curves."""
    load = path_strains(module, response.loading)
    unload = path_strains(module, response.unloading)
    return ModuleStrains(
        module=module,
        pressure=np.asarray(response.loading.pressure, float),
        unloading_pressure=np.asarray(response.unloading.pressure, float),
        unloading_measure=unload["measure"],
        response=response,
        **load,
    )


CellModel = Callable[[CellGeometry, float], Response]
