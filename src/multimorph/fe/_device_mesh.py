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

__all__ = ["FE_DEVICE_KINDS", "FE_MODULE_KINDS", "DeviceMesh", "FEBranch", "Hub", "device_mesh",
           "device_pieces", "fe_device_branches", "fe_device_modules"]


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
    for m in device.modules:
        if m.kind not in FE_DEVICE_KINDS:
            raise SpecError(f"module {m.name!r}.kind: {m.kind!r} is not supported by FE; "
                            f"{_SUPPORTED}")
    out: list[FEBranch] = []
    for name, mods in device.branches().items():
        parent = next((m.attach_to for m in mods if m.attach_to is not None), None)
        for a, b in itertools.pairwise(mods):
            if abs(b.start - a.end) > 1e-9 * max(a.end, 1e-3):
                raise SpecError(f"module {b.name!r}.start: starts at {b.start * 1e3:.4g} mm, "
                                f"not where {a.name!r} ends ({a.end * 1e3:.4g} mm); {_SUPPORTED}")
        counts = {m.count for m in mods}
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
    placed = {m.name for m in roots[0].modules}
    rest = [b for b in out if b.parent is not None]
    while rest:  # Device validation rules out cycles
        ready = [b for b in rest if b.parent in placed]
        ordered += ready
        placed |= {m.name for b in ready for m in b.modules}
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
    for m in branches[0].modules:
        if m.kind not in FE_MODULE_KINDS:
            raise SpecError(f"module {m.name!r}.kind: {m.kind!r}; one grid holds a series of "
                            f"{' and '.join(FE_MODULE_KINDS)} modules")
        if not _in_grid(m):
            raise SpecError(f"module {m.name!r}.orientation: "
                            f"{math.degrees(m.orientation):.4g} deg; one grid holds modules "
                            f"at 0 or 180 deg")
    return branches[0].modules


def _flipped(m: Module) -> bool:
    return abs(math.remainder(m.orientation, 2.0 * math.pi)) > 1e-9


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
    frames: tuple[tuple[np.ndarray, np.ndarray], ...] = ()
    hubs: tuple[Hub, ...] = ()
    source: tuple[str, ...] = ()
    tip_entry: int = -1

    def __post_init__(self) -> None:
        k = len(self.modules)
        if not self.frames:
            eye = np.eye(3)
            object.__setattr__(self, "frames", tuple(
                (np.array([self.width / 2, float(self.starts[i]), self.height / 2]), eye)
                for i in range(k)))
        if not self.source:
            object.__setattr__(self, "source", tuple(m.name for m in self.modules))
        if self.tip_entry < 0:
            object.__setattr__(self, "tip_entry", k - 1)

    @property
    def length(self) -> float:
        """Length of the clamped branch along y (m)."""
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


def _boxes(mods: tuple[Module, ...]) -> tuple[list[tuple[float, ...]], list[tuple[float, ...]]]:
    """Outer and chamber boxes ``(x, y, z, dx, dy, dz)`` of one series branch in its grid's
    frame (axis x = W/2, z = H/2, from y = 0)."""
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


