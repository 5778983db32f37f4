"""The structured hexahedral mesh of a device: modules in series, one pressure line.

One grid holds the whole device. Every module's cross-section is centred on the common axis
(x = W/2, z = H/2, with W × H the largest box); the grid is cut at every module's wall planes
(x and z: the union over modules, z mirrored within the section for a module turned by
180°), and along y each module's cells follow each other from the clamped face y = 0, as in
:func:`~multimorph.fe.cell_mesh`. A grid cell is kept when it lies inside its module's box
and outside its chambers; neighbouring modules' end walls merge into one partition, like
adjacent cells of a module. Every chamber is on the one pressure line.
:func:`fe_device_modules` says which devices the grid can hold.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from multimorph.device import Device, Module
from multimorph.errors import SpecError
from multimorph.fe._mesh import (
    _HEX_FACES,
    BOTTOM,
    WALL,
    MeshDensity,
    _axis,
    _chamber_faces,
    _compact,
    resolve_density,
)
from multimorph.materials import Material

__all__ = ["FE_MODULE_KINDS", "DeviceMesh", "device_boxes", "device_mesh", "fe_device_modules"]


#: Module kinds that the structured device mesh can hold.
FE_MODULE_KINDS = ("bending", "stretching")

_SUPPORTED = ("FE devices support one series branch of bending and stretching modules "
              "(count = 1, orientation 0 or 180 deg, each starting where the previous ends)")


def fe_device_modules(device: Device) -> tuple[Module, ...]:
    """The device's modules in order along its one branch, checked for FE.

    Raises
    ------
    SpecError
        Naming the module and field for anything the structured mesh cannot hold: twisting
        modules, parallel branches (``attach_to``, a second branch), ``count`` > 1, an
        orientation other than 0° or 180°, or a gap between modules.
    """
    branches = device.branches()
    for m in device.modules:
        where = f"module {m.name!r}"
        if m.kind not in FE_MODULE_KINDS:
            raise SpecError(f"{where}.kind: {m.kind!r} is not supported by FE; {_SUPPORTED}")
        if m.attach_to is not None:
            raise SpecError(f"{where}.attach_to: parallel branches are not supported by FE; "
                            f"{_SUPPORTED}")
        if m.count != 1:
            raise SpecError(f"{where}.count: {m.count} copies are not supported by FE; "
                            f"{_SUPPORTED}")
        turn = math.remainder(m.orientation, math.pi)
        if abs(turn) > 1e-9:
            raise SpecError(f"{where}.orientation: {math.degrees(m.orientation):.4g} deg is not "
                            f"supported by FE; {_SUPPORTED}")
    if len(branches) != 1:
        names = ", ".join(sorted(branches))
        raise SpecError(f"module branch: the device has {len(branches)} branches ({names}); "
                        f"{_SUPPORTED}")
    mods = tuple(next(iter(branches.values())))
    for a, b in itertools.pairwise(mods):
        if abs(b.start - a.end) > 1e-9 * max(a.end, 1e-3):
            raise SpecError(f"module {b.name!r}.start: starts at {b.start * 1e3:.4g} mm, not "
                            f"where {a.name!r} ends ({a.end * 1e3:.4g} mm); {_SUPPORTED}")
    return mods


def _flipped(m: Module) -> bool:
    return abs(math.remainder(m.orientation, 2.0 * math.pi)) > 1e-9


@dataclass(frozen=True, eq=False)
class DeviceMesh:
    """A hexahedral mesh of a device with its tags (m, reference configuration).

    Attributes
    ----------
    points : ndarray (n, 3)
    cells : ndarray (m, 8)
        VTK hexahedron connectivity.
    region : ndarray (m,)
        0 for wall elastomer, 1 for a module's bottom (strain-limiting) layer.
    module : ndarray (m,)
        Index of the element's module in ``modules``.
    material : ndarray (m,)
        Index of the element's material in ``materials``.
    chamber_points : ndarray (n,) of bool
        Nodes on a chamber surface (the pressure boundary).
    chamber_faces : ndarray (k, 4)
        Chamber faces, normals out of the chamber.
    face_module : ndarray (k,)
        Module of each chamber face.
    clamped, mirror : ndarray (n,) of bool
        Nodes on the mounting face y = 0 and on the mirror plane x = W/2 (half model).
    start_sections, end_sections : tuple of ndarray
        Per module, the nodes of its start and end cross-section (inside its own box).
    starts : ndarray (k + 1,)
        y of every module's start and of the free end (m).
    modules : tuple of Module
    materials : tuple of Material
        Distinct materials, in order of first use (module wall, then bottom layer).
    width, height : float
        The largest box W × H (m); sections are centred on x = W/2, z = H/2.
    half : bool
    density : MeshDensity
    """

    points: np.ndarray
    cells: np.ndarray
    region: np.ndarray
    module: np.ndarray
    material: np.ndarray
    chamber_points: np.ndarray
    chamber_faces: np.ndarray
    face_module: np.ndarray
    clamped: np.ndarray
    mirror: np.ndarray
    start_sections: tuple[np.ndarray, ...]
    end_sections: tuple[np.ndarray, ...]
    starts: np.ndarray
    modules: tuple[Module, ...]
    materials: tuple[Material, ...]
    width: float
    height: float
    half: bool
    density: MeshDensity = field(default_factory=MeshDensity)

    @property
    def length(self) -> float:
        """Device length along y (m)."""
        return float(self.starts[-1])

    @property
    def ndof(self) -> int:
        return 3 * len(self.points)

    @property
    def ncells(self) -> int:
        return len(self.cells)


def _graded(breaks: list[float], walls: list[tuple[float, float]], edge: float, n: int,
            ) -> np.ndarray:
    """Coordinates through sorted breaks; an interval inside a wall of thickness t gets at
    least ⌈n · length / t⌉ elements, so every wall of every module has ≥ n through it."""
    scale = max(abs(breaks[0]), abs(breaks[-1]), 1e-3)
    tol = 1e-9 * scale
    pts = [breaks[0]]
    for b in breaks[1:]:
        if b - pts[-1] > tol:
            pts.append(b)
    out = [np.array([pts[0]])]
    for a, b in itertools.pairwise(pts):
        k = 1
        for lo, hi in walls:
            if a >= lo - tol and b <= hi + tol:
                k = max(k, math.ceil(n * (b - a) / (hi - lo) - 1e-9))
        out.append(_axis([a, b], edge, k, {0})[1:])
    return np.concatenate(out)


def _layout(mods: tuple[Module, ...]) -> tuple[float, float, list[dict[str, Any]]]:
    """Common box W × H and, per module, its outer box, chamber box and bottom layer in
    global x, z (every cross-section centred on the axis x = W/2, z = H/2; a module turned
    by 180° has its stiff layer on top)."""
    W = max(m.cell.width for m in mods)
    H = max(m.cell.height for m in mods)
    geo = []
    for m in mods:
        g = m.cell
        zb = H / 2 - g.height / 2
        lower = g.ht if _flipped(m) else g.hb
        z0 = zb + lower
        geo.append({"x0": W / 2 - g.width / 2, "zb": zb, "zt": zb + g.height, "z0": z0,
                    "z1": z0 + g.hc, "xc": W / 2 - g.width / 2 + g.ws,
                    "bot": (zb + g.height - g.hb, zb + g.height) if _flipped(m)
                    else (zb, zb + g.hb)})
    return W, H, geo


def device_boxes(device: Device) -> tuple[list[tuple[float, ...]], list[tuple[float, ...]]]:
    """The device solid as boxes (m, the FE mesh's frame: y along the axis from the
    clamped end): one outer box per module and one box per chamber, each
    ``(x, y, z, dx, dy, dz)``. The solid is the union of the outer boxes minus the
    chambers."""
    mods = fe_device_modules(device)
    W, _, geo = _layout(mods)
    outer, inner = [], []
    y0 = 0.0
    for m, q in zip(mods, geo, strict=True):
        g = m.cell
        outer.append((q["x0"], y0, q["zb"], W - 2 * q["x0"], m.n_cells * g.d,
                      q["zt"] - q["zb"]))
        for k in range(m.n_cells):
            inner.append((q["xc"], y0 + k * g.d + g.df, q["z0"], W - 2 * q["xc"],
                          g.d - 2 * g.df, q["z1"] - q["z0"]))
        y0 += m.n_cells * g.d
    return outer, inner


def device_mesh(device: Device, mesh: str | MeshDensity = "coarse", *,
                element_size: float | None = None, half: bool = True) -> DeviceMesh:
    """Mesh a device's modules in series with one structured hexahedral grid.

    Parameters
    ----------
    device : Device
        One series branch of bending and stretching modules (see :func:`fe_device_modules`).
    mesh : {"coarse", "medium", "fine"} or MeshDensity
        Density; the in-plane edge along y is each module's own (a fraction of its cell
        length), across (x, z) the smallest over the modules.
    element_size : float, optional
        Explicit target edge length (m).
    half : bool
        Mesh only x ≤ W/2 (every module is mirror-symmetric about the common plane).

    Returns
    -------
    DeviceMesh
    """
    mods = fe_device_modules(device)
    dens = resolve_density(mesh, element_size)
    n = dens.wall_elements
    W, H, geo = _layout(mods)
    edge = min(dens.edge(m.cell) for m in mods)
    xb = sorted({v for q in geo for v in (q["x0"], q["xc"])} | {W / 2})
    xh = _graded(xb, [(q["x0"], q["xc"]) for q in geo], edge, n)
    xs = xh if half else np.concatenate([xh, (W - xh[::-1])[1:]])
    zb_ = sorted({v for q in geo for v in (q["zb"], q["z0"], q["z1"], q["zt"])})
    zs = _graded(zb_, [w for q in geo for w in ((q["zb"], q["z0"]), (q["z1"], q["zt"]))],
                 edge, n)
    starts = [0.0]
    ys = [np.array([0.0])]
    for m in mods:
        g, y0 = m.cell, starts[-1]
        br = [y0]
        for k in range(m.n_cells):
            br += [y0 + k * g.d + g.df, y0 + (k + 1) * g.d - g.df, y0 + (k + 1) * g.d]
        walls = {i for i in range(len(br) - 1) if i % 3 != 1}
        ys.append(_axis(br, dens.edge(g), n, walls)[1:])
        starts.append(br[-1])
    ys = np.concatenate(ys)
    y_at = np.array(starts)

    X, Y, Z = np.meshgrid(xs, ys, zs, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    nx, ny, nz = len(xs), len(ys), len(zs)
    idx = np.arange(nx * ny * nz).reshape(nx, ny, nz)
    a = idx[:-1, :-1, :-1].ravel()
    b = idx[1:, :-1, :-1].ravel()
    c = idx[1:, 1:, :-1].ravel()
    e = idx[:-1, 1:, :-1].ravel()
    cells = np.column_stack([a, b, c, e, a + 1, b + 1, c + 1, e + 1])
    cen = pts[cells].mean(axis=1)
    mod = np.clip(np.searchsorted(y_at, cen[:, 1]) - 1, 0, len(mods) - 1)

    def per(key: str) -> np.ndarray:
        return np.array([q[key] for q in geo])[mod]

    d = np.array([m.cell.d for m in mods])[mod]
    df = np.array([m.cell.df for m in mods])[mod]
    dx = np.abs(cen[:, 0] - W / 2)
    yl = np.mod(cen[:, 1] - y_at[mod], d)
    in_box = (dx < W / 2 - per("x0")) & (cen[:, 2] > per("zb")) & (cen[:, 2] < per("zt"))
    chamber = ((dx < W / 2 - per("xc")) & (yl > df) & (yl < d - df)
               & (cen[:, 2] > per("z0")) & (cen[:, 2] < per("z1")))
    keep = in_box & ~chamber
    cells, cen, mod = cells[keep], cen[keep], mod[keep]
    pts, cells = _compact(pts, cells)
    bot = np.array([q["bot"] for q in geo])[mod]
    region = np.where((cen[:, 2] > bot[:, 0]) & (cen[:, 2] < bot[:, 1]), BOTTOM,
                      WALL).astype(np.int8)
    materials: list[Material] = []
    for m in mods:
        for mat in (m.cell.material, m.cell.bottom_material):
            if mat not in materials:
                materials.append(mat)
    mat_of = np.array([[materials.index(m.cell.material),
                        materials.index(m.cell.bottom_material)] for m in mods])
    material = mat_of[mod, region].astype(np.int16)

    tol = 1e-9 * max(W, H, starts[-1])
    px, py, pz = pts.T
    chamber_points = np.zeros(len(pts), dtype=bool)
    for m, q, y0 in zip(mods, geo, starts, strict=False):
        g = m.cell
        for k in range(m.n_cells):
            lo = (q["xc"], y0 + k * g.d + g.df, q["z0"])
            hi = (W - q["xc"], y0 + (k + 1) * g.d - g.df, q["z1"])
            inside = np.ones(len(pts), dtype=bool)
            on_plane = np.zeros(len(pts), dtype=bool)
            for p_, l_, h_ in zip((px, py, pz), lo, hi, strict=True):
                inside &= (p_ > l_ - tol) & (p_ < h_ + tol)
                on_plane |= (np.abs(p_ - l_) < tol) | (np.abs(p_ - h_) < tol)
            chamber_points |= inside & on_plane
    ch, on = _chamber_faces(cells, chamber_points)
    face_module = np.repeat(mod, len(_HEX_FACES))[on]

    def section(y: float, q: dict[str, float]) -> np.ndarray:
        return np.flatnonzero((np.abs(py - y) < tol) & (px > q["x0"] - tol)
                              & (px < W - q["x0"] + tol) & (pz > q["zb"] - tol)
                              & (pz < q["zt"] + tol))

    return DeviceMesh(
        points=pts, cells=cells, region=region, module=mod.astype(np.int16), material=material,
        chamber_points=chamber_points, chamber_faces=ch, face_module=face_module,
        clamped=np.abs(py) < tol,
        mirror=(np.abs(px - W / 2) < tol) if half else np.zeros(len(pts), dtype=bool),
        start_sections=tuple(section(starts[i], q) for i, q in enumerate(geo)),
        end_sections=tuple(section(starts[i + 1], q) for i, q in enumerate(geo)),
        starts=y_at, modules=mods, materials=tuple(materials), width=W, height=H, half=half,
        density=dens)
