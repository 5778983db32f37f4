"""Structured hexahedral grids: the mesh base type, densities and the grid helpers.

Every FE mesh of the package (a cell or module, a device, a twisting module) is a
:class:`HexMesh`: VTK hexahedra with region tags, the chamber surface as whole quad faces
(FElupe's pressure boundary needs hex/quad faces), the clamped nodes and, for a half model,
the nodes on the mirror plane x = const. A grid is built by cutting a box at every wall
plane (:func:`graded_axis` divides each interval), deleting the cells inside the chambers
and dropping the unused nodes (:func:`_compact`).
"""

from __future__ import annotations

import itertools
import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from multimorph.materials import Material

__all__ = ["BOTTOM", "HEX_FACES", "REGION_NAMES", "SHAFT", "WALL", "HexMesh", "carve",
           "chamber_surface", "graded_axis", "hex_boundary", "material_bodies"]

WALL, BOTTOM, SHAFT = 0, 1, 2
"""Region tags: wall elastomer (top, side and end walls), the stiff bottom layer, and a
twisting module's shaft."""

#: names of the element regions by tag
REGION_NAMES = ("wall", "bottom layer", "shaft")

#: local faces of a VTK hexahedron, each ordered counter-clockwise seen from outside the cell
HEX_FACES = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4],
                      [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]])


@dataclass(frozen=True, eq=False)
class HexMesh(ABC):
    """A hexahedral mesh with its tags (all coordinates in m, reference configuration).

    Attributes
    ----------
    points : ndarray (n, 3)
    cells : ndarray (m, 8)
        VTK hexahedron connectivity.
    region : ndarray (m,)
        Region tag of every element (:data:`WALL`, :data:`BOTTOM`, :data:`SHAFT`).
    chamber_points : ndarray (n,) of bool
        Nodes on a chamber surface (the pressure boundary).
    chamber_faces : ndarray (k, 4)
        Chamber faces, ordered so that their normal points out of the chamber.
    clamped : ndarray (n,) of bool
        Nodes held fixed (the mounting face).
    mirror : ndarray (n,) of bool
        Nodes on the mirror plane of a half model (held in x; all False for a whole one).
    """

    points: np.ndarray
    cells: np.ndarray
    region: np.ndarray
    chamber_points: np.ndarray
    chamber_faces: np.ndarray
    clamped: np.ndarray
    mirror: np.ndarray

    @property
    def ndof(self) -> int:
        """Displacement degrees of freedom before constraints."""
        return 3 * len(self.points)

    @property
    def ncells(self) -> int:
        """Number of elements."""
        return len(self.cells)

    @abstractmethod
    def bodies(self) -> list[tuple[np.ndarray, Material]]:
        """Element indices and material of every body, one per material region."""

    def fixed(self) -> np.ndarray:
        """Fixed displacement components (n, 3): every one of a clamped node, x on the
        mirror plane."""
        out = np.zeros((len(self.points), 3), dtype=bool)
        out[self.clamped] = True
        out[self.mirror, 0] = True
        return out

    def section_weights(self, nodes: np.ndarray) -> np.ndarray:
        """Area weights of ``nodes`` (a plane cross-section): a quarter of every quad face
        of the section each node touches, so weighted means of bilinear fields are exact."""
        on = np.zeros(len(self.points), dtype=bool)
        on[nodes] = True
        faces = self.cells[:, HEX_FACES].reshape(-1, 4)
        faces = faces[np.all(on[faces], axis=1)]
        faces = faces[np.unique(np.sort(faces, axis=1), axis=0, return_index=True)[1]]
        P = self.points[faces]
        area = 0.5 * np.linalg.norm(np.cross(P[:, 2] - P[:, 0], P[:, 3] - P[:, 1]), axis=1)
        w = np.zeros(len(self.points))
        np.add.at(w, faces.ravel(), np.repeat(area / 4.0, 4))
        return w[nodes]


def material_bodies(material: np.ndarray, materials: Sequence[Material],
                    ) -> list[tuple[np.ndarray, Material]]:
    """One body per entry of ``materials``: the elements whose ``material`` index is its."""
    return [(np.flatnonzero(material == i), mat) for i, mat in enumerate(materials)]


