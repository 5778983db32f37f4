"""The structured hexahedral mesh of a device: modules in series and parallel branches, one
pressure line.

One grid holds each branch (a series of modules). Every module's cross-section is centred on
the common axis (x = W/2, z = H/2, with W × H the largest box); the grid is cut at every
module's wall planes (x and z: the union over modules, z mirrored within the section for a
module turned by 180°), and along y each module's cells follow each other from the branch's
start y = 0 (the clamped face of the main branch), as in :func:`~multimorph.fe.cell_mesh`.
A grid cell is kept when it lies inside its module's box and outside its chambers;
neighbouring modules' end walls merge into one partition, like adjacent cells of a module.
Every chamber is on the one pressure line.

Parallel branches (``attach_to``, ``count`` copies at ``radius`` around the parent's axis,
placed as the reduced model places them) get a grid each, turned and moved into place. The
parent module's end section and the start sections of every copy are tied by a rigid *hub*
(:class:`Hub`: a penalty multi-point constraint with a rotation point, FElupe's
``MultiPointConstraint``): the rigid joint the reduced model assumes. A branched device is
meshed whole (no mirror plane). :func:`fe_device_branches` says which devices FE can hold.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from multimorph.device import Device, Module
from multimorph.fe.mesh._branches import (
    FEBranch,
    Placement,
    fe_device_branches,
    grid_modules,
    in_grid,
    placements,
    section_layout,
)
from multimorph.fe.mesh._density import MeshDensity, resolve_density
from multimorph.fe.mesh._hex import (
    BOTTOM,
    WALL,
    HexMesh,
    carve,
    chamber_surface,
    graded_axis,
    material_bodies,
)
from multimorph.fe.mesh._twist import twisting_module_mesh
from multimorph.materials import Material

__all__ = ["DeviceMesh", "Hub", "device_mesh"]


@dataclass(frozen=True, eq=False)
class Hub:
    """A rigid joint: ``points`` (the parent's end section and the start sections of a
    branch's copies) keep their arms to ``center`` up to one rotation, whose rotation vector
    (rad) is the displacement of the extra node ``rotation``. ``parent`` and ``children``
    are module entries of the mesh."""

    points: np.ndarray
    center: int
    rotation: int
    parent: int
    children: tuple[int, ...]


@dataclass(frozen=True, eq=False)
class DeviceMesh(HexMesh):
    """A hexahedral mesh of a device with its tags (:class:`HexMesh`; m).

    Attributes
    ----------
    region : ndarray (m,)
        :data:`WALL` for wall elastomer, :data:`BOTTOM` for a module's bottom
        (strain-limiting) layer, :data:`SHAFT` for a twisting module's shaft.
    clamped, mirror : ndarray (n,) of bool
        Nodes on the mounting face y = 0 and on the mirror plane x = W/2 (half model).
    module : ndarray (m,)
        Index of the element's module in ``modules``.
    material : ndarray (m,)
        Index of the element's material in ``materials``.
    face_module : ndarray (k,)
        Module of each chamber face.
    start_sections, end_sections : tuple of ndarray
        Per module, the nodes of its start and end cross-section (inside its own box).
    starts : ndarray (k + 1,)
        y of every module's start and of the free end (m) along the clamped branch.
    modules : tuple of Module
        The module *entries*: every copy of a module with ``count`` > 1 is an entry named
        ``"<module>#<copy>"`` (as in the reduced model's shapes); ``source`` names the
        module it copies.
    materials : tuple of Material
        Distinct materials, in order of first use (module wall, then bottom layer).
    width, height : float
        The clamped branch's largest box W × H (m); its sections are centred on x = W/2,
        z = H/2.
    half : bool
    density : MeshDensity
    frames : tuple of (ndarray (3,), ndarray (3, 3))
        Per entry, the origin (centre of its start section) and the rotation Q whose
        columns are its branch copy's x, y (axis) and z axes in the undeformed mesh frame
        (an unturned module has its stiff layer towards −z of that frame).
    hubs : tuple of Hub
        Rigid joints of parallel branches (none for a series device). Their ``center`` and
        ``rotation`` nodes belong to no element.
    source : tuple of str
        Per entry, the name of the device module it is (a copy of).
    tip_entry : int
        The entry whose end section is the device's tip (the end of the clamped branch).
    """

    module: np.ndarray
    material: np.ndarray
    face_module: np.ndarray
    start_sections: tuple[np.ndarray, ...]
    end_sections: tuple[np.ndarray, ...]
    starts: np.ndarray
    modules: tuple[Module, ...]
    materials: tuple[Material, ...]
    width: float
    height: float
    half: bool
    density: MeshDensity = field(default_factory=MeshDensity)
    frames: tuple[tuple[np.ndarray, np.ndarray], ...] = ()
    hubs: tuple[Hub, ...] = ()
    source: tuple[str, ...] = ()
    tip_entry: int = -1

    def __post_init__(self) -> None:
        count = len(self.modules)
        if not self.frames:
            eye = np.eye(3)
            object.__setattr__(self, "frames", tuple(
                (np.array([self.width / 2, float(self.starts[i]), self.height / 2]), eye)
                for i in range(count)))
        if not self.source:
            object.__setattr__(self, "source", tuple(mod.name for mod in self.modules))
        if self.tip_entry < 0:
            object.__setattr__(self, "tip_entry", count - 1)

    @property
    def length(self) -> float:
        """Length of the clamped branch along y (m)."""
        return float(self.starts[-1])

    def bodies(self) -> list[tuple[np.ndarray, Material]]:
        """One body per distinct material (its elements and the material)."""
        return material_bodies(self.material, self.materials)


def _graded(breaks: list[float], walls: list[tuple[float, float]], edge: float, n: int,
            ) -> np.ndarray:
    """Coordinates through sorted breaks; an interval inside a wall of thickness t gets at
    least ⌈n · length / t⌉ elements, so every wall of every module has ≥ n through it."""
    scale = max(abs(breaks[0]), abs(breaks[-1]), 1e-3)
    tol = 1e-9 * scale
    cuts = [breaks[0]]
    for b in breaks[1:]:
        if b - cuts[-1] > tol:
            cuts.append(b)
    out = [np.array([cuts[0]])]
    for a, b in itertools.pairwise(cuts):
        k = 1
        for lo, hi in walls:
            if a >= lo - tol and b <= hi + tol:
                k = max(k, math.ceil(n * (b - a) / (hi - lo) - 1e-9))
        out.append(graded_axis([a, b], edge, k, {0})[1:])
    return np.concatenate(out)


def device_mesh(device: Device, mesh: str | MeshDensity = "coarse", *,
                element_size: float | None = None, half: bool = True) -> DeviceMesh:
    """Mesh a device: a structured hexahedral grid per branch copy, rigid hubs between.

    Parameters
    ----------
    device : Device
        Branches of bending and stretching modules (see :func:`fe_device_branches`).
    mesh : {"coarse", "medium", "fine"} or MeshDensity
        Density; the in-plane edge along y is each module's own (a fraction of its cell
        length), across (x, z) the smallest over a branch's modules.
    element_size : float, optional
        Explicit target edge length (m).
    half : bool
        Mesh only x ≤ W/2 (every module is mirror-symmetric about the common plane). Only a
        series device (one branch); a branched device is always meshed whole.

    Returns
    -------
    DeviceMesh
    """
    branches = fe_device_branches(device)
    density = resolve_density(mesh, element_size)
    if len(branches) == 1 and all(in_grid(module) for module in branches[0].modules):
        return _series_mesh(branches[0].modules, density, half)
    return _branched_mesh(branches, density)


def _series_mesh(mods: tuple[Module, ...], density: MeshDensity, half: bool) -> DeviceMesh:
    """One structured grid of modules in series (see :func:`device_mesh`)."""
    n = density.wall_elements
    W, H, layout = section_layout(mods)
    edge = min(density.edge(module.cell) for module in mods)
    xb = sorted({v for q in layout for v in (q["x0"], q["xc"])} | {W / 2})
    xh = _graded(xb, [(q["x0"], q["xc"]) for q in layout], edge, n)
    xs = xh if half else np.concatenate([xh, (W - xh[::-1])[1:]])
    zb_ = sorted({v for q in layout for v in (q["zb"], q["z0"], q["z1"], q["zt"])})
    zs = _graded(zb_, [w for q in layout for w in ((q["zb"], q["z0"]), (q["z1"], q["zt"]))],
                 edge, n)
    starts = [0.0]
    ys = [np.array([0.0])]
    for module in mods:
        cell, y0 = module.cell, starts[-1]
        br = [y0]
        for k in range(module.n_cells):
            br += [y0 + k * cell.d + cell.df, y0 + (k + 1) * cell.d - cell.df,
                   y0 + (k + 1) * cell.d]
        walls = {i for i in range(len(br) - 1) if i % 3 != 1}
        ys.append(graded_axis(br, density.edge(cell), n, walls)[1:])
        starts.append(br[-1])
    y_at = np.array(starts)

    def module_of(cen: np.ndarray) -> np.ndarray:
        return np.clip(np.searchsorted(y_at, cen[:, 1]) - 1, 0, len(mods) - 1)

    def solid(cen: np.ndarray) -> np.ndarray:
        mod = module_of(cen)

        def per(key: str) -> np.ndarray:
            return np.array([q[key] for q in layout])[mod]

        d = np.array([module.cell.d for module in mods])[mod]
        df = np.array([module.cell.df for module in mods])[mod]
        dx = np.abs(cen[:, 0] - W / 2)
        yl = np.mod(cen[:, 1] - y_at[mod], d)
        in_box = (dx < W / 2 - per("x0")) & (cen[:, 2] > per("zb")) & (cen[:, 2] < per("zt"))
        chamber = ((dx < W / 2 - per("xc")) & (yl > df) & (yl < d - df)
                   & (cen[:, 2] > per("z0")) & (cen[:, 2] < per("z1")))
        return in_box & ~chamber

    pts, cells, cen = carve(xs, np.concatenate(ys), zs, solid)
    mod = module_of(cen)
    bot = np.array([q["bot"] for q in layout])[mod]
    region = np.where((cen[:, 2] > bot[:, 0]) & (cen[:, 2] < bot[:, 1]), BOTTOM,
                      WALL).astype(np.int8)
    materials: list[Material] = []
    for module in mods:
        for mat in (module.cell.material, module.cell.bottom_material):
            if mat not in materials:
                materials.append(mat)
    mat_of = np.array([[materials.index(module.cell.material),
                        materials.index(module.cell.bottom_material)] for module in mods])
    material = mat_of[mod, region].astype(np.int16)

    tol = 1e-9 * max(W, H, starts[-1])
    px, py, pz = pts.T
    chamber_points, faces, face_cell = chamber_surface(
        pts, cells, [((q["xc"], y0 + k * module.cell.d + module.cell.df, q["z0"]),
                      (W - q["xc"], y0 + (k + 1) * module.cell.d - module.cell.df, q["z1"]))
                     for module, q, y0 in zip(mods, layout, starts, strict=False)
                     for k in range(module.n_cells)], tol)
    face_module = mod[face_cell]

    def section(y: float, q: dict[str, float]) -> np.ndarray:
        return np.flatnonzero((np.abs(py - y) < tol) & (px > q["x0"] - tol)
                              & (px < W - q["x0"] + tol) & (pz > q["zb"] - tol)
                              & (pz < q["zt"] + tol))

    return DeviceMesh(
        points=pts, cells=cells, region=region, module=mod.astype(np.int16), material=material,
        chamber_points=chamber_points, chamber_faces=faces, face_module=face_module,
        clamped=np.abs(py) < tol,
        mirror=(np.abs(px - W / 2) < tol) if half else np.zeros(len(pts), dtype=bool),
        start_sections=tuple(section(starts[i], q) for i, q in enumerate(layout)),
        end_sections=tuple(section(starts[i + 1], q) for i, q in enumerate(layout)),
        starts=y_at, modules=mods, materials=tuple(materials), width=W, height=H, half=half,
        density=density)


_PIECE_KEYS = ("points", "cells", "region", "module", "materials", "material", "chamber_points",
               "chamber_faces", "face_module", "clamped", "starts", "start_sections",
               "end_sections", "width", "height")


def _piece_mesh(piece: Placement, density: MeshDensity) -> dict[str, Any]:
    """A piece's own mesh as the arrays the device mesh gathers (local frame)."""
    if piece.twisting:
        twist = twisting_module_mesh(piece.modules[0], density)
        return {"points": twist.points, "cells": twist.cells, "region": twist.region,
                "module": np.zeros(len(twist.cells), dtype=np.int16),
                "materials": twist.materials, "material": twist.material,
                "chamber_points": twist.chamber_points, "chamber_faces": twist.chamber_faces,
                "face_module": np.zeros(len(twist.chamber_faces), dtype=np.int16),
                "clamped": twist.clamped, "starts": np.array([0.0, twist.length]),
                "start_sections": (np.flatnonzero(twist.clamped),),
                "end_sections": (twist.end_section,), "width": 0.0, "height": 0.0}
    grid = _series_mesh(grid_modules(piece.modules), density, half=False)
    return {key: getattr(grid, key) for key in _PIECE_KEYS}


def _branched_mesh(branches: tuple[FEBranch, ...], density: MeshDensity) -> DeviceMesh:
    """Meshes of every piece (grids and twisting modules), placed in the mesh frame and
    joined by rigid hubs."""
    parts: dict[str, list[np.ndarray]] = {key: [] for key in (
        "points", "cells", "region", "material", "module", "chamber_points", "chamber_faces",
        "face_module", "clamped")}
    starts_s: list[np.ndarray] = []
    ends_s: list[np.ndarray] = []
    entries: list[Module] = []
    frames: list[tuple[np.ndarray, np.ndarray]] = []
    source: list[str] = []
    materials: list[Material] = []
    entry_of: dict[tuple[str, int], int] = {}
    children: dict[tuple[str, int], list[int]] = {}
    offset = 0
    main: dict[str, Any] | None = None
    tip = 0
    for piece in placements(branches):
        grid = _piece_mesh(piece, density)
        if main is None:
            main = grid
        P = piece.origin + (grid["points"] - piece.centre) @ piece.Q.T
        e0 = len(entries)
        mat = np.array([_index(materials, material) for material in grid["materials"]],
                       dtype=np.int16)
        for key, val in (("points", P), ("cells", grid["cells"] + offset),
                         ("region", grid["region"]), ("material", mat[grid["material"]]),
                         ("module", grid["module"] + e0),
                         ("chamber_points", grid["chamber_points"]),
                         ("chamber_faces", grid["chamber_faces"] + offset),
                         ("face_module", grid["face_module"] + e0),
                         ("clamped", grid["clamped"] if piece.parent is None
                          else np.zeros(len(P), dtype=bool))):
            parts[key].append(val)
        for i, module in enumerate(piece.modules):
            name = module.name if piece.branch.count == 1 else f"{module.name}#{piece.copy}"
            entries.append(replace(module, name=name))
            source.append(module.name)
            frames.append((piece.origin
                           + piece.Q @ np.array([0.0, float(grid["starts"][i]), 0.0]),
                           piece.Q.copy()))
            starts_s.append(grid["start_sections"][i] + offset)
            ends_s.append(grid["end_sections"][i] + offset)
            entry_of[(module.name, piece.copy)] = e0 + i
        if piece.parent is not None:
            children.setdefault(piece.parent, []).append(e0)
        if piece.branch.parent is None:
            tip = len(entries) - 1
        offset += len(P)
    assert main is not None
    hubs = []
    extra = []
    for key, kids in children.items():
        parent = entry_of[key]
        tied = np.unique(np.concatenate([ends_s[parent], *(starts_s[c] for c in kids)]))
        at = frames[parent][0] + frames[parent][1] @ np.array(
            [0.0, entries[parent].length, 0.0])
        center, rotation = offset + len(extra), offset + len(extra) + 1
        extra += [at, at]
        hubs.append(Hub(tied, center, rotation, parent, tuple(kids)))
    points = np.concatenate([*parts["points"], np.array(extra).reshape(-1, 3)])
    pad = np.zeros(len(extra), dtype=bool)
    main_mods = branches[0].modules
    return DeviceMesh(
        points=points, cells=np.concatenate(parts["cells"]),
        region=np.concatenate(parts["region"]).astype(np.int8),
        module=np.concatenate(parts["module"]).astype(np.int16),
        material=np.concatenate(parts["material"]).astype(np.int16),
        chamber_points=np.concatenate([*parts["chamber_points"], pad]),
        chamber_faces=np.concatenate(parts["chamber_faces"]),
        face_module=np.concatenate(parts["face_module"]).astype(np.int16),
        clamped=np.concatenate([*parts["clamped"], pad]),
        mirror=np.zeros(len(points), dtype=bool),
        start_sections=tuple(starts_s), end_sections=tuple(ends_s),
        starts=np.concatenate([[0.0], np.cumsum([module.length for module in main_mods])]),
        modules=tuple(entries), materials=tuple(materials), width=float(main["width"]),
        height=float(main["height"]), half=False, density=density, frames=tuple(frames),
        hubs=tuple(hubs), source=tuple(source), tip_entry=tip)


def _index(items: list[Material], item: Material) -> int:
    """Index of ``item`` in ``items`` (appended if new)."""
    if item not in items:
        items.append(item)
    return items.index(item)
