"""Structured hexahedral mesh of a unit cell (graded grid, chamber removed, regions tagged).

The cell box [0, w] × [0, d] × [0, h] (x across, y along, z up) is cut by the planes of the
chamber walls, each interval is divided uniformly, the cells inside the chamber are deleted
and the unused nodes dropped. Every wall face lies on grid lines, so the chamber surface is
made of whole quad faces (FElupe's pressure boundary needs hex/quad faces). By default only
the half x ≤ w/2 is meshed (mirror plane x = w/2).

A tilted cell (the twisting module's chambers, at an angle β to the strip axis) is the straight
mesh sheared in the strip plane, y' = y + (x − w/2) tan β: the partitions turn by β, the side
walls stay parallel to the strip axis y. The shear keeps every tag, every volume and the
element quality's sign (its determinant is 1).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from multimorph.errors import SpecError
from multimorph.geometry import CellGeometry

__all__ = ["MAX_TILT", "MESH_PRESETS", "CellMesh", "MeshDensity", "cell_mesh", "resolve_density"]

WALL, BOTTOM = 0, 1
#: names of the element regions by tag (twisting modules add 2, the shaft)
REGION_NAMES = ("wall", "bottom layer", "shaft")
"""Region tags: wall elastomer (top, side and end walls) and the stiff bottom layer."""

MAX_TILT = math.radians(80.0)
"""Largest chamber tilt |β| (rad) a cell mesh accepts (tan β grows without bound at 90°)."""


@dataclass(frozen=True)
class MeshDensity:
    """How finely to divide a cell.

    Parameters
    ----------
    wall_elements : int
        Elements through the thickness of every wall (≥ 1).
    size : float or None
        Target element edge length (m); ``None`` uses ``length_fraction``.
    length_fraction : float
        Target edge length as a fraction of the cell length d (used when ``size`` is None).
    """

    wall_elements: int = 2
    size: float | None = None
    length_fraction: float = 0.1

    def edge(self, geometry: CellGeometry) -> float:
        return self.size if self.size is not None else self.length_fraction * geometry.length


#: Named densities. At the reference cell (d 20, w 10, h 8, walls 1–2 mm) the half model has
#: about 1.6k (coarse), 4.7k (medium) and 11k (fine) displacement DOF.
MESH_PRESETS: dict[str, MeshDensity] = {
    "coarse": MeshDensity(wall_elements=2, length_fraction=1 / 10),
    "medium": MeshDensity(wall_elements=3, length_fraction=1 / 16),
    "fine": MeshDensity(wall_elements=4, length_fraction=1 / 24),
}


def resolve_density(mesh: str | MeshDensity = "coarse", element_size: float | None = None,
                    ) -> MeshDensity:
    """A :class:`MeshDensity` from a preset name and/or an explicit element size (m).

    An explicit size keeps at least two elements through each wall.
    """
    if isinstance(mesh, MeshDensity):
        base = mesh
    else:
        try:
            base = MESH_PRESETS[str(mesh).lower()]
        except KeyError:
            raise SpecError(f"mesh: unknown preset {mesh!r}; expected one of "
                            f"{', '.join(MESH_PRESETS)}") from None
    if element_size is not None:
        if not (math.isfinite(element_size) and element_size > 0):
            raise SpecError(f"element_size: must be a positive length, got {element_size!r}")
        return MeshDensity(wall_elements=max(2, base.wall_elements), size=float(element_size))
    return base


@dataclass(frozen=True, eq=False)
class CellMesh:
    """A hexahedral cell mesh with its tags (all coordinates in m, reference configuration).

    Attributes
    ----------
    points : ndarray (n, 3)
    cells : ndarray (m, 8)
        VTK hexahedron connectivity.
    region : ndarray (m,)
        0 for wall elastomer, 1 for the bottom layer.
    chamber_points : ndarray (n,) of bool
        Nodes on the chamber surface (pressure boundary).
    chamber_faces : ndarray (k, 4)
        Chamber faces, ordered so that their normal points out of the chamber.
    clamped : ndarray (n,) of bool
        Nodes on the mounting face y = 0 (a tilted mesh: the sheared plane
        y = (x − w/2) tan β).
    mirror : ndarray (n,) of bool
        Nodes on the mirror plane x = w/2 (all False for a full model).
    bend_line : ndarray (j,)
        Nodes of the outer bottom edge (x = 0, z = 0), ordered by y: the material line whose
        circle fit gives the bending curvature (the bottom-centre line x = w/2 would also
        carry the local downward bulge of the chamber floor).
    end_face : ndarray (i,)
        Nodes of the free end face y = n_cells · d (sheared like the clamp when tilted).
    half : bool
        Whether only x ≤ w/2 is meshed.
    geometry : CellGeometry
    n_cells : int
        Cells in series along y (the meshed length is ``n_cells · d``).
    tilt : float
        Chamber tilt β (rad) of a sheared mesh; 0 for a straight one.
    """

    points: np.ndarray
    cells: np.ndarray
    region: np.ndarray
    chamber_points: np.ndarray
    chamber_faces: np.ndarray
    clamped: np.ndarray
    mirror: np.ndarray
    bend_line: np.ndarray
    end_face: np.ndarray
    half: bool
    geometry: CellGeometry
    density: MeshDensity = field(default_factory=MeshDensity)
    n_cells: int = 1
    tilt: float = 0.0

    @property
    def length(self) -> float:
        """Meshed length along y (m): ``n_cells · d``."""
        return self.n_cells * self.geometry.length

    @property
    def ndof(self) -> int:
        """Displacement degrees of freedom before constraints."""
        return 3 * len(self.points)

    @property
    def ncells(self) -> int:
        return len(self.cells)

    def unsheared(self) -> np.ndarray:
        """Node coordinates before the tilt shear (m): y − (x − w/2) tan β; the mesh's own
        points when it is straight."""
        pts = self.points.copy()
        pts[:, 1] -= (pts[:, 0] - 0.5 * self.geometry.width) * math.tan(self.tilt)
        return pts

    def sections(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """The material cross-sections between cells: (nodes, weights) for k = 0 … n_cells.

        Section k is the plane y = k d of the unsheared mesh (the clamp, the mid-planes of
        the partitions, the free end), which a tilted mesh shears into a plane parallel to
        its partitions. A node's weight is its share of the section's reference area (a
        quarter of every quad face of the plane it touches), so weighted means of a bilinear
        field over a section are exact.
        """
        y = self.unsheared()[:, 1]
        d = self.geometry.length
        tol = 1e-9 * max(self.geometry.width, self.length, self.geometry.height)
        faces = self.cells[:, _HEX_FACES].reshape(-1, 4)
        faces = faces[np.unique(np.sort(faces, axis=1), axis=0, return_index=True)[1]]
        out = []
        for k in range(self.n_cells + 1):
            on = np.abs(y - k * d) < tol
            f = faces[np.all(on[faces], axis=1)]
            P = self.points[f]
            area = 0.5 * np.linalg.norm(np.cross(P[:, 2] - P[:, 0], P[:, 3] - P[:, 1]), axis=1)
            w = np.zeros(len(self.points))
            np.add.at(w, f.ravel(), np.repeat(area / 4.0, 4))
            nodes = np.flatnonzero(on)
            out.append((nodes, w[nodes]))
        return out

    def strip_nodes(self) -> tuple[np.ndarray, np.ndarray]:
        """Nodes and area weights of the sections that measure the strip's mean strain:
        k = 1 … n away from the clamp (a lone cell also needs the clamped section k = 0)."""
        sec = self.sections()
        sec = sec[1:] if self.n_cells > 1 else sec
        return np.concatenate([n for n, _ in sec]), np.concatenate([w for _, w in sec])


def _axis(breaks: list[float], edge: float, wall: int, walls: set[int]) -> np.ndarray:
    """Graded coordinates: each interval between breaks divided uniformly."""
    out = [np.array([breaks[0]])]
    for i, (a, b) in enumerate(itertools.pairwise(breaks)):
        n = max(1, math.ceil((b - a) / edge - 1e-9))
        if i in walls:
            n = max(n, wall)
        out.append(np.linspace(a, b, n + 1)[1:])
    return np.concatenate(out)


# local faces of a VTK hexahedron, each ordered counter-clockwise seen from outside the cell
_HEX_FACES = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4],
                       [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]])


def _compact(points: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop the points no cell uses and renumber the connectivity."""
    used = np.unique(cells)
    renum = -np.ones(len(points), dtype=np.int64)
    renum[used] = np.arange(len(used))
    return points[used], renum[cells]


