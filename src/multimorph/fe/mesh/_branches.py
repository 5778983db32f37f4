"""A device as FE meshes it: its branches, checked, and every piece placed in the mesh frame.

A branch is a series of modules (each starting where the previous ends); parallel branches
(``attach_to``, ``count`` copies at ``radius`` around the parent's axis) are placed as the
reduced model places them. A branch is cut into *pieces*: runs of bending and stretching
modules at 0° or 180° share one structured grid, any other module (a twisting module, a
module turned by another angle) is a piece of its own. :func:`fe_device_branches` says which
devices FE can hold.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from multimorph.device import Device, Module
from multimorph.errors import SpecError

__all__ = ["FE_DEVICE_KINDS", "FE_MODULE_KINDS", "FEBranch", "Placement", "device_pieces",
           "fe_device_branches", "fe_device_modules", "flipped", "grid_modules", "in_grid",
           "placements", "section_layout"]


#: Module kinds that the structured device grid (one series of box cells) can hold.
FE_MODULE_KINDS = ("bending", "stretching")

#: Module kinds an FE device can hold (a twisting module is a mesh of its own, tied to its
#: neighbours by rigid hubs).
FE_DEVICE_KINDS = ("bending", "stretching", "twisting")

_SUPPORTED = ("FE devices support branches of bending, stretching and twisting modules in "
              "series (each starting where the previous ends); a branch attaches to the end "
              "of a module with one copy")


@dataclass(frozen=True)
class FEBranch:
    """One branch of a device as FE meshes it: ``modules`` in series, ``count`` copies at
    ``radius`` around the axis of ``parent``'s end (``None``: the clamped main branch)."""

    name: str
    modules: tuple[Module, ...]
    parent: str | None = None
    count: int = 1
    radius: float = 0.0


def fe_device_branches(device: Device) -> tuple[FEBranch, ...]:
    """The device's branches, parents before children, checked for FE.

    Raises
    ------
    SpecError
        Naming the module and field for anything FE cannot hold: a gap between modules of a
        branch, copies
        (``count`` > 1) on the clamped branch or differing within a branch, a branch attached
        to a module with copies.
    """
    for module in device.modules:
        if module.kind not in FE_DEVICE_KINDS:
            raise SpecError(f"module {module.name!r}.kind: {module.kind!r} is not supported by FE; "
                            f"{_SUPPORTED}")
    out: list[FEBranch] = []
    for name, mods in device.branches().items():
        parent = next((module.attach_to for module in mods if module.attach_to is not None), None)
        for a, b in itertools.pairwise(mods):
            if abs(b.start - a.end) > 1e-9 * max(a.end, 1e-3):
                raise SpecError(f"module {b.name!r}.start: starts at {b.start * 1e3:.4g} mm, "
                                f"not where {a.name!r} ends ({a.end * 1e3:.4g} mm); {_SUPPORTED}")
        counts = {module.count for module in mods}
        if len(counts) > 1:
            raise SpecError(f"module {mods[-1].name!r}.count: the modules of branch {name!r} "
                            f"have different counts {sorted(counts)}; {_SUPPORTED}")
        count = mods[0].count
        if parent is None and count != 1:
            raise SpecError(f"module {mods[0].name!r}.count: {count} copies of the clamped "
                            f"branch {name!r} are not supported by FE; {_SUPPORTED}")
        if parent is not None and device.module(parent).count != 1:
            raise SpecError(f"module {mods[0].name!r}.attach_to: {parent!r} has "
                            f"{device.module(parent).count} copies; {_SUPPORTED}")
        out.append(FEBranch(name, tuple(mods), parent, count, mods[0].radius))
    roots = [b for b in out if b.parent is None]
    if len(roots) != 1:
        names = ", ".join(sorted(b.name for b in roots))
        raise SpecError(f"module branch: the device has {len(roots)} clamped branches "
                        f"({names}); FE needs exactly one (the others attach_to a module)")
    ordered = roots
    placed = {module.name for module in roots[0].modules}
    rest = [b for b in out if b.parent is not None]
    while rest:  # Device validation rules out cycles
        ready = [b for b in rest if b.parent in placed]
        ordered += ready
        placed |= {module.name for b in ready for module in b.modules}
        rest = [b for b in rest if b not in ready]
    return tuple(ordered)