def _rot_y(angle: float) -> np.ndarray:
    """Rotation by ``angle`` about y (the reduced model's placement of parallel copies)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _in_grid(m: Module) -> bool:
    """Whether ``m`` can share a series grid: a bending or stretching module whose bending
    plane is a grid plane (orientation 0° or 180°)."""
    return (m.kind in FE_MODULE_KINDS
            and abs(math.remainder(m.orientation, math.pi)) <= 1e-9)


def _segments(mods: tuple[Module, ...]) -> list[tuple[Module, ...]]:
    """A branch cut into meshable pieces: runs of bending and stretching modules at 0° or
    180° (one grid each) and single modules otherwise (a twisting module's strips on a
    shaft, or the grid of a module turned by another angle, placed turned)."""
    out: list[tuple[Module, ...]] = []
    for m in mods:
        if _in_grid(m) and out and _in_grid(out[-1][-1]):
            out[-1] = (*out[-1], m)
        else:
            out.append((m,))
    return out


def _turned(seg: tuple[Module, ...]) -> bool:
    """A one-module piece that is placed turned by its orientation (its own grid unturned)."""
    return not _in_grid(seg[0])


def _grid_modules(seg: tuple[Module, ...]) -> tuple[Module, ...]:
    """The modules a piece's grid is built from: a turned piece's module unturned (the
    placement turns it)."""
    return tuple(replace(m, orientation=0.0) for m in seg) if _turned(seg) else seg


@dataclass(frozen=True)
class _Placement:
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
    W, H, _ = _layout(seg)
    return np.array([W / 2, 0.0, H / 2])


def _placements(branches: tuple[FEBranch, ...]) -> list[_Placement]:
    """Every piece placed as the reduced model places it. The clamped branch's first piece
    is the mesh frame; pieces of a branch follow each other along its axis; copy j of an
    attached branch starts at its parent's end section, turned by 2πj/count about the
    parent's axis and moved ``radius`` along the turned z; a module that is a piece of its
    own (twisting, or bending at an angle other than 0° or 180°) is turned by its
    ``orientation`` about its own axis."""
    out: list[_Placement] = []
    end: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    axis0 = _centre(_segments(branches[0].modules)[0])
    for br in branches:
        for j in range(br.count):
            if br.parent is None:
                origin, Q = axis0.copy(), np.eye(3)
            else:
                o, R = end[br.parent]
                Q = R @ _rot_y(2.0 * math.pi * j / br.count)
                origin = o + Q @ np.array([0.0, 0.0, br.radius])
            parent = None if br.parent is None else (br.parent, 0)
            for seg in _segments(br.modules):
                Qp = Q @ _rot_y(seg[0].orientation) if _turned(seg) else Q
                out.append(_Placement(br, j, seg, origin.copy(), Qp, _centre(seg), parent))
                y = 0.0
                for m in seg:
                    y += m.length
                    if j == 0:
                        end[m.name] = (origin + Q @ np.array([0.0, y, 0.0]), Q)
                origin = origin + Q @ np.array([0.0, y, 0.0])
                parent = (seg[-1].name, j)
    return out


def _affine(pl: _Placement) -> list[float]:
    """Row-major 3 × 4 map of a placement (local grid frame → mesh frame, m)."""
    t = pl.origin - pl.Q @ pl.centre
    return [*pl.Q[0], t[0], *pl.Q[1], t[1], *pl.Q[2], t[2]]


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
    return [(*_boxes(_grid_modules(pl.modules)), _affine(pl))
            for pl in _placements(fe_device_branches(device)) if not pl.twisting]


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
    dens = resolve_density(mesh, element_size)
    if len(branches) == 1 and all(_in_grid(m) for m in branches[0].modules):
        return _series_mesh(branches[0].modules, dens, half)
    return _branched_mesh(branches, dens)


def _series_mesh(mods: tuple[Module, ...], dens: MeshDensity, half: bool) -> DeviceMesh:
    """One structured grid of modules in series (see :func:`device_mesh`)."""
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


def _piece_mesh(pl: _Placement, dens: MeshDensity) -> dict[str, Any]:
    """A piece's own mesh as the arrays the device mesh gathers (local frame)."""
    if pl.twisting:
        from multimorph.fe._twist_mesh import twisting_module_mesh

        tm = twisting_module_mesh(pl.modules[0], dens)
        return {"points": tm.points, "cells": tm.cells, "region": tm.region,
                "module": np.zeros(len(tm.cells), dtype=np.int16),
                "materials": tm.materials, "material": tm.material,
                "chamber_points": tm.chamber_points, "chamber_faces": tm.chamber_faces,
                "face_module": np.zeros(len(tm.chamber_faces), dtype=np.int16),
                "clamped": tm.clamped, "starts": np.array([0.0, tm.length]),
                "start_sections": (np.flatnonzero(tm.clamped),),
                "end_sections": (tm.end_section,), "width": 0.0, "height": 0.0}
    g = _series_mesh(_grid_modules(pl.modules), dens, half=False)
    return {k: getattr(g, k) for k in (
        "points", "cells", "region", "module", "materials", "material", "chamber_points",
        "chamber_faces", "face_module", "clamped", "starts", "start_sections", "end_sections",
        "width", "height")}


def _branched_mesh(branches: tuple[FEBranch, ...], dens: MeshDensity) -> DeviceMesh:
    """Meshes of every piece (grids and twisting modules), placed in the mesh frame and
    joined by rigid hubs."""
    parts: dict[str, list[np.ndarray]] = {k: [] for k in (
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
    for pl in _placements(branches):
        g = _piece_mesh(pl, dens)
        if main is None:
            main = g
        P = pl.origin + (g["points"] - pl.centre) @ pl.Q.T
        e0 = len(entries)
        mat = np.array([_index(materials, m) for m in g["materials"]], dtype=np.int16)
        for key, val in (("points", P), ("cells", g["cells"] + offset),
                         ("region", g["region"]), ("material", mat[g["material"]]),
                         ("module", g["module"] + e0),
                         ("chamber_points", g["chamber_points"]),
                         ("chamber_faces", g["chamber_faces"] + offset),
                         ("face_module", g["face_module"] + e0),
                         ("clamped", g["clamped"] if pl.parent is None
                          else np.zeros(len(P), dtype=bool))):
            parts[key].append(val)
        for i, m in enumerate(pl.modules):
            name = m.name if pl.branch.count == 1 else f"{m.name}#{pl.copy}"
            entries.append(replace(m, name=name))
            source.append(m.name)
            frames.append((pl.origin + pl.Q @ np.array([0.0, float(g["starts"][i]), 0.0]),
                           pl.Q.copy()))
            starts_s.append(g["start_sections"][i] + offset)
            ends_s.append(g["end_sections"][i] + offset)
            entry_of[(m.name, pl.copy)] = e0 + i
        if pl.parent is not None:
            children.setdefault(pl.parent, []).append(e0)
        if pl.branch.parent is None:
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
        starts=np.concatenate([[0.0], np.cumsum([m.length for m in main_mods])]),
        modules=tuple(entries), materials=tuple(materials), width=float(main["width"]),
        height=float(main["height"]), half=False, density=dens, frames=tuple(frames),
        hubs=tuple(hubs), source=tuple(source), tip_entry=tip)


def _index(items: list[Material], item: Material) -> int:
    """Index of ``item`` in ``items`` (appended if new)."""
    if item not in items:
        items.append(item)
    return items.index(item)