def _chamber_faces(cells: np.ndarray, chamber_points: np.ndarray,
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The boundary quads whose nodes all lie on a chamber surface.

    Returns the faces (k, 4), ordered so that their normal points out of the chamber, and
    the mask over all ``len(cells) · 6`` hexahedron faces that selected them (cell-major,
    for per-cell tags). The solid's outward normal points *into* the chamber, so the faces
    are reversed (the volume integral wants the chamber's outward normal).
    """
    faces = cells[:, _HEX_FACES].reshape(-1, 4)
    _, inv, counts = np.unique(np.sort(faces, axis=1), axis=0, return_inverse=True,
                               return_counts=True)
    on = (counts[inv.ravel()] == 1) & np.all(chamber_points[faces], axis=1)
    return faces[on][:, ::-1].copy(), on


def cell_mesh(geometry: CellGeometry, mesh: str | MeshDensity = "coarse", *,
              element_size: float | None = None, half: bool = True, n_cells: int = 1,
              tilt: float = 0.0) -> CellMesh:
    """Mesh a unit cell, or ``n_cells`` of them in series (a module), with hexahedra.

    Parameters
    ----------
    geometry : CellGeometry
    mesh : {"coarse", "medium", "fine"} or MeshDensity
        Density preset (see :data:`MESH_PRESETS`).
    element_size : float, optional
        Explicit target edge length (m); overrides the preset's length.
    half : bool
        Mesh only x ≤ w/2 (the cell is mirror-symmetric about x = w/2).
    n_cells : int
        Cells in series along y (a bending or stretching module of length n·d): cell k
        occupies [k d, (k + 1) d], so neighbouring end walls merge into one solid partition
        2 df thick, and every chamber is on the same pressure line.
    tilt : float
        Chamber tilt β (rad), |β| < 80°: the twisting module's cells, whose chambers expand
        at the angle β to the strip axis. The straight mesh is sheared in the strip plane,
        y' = y + (x − w/2) tan β, so the partitions (end walls) turn by β while the side
        walls stay parallel to y. The partitions keep their thickness df along y (df cos β
        normal to themselves), the chamber keeps its volume, and the clamped and free end
        faces are the sheared planes y' = (x − w/2) tan β and n d + (x − w/2) tan β. A
        tilted cell has no mirror plane: it needs ``half=False``.

    Returns
    -------
    CellMesh

    Examples
    --------
    >>> from multimorph.materials import Material
    >>> g = CellGeometry(20e-3, 10e-3, 8e-3, 1e-3, 2e-3, 2e-3, 2e-3,
    ...                  material=Material("neo-hooke", {"mu": 1e5}))
    >>> m = cell_mesh(g, "coarse")
    >>> m.ncells, m.ndof
    (288, 1476)
    """
    if isinstance(n_cells, bool) or not isinstance(n_cells, int) or n_cells < 1:
        raise SpecError(f"n_cells: expected a positive integer, got {n_cells!r}")
    tilt = float(tilt)
    if not (math.isfinite(tilt) and abs(tilt) < MAX_TILT):
        raise SpecError(f"tilt: must lie strictly between -80 and 80 degrees, got "
                        f"{math.degrees(tilt):.4g} deg")
    if tilt != 0.0 and half:
        raise SpecError("tilt: a tilted cell has no mirror plane x = w/2; mesh it with "
                        "half=False")
    dens = resolve_density(mesh, element_size)
    g = geometry
    h = dens.edge(g)
    n = dens.wall_elements
    w, d, H = g.width, g.length, g.height
    L = n_cells * d
    if half:
        xs = _axis([0.0, g.ws, w / 2], h, n, {0})
    else:
        xc = _axis([g.ws, w / 2], h, n, set())
        xs = np.concatenate([_axis([0.0, g.ws], h, n, {0}), xc[1:],
                             (w - xc[::-1])[1:], (w - _axis([0.0, g.ws], h, n, {0})[::-1])[1:]])
    ybreaks = [0.0]
    for k in range(n_cells):
        ybreaks += [k * d + g.df, (k + 1) * d - g.df, (k + 1) * d]
    ys = _axis(ybreaks, h, n, {i for i in range(len(ybreaks) - 1) if i % 3 != 1})
    zs = _axis([0.0, g.hb, g.hb + g.hc, H], h, n, {0, 2})

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
    x0, x1 = g.ws, w - g.ws
    z0, z1 = g.hb, g.hb + g.hc
    # position within its own cell: chambers at [df, d − df] of every cell
    yl = np.mod(cen[:, 1], d)
    inside = ((cen[:, 0] > x0) & (cen[:, 0] < x1) & (yl > g.df) & (yl < d - g.df)
              & (cen[:, 2] > z0) & (cen[:, 2] < z1))
    cells = cells[~inside]
    cen = cen[~inside]
    pts, cells = _compact(pts, cells)
    region = np.where(cen[:, 2] < g.hb, BOTTOM, WALL).astype(np.int8)

    tol = 1e-9 * max(w, L, H)
    px, py, pz = pts.T
    chamber_points = np.zeros(len(pts), dtype=bool)
    for k in range(n_cells):
        y0, y1 = k * d + g.df, (k + 1) * d - g.df
        in_box = ((px > x0 - tol) & (px < x1 + tol) & (py > y0 - tol) & (py < y1 + tol)
                  & (pz > z0 - tol) & (pz < z1 + tol))
        on_plane = ((np.abs(px - x0) < tol) | (np.abs(px - x1) < tol)
                    | (np.abs(py - y0) < tol) | (np.abs(py - y1) < tol)
                    | (np.abs(pz - z0) < tol) | (np.abs(pz - z1) < tol))
        chamber_points |= in_box & on_plane

    ch, _ = _chamber_faces(cells, chamber_points)

    clamped = np.abs(py) < tol
    mirror = (np.abs(px - w / 2) < tol) if half else np.zeros(len(pts), dtype=bool)
    line = np.flatnonzero((np.abs(px) < tol) & (np.abs(pz) < tol))
    line = line[np.argsort(py[line])]
    end_face = np.flatnonzero(np.abs(py - L) < tol)
    if len(line) < 3:
        raise SpecError("mesh: the bottom edge line has fewer than 3 nodes")
    if tilt != 0.0:
        # every tag above was found on the straight grid; the shear moves only the points
        pts[:, 1] += (px - w / 2) * math.tan(tilt)
    return CellMesh(points=pts, cells=cells, region=region, chamber_points=chamber_points,
                    chamber_faces=ch, clamped=clamped, mirror=mirror, bend_line=line,
                    end_face=end_face, half=half, geometry=g, density=dens,
                    n_cells=n_cells, tilt=tilt)