def fe_device_modules(device: Device) -> tuple[Module, ...]:
    """The device's modules in order along its one branch, for one structured grid (a series
    of bending and stretching modules), checked for FE.

    Raises
    ------
    SpecError
        As :func:`fe_device_branches`, and for a device with more than one branch or with a
        twisting module.
    """
    branches = fe_device_branches(device)
    if len(branches) != 1:
        names = ", ".join(b.name for b in branches)
        raise SpecError(f"module branch: the device has {len(branches)} branches ({names}); "
                        "this needs a single series of modules")
    for module in branches[0].modules:
        if module.kind not in FE_MODULE_KINDS:
            raise SpecError(f"module {module.name!r}.kind: {module.kind!r}; one grid holds a "
                            f"series of {' and '.join(FE_MODULE_KINDS)} modules")
        if not in_grid(module):
            raise SpecError(f"module {module.name!r}.orientation: "
                            f"{math.degrees(module.orientation):.4g} deg; one grid holds modules "
                            f"at 0 or 180 deg")
    return branches[0].modules


def flipped(module: Module) -> bool:
    """Whether ``module`` is turned over (an orientation other than 0°)."""
    return abs(math.remainder(module.orientation, 2.0 * math.pi)) > 1e-9


def section_layout(mods: tuple[Module, ...]) -> tuple[float, float, list[dict[str, Any]]]:
    """Common box W × H and, per module, its outer box, chamber box and bottom layer in
    global x, z (every cross-section centred on the axis x = W/2, z = H/2; a module turned
    by 180° has its stiff layer on top)."""
    W = max(module.cell.width for module in mods)
    H = max(module.cell.height for module in mods)
    layout = []
    for module in mods:
        cell = module.cell
        zb = H / 2 - cell.height / 2
        lower = cell.ht if flipped(module) else cell.hb
        z0 = zb + lower
        layout.append({"x0": W / 2 - cell.width / 2, "zb": zb, "zt": zb + cell.height, "z0": z0,
                    "z1": z0 + cell.hc, "xc": W / 2 - cell.width / 2 + cell.ws,
                    "bot": (zb + cell.height - cell.hb, zb + cell.height) if flipped(module)
                    else (zb, zb + cell.hb)})
    return W, H, layout


def _boxes(mods: tuple[Module, ...]) -> tuple[list[tuple[float, ...]], list[tuple[float, ...]]]:
    """Outer and chamber boxes ``(x, y, z, dx, dy, dz)`` of one series branch in its grid's
    frame (axis x = W/2, z = H/2, from y = 0)."""
    W, _, layout = section_layout(mods)
    outer, inner = [], []
    y0 = 0.0
    for module, q in zip(mods, layout, strict=True):
        cell = module.cell
        outer.append((q["x0"], y0, q["zb"], W - 2 * q["x0"], module.n_cells * cell.d,
                      q["zt"] - q["zb"]))
        for k in range(module.n_cells):
            inner.append((q["xc"], y0 + k * cell.d + cell.df, q["z0"], W - 2 * q["xc"],
                          cell.d - 2 * cell.df, q["z1"] - q["z0"]))
        y0 += module.n_cells * cell.d
    return outer, inner


def _rot_y(angle: float) -> np.ndarray:
    """Rotation by ``angle`` about y (the reduced model's placement of parallel copies)."""
    cos_a, sin_a = math.cos(angle), math.sin(angle)
    return np.array([[cos_a, 0.0, sin_a], [0.0, 1.0, 0.0], [-sin_a, 0.0, cos_a]])


def in_grid(module: Module) -> bool:
    """Whether ``m`` can share a series grid: a bending or stretching module whose bending
    plane is a grid plane (orientation 0° or 180°)."""
    return (module.kind in FE_MODULE_KINDS
            and abs(math.remainder(module.orientation, math.pi)) <= 1e-9)


def _segments(mods: tuple[Module, ...]) -> list[tuple[Module, ...]]:
    """A branch cut into meshable pieces: runs of bending and stretching modules at 0° or
    180° (one grid each) and single modules otherwise (a twisting module's strips on a
    shaft, or the grid of a module turned by another angle, placed turned)."""
    out: list[tuple[Module, ...]] = []
    for module in mods:
        if in_grid(module) and out and in_grid(out[-1][-1]):
            out[-1] = (*out[-1], module)
        else:
            out.append((module,))
    return out


