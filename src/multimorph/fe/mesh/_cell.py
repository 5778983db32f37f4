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

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from multimorph.errors import SpecError
from multimorph.fe.mesh._density import MeshDensity, resolve_density
from multimorph.fe.mesh._hex import BOTTOM, WALL, HexMesh, carve, chamber_surface, graded_axis
from multimorph.geometry import CellGeometry
from multimorph.materials import Material

__all__ = ["MAX_TILT", "CellMesh", "cell_mesh"]

MAX_TILT = math.radians(80.0)
"""Largest chamber tilt |β| (rad) a cell mesh accepts (tan β grows without bound at 90°)."""


@dataclass(frozen=True, eq=False)
class CellMesh(HexMesh):
    """A hexahedral mesh of a cell or a module of cells in series (:class:`HexMesh`; m).

    Attributes
    ----------
    region : ndarray (m,)
        :data:`WALL` for wall elastomer, :data:`BOTTOM` for the bottom layer.
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
    plate : tuple of int, optional
        The centre and rotation nodes of a rigid end plate (:meth:`with_end_plate`); they
        belong to no element.
    slide : bool
        Mirror ends (:meth:`with_end_plate` ``(slide=True)``): the clamp face only keeps
        y = 0 and the end face only stays a plane (turning about x), both free to stretch
        in their planes, as the partitions' mid-planes inside a long module.
    """

    bend_line: np.ndarray
    end_face: np.ndarray
    half: bool
    geometry: CellGeometry
    density: MeshDensity = field(default_factory=MeshDensity)
    n_cells: int = 1
    tilt: float = 0.0
    plate: tuple[int, int] | None = None
    slide: bool = False

    @property
    def length(self) -> float:
        """Meshed length along y (m): ``n_cells · d``."""
        return self.n_cells * self.geometry.length

    def bodies(self) -> list[tuple[np.ndarray, Material]]:
        """The wall elastomer and the bottom layer (their cells and materials)."""
        bottom = self.geometry.bottom_material
        assert bottom is not None
        return [(np.flatnonzero(self.region == WALL), self.geometry.material),
                (np.flatnonzero(self.region == BOTTOM), bottom)]

    def fixed(self) -> np.ndarray:
        """:meth:`HexMesh.fixed`; a half model's end plate keeps its centre on the mirror
        plane and turns about x only."""
        out = super().fixed()
        if self.plate is not None and self.half:
            centre, rotation = self.plate
            out[centre, 0] = True
            out[rotation, 1:] = True
            if self.slide:
                # the clamp face stays on y = 0, free in its plane but for one node's z
                # (the mirror plane holds x); the plane's offset is the centre's y
                out[self.clamped, 0] = self.mirror[self.clamped]
                out[self.clamped, 2] = False
                clamped = np.flatnonzero(self.clamped & self.mirror)
                out[clamped[np.argmin(self.points[clamped, 2])], 2] = True
                out[centre, 2] = True
        return out

    def with_end_plate(self, slide: bool = False) -> CellMesh:
        """This mesh with two more nodes, the centre (at the end face's centroid; on the
        mirror plane of a half model) and the rotation node of a rigid plate to tie the free
        end face to (:attr:`plate`). ``slide=True``: mirror ends instead (:attr:`slide`;
        a straight half model only)."""
        if self.plate is not None:
            if self.slide != slide:
                raise ValueError("this mesh already has an end plate of the other kind")
            return self
        if slide and not (self.half and self.tilt == 0.0):
            raise SpecError("end: mirror ends need a straight half model (half = true, no "
                            "tilt); a tilted cell keeps the rigid plate")
        centre = self.points[self.end_face].mean(axis=0)
        if self.half:
            centre[0] = self.geometry.width / 2
        n = len(self.points)
        no = np.zeros(2, dtype=bool)
        return dataclasses.replace(
            self, points=np.vstack([self.points, centre, centre]),
            chamber_points=np.concatenate([self.chamber_points, no]),
            clamped=np.concatenate([self.clamped, no]),
            mirror=np.concatenate([self.mirror, no]), plate=(n, n + 1), slide=slide)

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
        its partitions. A node's weight is its share of the section's reference area
        (:meth:`~HexMesh.section_weights`).
        """
        y = self.unsheared()[:, 1]
        d = self.geometry.length
        tol = 1e-9 * max(self.geometry.width, self.length, self.geometry.height)
        out = []
        for k in range(self.n_cells + 1):
            nodes = np.flatnonzero(np.abs(y - k * d) < tol)
            out.append((nodes, self.section_weights(nodes)))
        return out

    def strip_nodes(self) -> tuple[np.ndarray, np.ndarray]:
        """Nodes and area weights of the sections that measure the strip's mean strain:
        k = 1 … n away from the clamp (a lone cell also needs the clamped section k = 0)."""
        sections = self.sections()
        sections = sections[1:] if self.n_cells > 1 else sections
        return (np.concatenate([nodes for nodes, _ in sections]),
                np.concatenate([weights for _, weights in sections]))


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
    density = resolve_density(mesh, element_size)
    geo = geometry
    edge = density.edge(geo)
    n = density.wall_elements
    w, d, H = geo.width, geo.length, geo.height
    L = n_cells * d
    if half:
        xs = graded_axis([0.0, geo.ws, w / 2], edge, n, {0})
    else:
        side = graded_axis([0.0, geo.ws], edge, n, {0})
        xc = graded_axis([geo.ws, w / 2], edge, n, set())
        xs = np.concatenate([side, xc[1:], (w - xc[::-1])[1:], (w - side[::-1])[1:]])
    ybreaks = [0.0]
    for k in range(n_cells):
        ybreaks += [k * d + geo.df, (k + 1) * d - geo.df, (k + 1) * d]
    ys = graded_axis(ybreaks, edge, n, {i for i in range(len(ybreaks) - 1) if i % 3 != 1})
    zs = graded_axis([0.0, geo.hb, geo.hb + geo.hc, H], edge, n, {0, 2})
    x0, x1 = geo.ws, w - geo.ws
    z0, z1 = geo.hb, geo.hb + geo.hc

    def solid(cen: np.ndarray) -> np.ndarray:
        # position within its own cell: chambers at [df, d − df] of every cell
        yl = np.mod(cen[:, 1], d)
        return ~((cen[:, 0] > x0) & (cen[:, 0] < x1) & (yl > geo.df) & (yl < d - geo.df)
                 & (cen[:, 2] > z0) & (cen[:, 2] < z1))

    pts, cells, cen = carve(xs, ys, zs, solid)
    region = np.where(cen[:, 2] < geo.hb, BOTTOM, WALL).astype(np.int8)
    tol = 1e-9 * max(w, L, H)
    chamber_points, faces, _ = chamber_surface(
        pts, cells, [((x0, k * d + geo.df, z0), (x1, (k + 1) * d - geo.df, z1))
                     for k in range(n_cells)], tol)
    px, py, pz = pts.T
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
                    chamber_faces=faces, clamped=clamped, mirror=mirror, bend_line=line,
                    end_face=end_face, half=half, geometry=geo, density=density,
                    n_cells=n_cells, tilt=tilt)