def graded_axis(breaks: list[float], edge: float, wall: int, walls: set[int]) -> np.ndarray:
    """Graded coordinates: each interval between ``breaks`` divided uniformly into pieces of
    at most ``edge``, the intervals numbered in ``walls`` into at least ``wall``."""
    out = [np.array([breaks[0]])]
    for i, (a, b) in enumerate(itertools.pairwise(breaks)):
        n = max(1, math.ceil((b - a) / edge - 1e-9))
        if i in walls:
            n = max(n, wall)
        out.append(np.linspace(a, b, n + 1)[1:])
    return np.concatenate(out)


def _box_grid(xs: np.ndarray, ys: np.ndarray, zs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The points and hexahedra (VTK order) of the tensor grid ``xs × ys × zs``."""
    X, Y, Z = np.meshgrid(xs, ys, zs, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    nx, ny, nz = len(xs), len(ys), len(zs)
    idx = np.arange(nx * ny * nz).reshape(nx, ny, nz)
    a = idx[:-1, :-1, :-1].ravel()
    b = idx[1:, :-1, :-1].ravel()
    c = idx[1:, 1:, :-1].ravel()
    e = idx[:-1, 1:, :-1].ravel()
    return pts, np.column_stack([a, b, c, e, a + 1, b + 1, c + 1, e + 1])


def _box_surface(points: np.ndarray, lo: Sequence[float], hi: Sequence[float], tol: float,
                ) -> np.ndarray:
    """The points on the surface of the box ``lo`` … ``hi`` (within ``tol``)."""
    inside = np.ones(len(points), dtype=bool)
    on_plane = np.zeros(len(points), dtype=bool)
    for p, a, b in zip(points.T, lo, hi, strict=True):
        inside &= (p > a - tol) & (p < b + tol)
        on_plane |= (np.abs(p - a) < tol) | (np.abs(p - b) < tol)
    return inside & on_plane


def _compact(points: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop the points no cell uses and renumber the connectivity."""
    used = np.unique(cells)
    renum = -np.ones(len(points), dtype=np.int64)
    renum[used] = np.arange(len(used))
    return points[used], renum[cells]


def _boundary_faces(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All ``len(cells) · 6`` faces of the hexahedra (cell-major, counter-clockwise seen from
    outside their element) and the mask of those on the boundary (faces of one element)."""
    faces = cells[:, HEX_FACES].reshape(-1, 4)
    _, inv, counts = np.unique(np.sort(faces, axis=1), axis=0, return_inverse=True,
                               return_counts=True)
    return faces, counts[inv.ravel()] == 1


def _chamber_faces(cells: np.ndarray, chamber_points: np.ndarray,
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The boundary quads whose nodes all lie on a chamber surface.

    Returns the faces (k, 4), ordered so that their normal points out of the chamber, and
    the mask over all ``len(cells) · 6`` hexahedron faces that selected them (cell-major,
    for per-cell tags). The solid's outward normal points *into* the chamber, so the faces
    are reversed (the volume integral wants the chamber's outward normal).
    """
    faces, outer = _boundary_faces(cells)
    on = outer & np.all(chamber_points[faces], axis=1)
    return faces[on][:, ::-1].copy(), on


def carve(xs: np.ndarray, ys: np.ndarray, zs: np.ndarray,
          solid: Callable[[np.ndarray], np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tensor grid ``xs × ys × zs`` cut down to the cells whose centroid ``solid`` keeps
    (``solid(centroids)`` is a mask), the unused nodes dropped: the points, the cells (VTK
    hexahedra) and the kept cells' centroids."""
    points, cells = _box_grid(xs, ys, zs)
    centroids = points[cells].mean(axis=1)
    keep = solid(centroids)
    points, cells = _compact(points, cells[keep])
    return points, cells, centroids[keep]


def chamber_surface(points: np.ndarray, cells: np.ndarray,
                    boxes: Iterable[tuple[Sequence[float], Sequence[float]]], tol: float,
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The chambers of a carved grid: the nodes on the surface of the chamber ``boxes``
    (each its lower and upper corner, within ``tol``), the chamber faces (normals out of the
    chamber) and the element of each face."""
    on = np.zeros(len(points), dtype=bool)
    for lo, hi in boxes:
        on |= _box_surface(points, lo, hi, tol)
    faces, mask = _chamber_faces(cells, on)
    return on, faces, np.repeat(np.arange(len(cells)), len(HEX_FACES))[mask]


def hex_boundary(cells: np.ndarray) -> np.ndarray:
    """The boundary quads of a hexahedral mesh (faces of exactly one element), ordered
    counter-clockwise seen from outside that element: their normals point away from the
    material, out of the outer surface and into every cavity (chambers)."""
    faces, outer = _boundary_faces(cells)
    return faces[outer]