def _turned(seg: tuple[Module, ...]) -> bool:
    """A one-module piece that is placed turned by its orientation (its own grid unturned)."""
    return not in_grid(seg[0])


def grid_modules(seg: tuple[Module, ...]) -> tuple[Module, ...]:
    """The modules a piece's grid is built from: a turned piece's module unturned (the
    placement turns it)."""
    return tuple(replace(module, orientation=0.0) for module in seg) if _turned(seg) else seg


@dataclass(frozen=True)
class Placement:
    """A piece (a segment of a branch copy) in the mesh frame: local point p ↦ origin +
    Q (p − centre), its start section at local y = 0 on the local axis through ``centre``.
    ``parent`` is the module entry (name, copy) whose end it is tied to, ``None`` for the
    clamped start of the main branch."""

    branch: FEBranch
    copy: int
    modules: tuple[Module, ...]
    origin: np.ndarray
    Q: np.ndarray
    centre: np.ndarray
    parent: tuple[str, int] | None

    @property
    def twisting(self) -> bool:
        return self.modules[0].kind == "twisting"


def _centre(seg: tuple[Module, ...]) -> np.ndarray:
    """The axis of a piece's own mesh: (W/2, 0, H/2) of a grid, the origin of a twisting
    module's mesh."""
    if seg[0].kind == "twisting":
        return np.zeros(3)
    W, H, _ = section_layout(seg)
    return np.array([W / 2, 0.0, H / 2])


def placements(branches: tuple[FEBranch, ...]) -> list[Placement]:
    """Every piece placed as the reduced model places it. The clamped branch's first piece
    is the mesh frame; pieces of a branch follow each other along its axis; copy j of an
    attached branch starts at its parent's end section, turned by 2πj/count about the
    parent's axis and moved ``radius`` along the turned z; a module that is a piece of its
    own (twisting, or bending at an angle other than 0° or 180°) is turned by its
    ``orientation`` about its own axis."""
    out: list[Placement] = []
    end: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    axis0 = _centre(_segments(branches[0].modules)[0])
    for branch in branches:
        for j in range(branch.count):
            if branch.parent is None:
                origin, Q = axis0.copy(), np.eye(3)
            else:
                end_origin, end_frame = end[branch.parent]
                Q = end_frame @ _rot_y(2.0 * math.pi * j / branch.count)
                origin = end_origin + Q @ np.array([0.0, 0.0, branch.radius])
            parent = None if branch.parent is None else (branch.parent, 0)
            for seg in _segments(branch.modules):
                Qp = Q @ _rot_y(seg[0].orientation) if _turned(seg) else Q
                out.append(Placement(branch, j, seg, origin.copy(), Qp, _centre(seg), parent))
                y = 0.0
                for module in seg:
                    y += module.length
                    if j == 0:
                        end[module.name] = (origin + Q @ np.array([0.0, y, 0.0]), Q)
                origin = origin + Q @ np.array([0.0, y, 0.0])
                parent = (seg[-1].name, j)
    return out


def _affine(piece: Placement) -> list[float]:
    """Row-major 3 × 4 map of a placement (local grid frame → mesh frame, m)."""
    t = piece.origin - piece.Q @ piece.centre
    return [*piece.Q[0], t[0], *piece.Q[1], t[1], *piece.Q[2], t[2]]


def device_pieces(device: Device) -> list[tuple[list[tuple[float, ...]], list[tuple[float, ...]],
                                                list[float]]]:
    """The device solid as pieces, one per grid (a series of bending and stretching modules
    of a branch copy): its outer and chamber boxes in its own grid frame
    (each ``(x, y, z, dx, dy, dz)``; the solid is the union of the outer boxes minus the
    chambers) and the row-major 3 × 4 affine map (m) into the mesh frame. A series device is
    one piece with the identity map.
    Twisting modules (tilted strips around a shaft, not boxes) are not among them. Pieces
    touch only where the geometry makes them; FE joins them by rigid hubs (see the module
    docstring)."""
    return [(*_boxes(grid_modules(piece.modules)), _affine(piece))
            for piece in placements(fe_device_branches(device)) if not piece.twisting]
