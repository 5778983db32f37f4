"""The structured hexahedral mesh of a twisting module: tilted strips around a shaft.

Geometry (global frame: the module axis along y, cross-sections in x–z, the clamp at y = 0):

* **Shaft.** The round shaft of radius ``shaft_radius`` r is approximated by a regular
  ``strips``-gon prism whose *inradius* is r (flat strips need flat faces to sit on): face k
  has the outward normal e_r(φ_k) = (sin φ_k, 0, cos φ_k), φ_k = 2πk/n, and half-width
  a = r tan(π/n). Its cross-section is an O-grid: an inner core (the polygon scaled by
  :data:`CORE` about the axis), split into n quads through the centroid and the edge
  midpoints, and an outer ring of n trapezoids. Each block is meshed by bilinear maps; the
  ring's nodes on face k lie exactly on the strip's x-grid over its footprint plus a few
  nodes over the gaps, and the core reuses the same distribution on each half edge, so the
  blocks match node for node. The section is extruded along the strips' y-grid planes.
* **Strips.** Each strip is the full tilted strip mesh of :func:`~multimorph.fe.cell_mesh`
  (``half=False, tilt=β``), its bottom face z = 0 on face k, centred on it: local x → face
  tangent e_θ = e_y × e_r (a proper rotation), local z → e_r.
* **Tilt.** The strips are sheared in their own frame, y' = y + s tan β with s the local
  x − w/2. The shaft gets y' = y + f with f continuous: s tan β on each strip footprint,
  going back linearly to 0 at the polygon's vertices over the gaps (periodic around the
  perimeter), and scaled linearly from the boundary value to 0 at the axis along rays. The
  shaft's elements are extrusions, so the shear keeps their volume and their Jacobian's sign
  (det J = det J_section · ∂y/∂ζ whatever f is).
* **Material.** Strip walls and bottom layers keep the cell's materials; the shaft is made
  of the cell's wall material (the gripper spec's shaft is the strips' Dragon Skin 10, and
  the reduced model assumes a shaft as soft as the strips, transmitting, not resisting, the
  twist).

Pieces are merged by coincident nodes (cKDTree, tolerance 1e-9 of the cell length), so the
mesh is conforming.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from multimorph.device import Module
from multimorph.errors import SpecError
from multimorph.fe.mesh._cell import CellMesh, cell_mesh
from multimorph.fe.mesh._density import MeshDensity, resolve_density
from multimorph.fe.mesh._hex import BOTTOM, SHAFT, HexMesh, material_bodies
from multimorph.materials import Material

__all__ = ["CORE", "TwistMesh", "twisting_module_mesh"]

CORE = 0.5
"""Size of the shaft's inner core, as a fraction of the polygon (the ring is the rest)."""


@dataclass(frozen=True, eq=False)
class TwistMesh(HexMesh):
    """A hexahedral mesh of a twisting module with its tags (:class:`HexMesh`; m).

    Attributes
    ----------
    region : ndarray (m,)
        :data:`WALL` strip wall, :data:`BOTTOM` strip bottom layer, :data:`SHAFT` shaft.
    clamped : ndarray (n,) of bool
        Nodes of the reference end (unsheared y = 0).
    mirror : ndarray (n,) of bool
        All False (a twisting module has no mirror plane).
    strip : ndarray (m,)
        Strip of each element (0 … strips − 1), −1 for the shaft.
    material : ndarray (m,)
        Index of the element's material in ``materials``.
    shear : ndarray (n,)
        The tilt's shift of every node along y (m): points minus :meth:`unsheared`.
    end_section : ndarray (i,)
        Nodes of the free end section (unsheared y = L).
    module : Module
    strip_mesh : CellMesh
        The one strip in its own frame.
    materials : tuple of Material
    radius : float
        Inradius of the shaft polygon (m), the module's ``shaft_radius``.
    half_face : float
        Half-width of a polygon face a = r tan(π/n) (m).
    density : MeshDensity
    """

    strip: np.ndarray
    material: np.ndarray
    shear: np.ndarray
    end_section: np.ndarray
    module: Module
    strip_mesh: CellMesh
    materials: tuple[Material, ...]
    radius: float
    half_face: float
    density: MeshDensity = field(default_factory=MeshDensity)

    @property
    def length(self) -> float:
        """Module length along y (m): ``n_cells · d``."""
        return self.module.length

    def bodies(self) -> list[tuple[np.ndarray, Material]]:
        """One body per distinct material (its elements and the material)."""
        return material_bodies(self.material, self.materials)

    def unsheared(self) -> np.ndarray:
        """Node coordinates before the tilt shear (m)."""
        pts = self.points.copy()
        pts[:, 1] -= self.shear
        return pts


def _frame(k: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Outward normal e_r and tangent e_θ = e_y × e_r of face k, as (x, z) pairs."""
    phi = 2.0 * math.pi * k / n
    return np.array([math.sin(phi), math.cos(phi)]), np.array([math.cos(phi), -math.sin(phi)])


def _face_grid(xs: np.ndarray, w: float, a: float, edge: float, tol: float) -> np.ndarray:
    """Tangential node positions s ∈ [−a, a] on a face: the strip's x-grid (shifted by
    −w/2) over its footprint, uniform nodes over the gaps to the vertices."""
    s = np.asarray(xs) - 0.5 * w
    gap = a - 0.5 * w
    if gap <= tol:
        return s
    k = max(1, math.ceil(gap / edge - 1e-9))
    right = np.linspace(0.5 * w, a, k + 1)[1:]
    return np.concatenate([-right[::-1], s, right])


def _tilt_shift(pts2: np.ndarray, n: int, r: float, a: float, w: float, tan_b: float,
                ) -> np.ndarray:
    """The shaft's y-shift f at section points (x, z): the boundary value at the ray's end
    scaled by the gauge λ = max_k (P · e_r(φ_k)) / r (0 at the axis, 1 on the boundary)."""
    normals = np.array([_frame(k, n)[0] for k in range(n)])
    tangents = np.array([_frame(k, n)[1] for k in range(n)])
    proj = pts2 @ normals.T  # (p, n)
    k = np.argmax(proj, axis=1)
    lam = proj[np.arange(len(pts2)), k] / r
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.where(lam > 0, np.einsum("pi,pi->p", pts2, tangents[k]) / np.where(
            lam > 0, lam, 1.0), 0.0)
    h = 0.5 * w
    if a - h <= 1e-9 * a:  # strips flush with the faces: no gaps
        return lam * np.clip(s, -h, h) * tan_b
    back = np.sign(s) * h * (a - np.minimum(np.abs(s), a)) / (a - h)
    return lam * np.where(np.abs(s) <= h, s, back) * tan_b


def _shaft_section(n: int, r: float, t_face: np.ndarray, n_ring: int,
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The O-grid section: points (x, z) and quads (duplicated nodes between blocks; the
    caller merges them). ``t_face`` are the tangential positions s on a face ([−a, a])."""
    a = r * math.tan(math.pi / n)
    pts, quads = [], []
    base = 0

    def block(P: np.ndarray) -> None:
        nonlocal base
        ni, nj = P.shape[:2]
        idx = base + np.arange(ni * nj).reshape(ni, nj)
        pts.append(P.reshape(-1, 2))
        quads.append(np.column_stack([idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(),
                                      idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()]))
        base += ni * nj

    rho = np.linspace(CORE, 1.0, n_ring + 1)
    t = t_face[t_face >= -1e-15 * a] / a  # half edge, midpoint (0) to vertex (1)
    t[0] = 0.0
    for k in range(n):
        er, et = _frame(k, n)
        outer = r * er + t_face[:, None] * et  # (m, 2)
        block(rho[None, :, None] * outer[:, None, :])  # ring trapezoid of face k
        er1 = _frame(k + 1, n)[0]
        C = np.zeros(2)
        mk, vk, mk1 = CORE * r * er, CORE * (r * er + a * et), CORE * r * er1
        xi, eta = np.meshgrid(t, t, indexing="ij")
        P = ((1 - xi) * (1 - eta))[..., None] * C + (xi * (1 - eta))[..., None] * mk \
            + (xi * eta)[..., None] * vk + ((1 - xi) * eta)[..., None] * mk1
        block(P)  # core quad at the vertex between faces k and k + 1
    return np.concatenate(pts), np.concatenate(quads)


def _distinct(v: np.ndarray, tol: float) -> np.ndarray:
    """Sorted values of ``v`` with those closer than ``tol`` to the previous one dropped
    (the grid lines of a mesh whose coordinates carry rounding from the shear)."""
    v = np.sort(v)
    return v[np.concatenate([[True], np.diff(v) > tol])]


def _merge(points: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Representative index of every point after merging points closer than ``tol``:
    returns (unique points, map old → new)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    pairs = cKDTree(points).query_pairs(tol, output_type="ndarray")
    n = len(points)
    G = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, labels = connected_components(G, directed=False)
    # number the groups in order of their first point
    first = np.full(labels.max() + 1, n)
    np.minimum.at(first, labels, np.arange(n))
    order = np.argsort(first)
    renum = np.empty_like(order)
    renum[order] = np.arange(len(order))
    return points[first[order]], renum[labels]


def twisting_module_mesh(module: Module, mesh: str | MeshDensity = "coarse", *,
                         element_size: float | None = None, tilt: float | None = None,
                         ) -> TwistMesh:
    """Mesh a twisting module (tilted strips around a polygonal shaft) with hexahedra.

    Parameters
    ----------
    module : Module
        ``kind="twisting"``: ``strips`` (≥ 3) strips of ``n_cells`` cells tilted by ``tilt``
        β, on a shaft of radius ``shaft_radius`` (the polygon's inradius).
    mesh : {"coarse", "medium", "fine"} or MeshDensity
        Density of the strip mesh (:func:`~multimorph.fe.cell_mesh`); the shaft follows it.
    element_size : float, optional
        Explicit target edge length (m).
    tilt : float, optional
        Override the module's tilt β (rad): ``0.0`` meshes the straight reference module
        (which :class:`Module` itself does not allow).

    Returns
    -------
    TwistMesh

    Raises
    ------
    SpecError
        Naming the module and field: not a twisting module, fewer than 3 strips (no polygon),
        or strips wider than the polygon's faces (2 r tan(π/n)).

    Examples
    --------
    >>> from multimorph.geometry import CellGeometry
    >>> from multimorph.materials import Material
    >>> g = CellGeometry(10e-3, 12e-3, 10e-3, 0.5e-3, 4e-3, 2.5e-3, 0.75e-3,
    ...                  material=Material("neo-hooke", {"mu": 1e5}))
    >>> m = Module("tw", "twisting", g, n_cells=2, tilt=0.5, shaft_radius=6e-3)
    >>> twisting_module_mesh(m).ncells > 0
    True
    """
    where = f"module {module.name!r}"
    if module.kind != "twisting":
        raise SpecError(f"{where}.kind: {module.kind!r}; twisting_module_mesh takes a "
                        f"twisting module")
    n = module.strips
    if n < 3:
        raise SpecError(f"{where}.strips: {n} strips; the FE shaft is a regular polygon with "
                        f"one face per strip, so it needs at least 3")
    cell = module.cell
    r = module.shaft_radius
    a = r * math.tan(math.pi / n)
    w, d = cell.width, cell.length
    tol = 1e-9 * d
    if 0.5 * w > a + tol:
        raise SpecError(f"{where}.shaft_radius: strips of width {w * 1e3:.4g} mm (cell "
                        f"width) do not fit on the faces of the {n}-gon shaft with inradius "
                        f"{r * 1e3:.4g} mm (face width 2 r tan(180°/strips) = "
                        f"{2 * a * 1e3:.4g} mm); raise shaft_radius or lower strips or the "
                        f"cell width")
    beta = module.tilt if tilt is None else float(tilt)
    density = resolve_density(mesh, element_size)
    edge = density.edge(cell)
    strip_mesh = cell_mesh(cell, density, n_cells=module.n_cells, half=False, tilt=beta)
    tan_b = math.tan(beta)
    loc = strip_mesh.unsheared()
    xs, ys = _distinct(loc[:, 0], tol), _distinct(loc[:, 1], tol)

    # strips: local (x, y, z) -> (x − w/2) e_θ + (r + z) e_r, y
    pts, cells, region, strip, chamber, chambers = [], [], [], [], [], []
    base = 0
    for k in range(n):
        er, et = _frame(k, n)
        across = strip_mesh.points[:, 0] - 0.5 * w
        rad = r + strip_mesh.points[:, 2]
        xz = across[:, None] * et + rad[:, None] * er
        P = np.column_stack([xz[:, 0], strip_mesh.points[:, 1], xz[:, 1]])
        pts.append(P)
        cells.append(strip_mesh.cells + base)
        region.append(strip_mesh.region)
        strip.append(np.full(len(strip_mesh.cells), k))
        chamber.append(strip_mesh.chamber_points)
        chambers.append(strip_mesh.chamber_faces + base)
        base += len(P)
    shift = [strip_mesh.points[:, 1] - loc[:, 1]] * n

    # shaft: O-grid section extruded along the strip's y planes, sheared by f
    s_face = _face_grid(xs, w, a, edge, tol)
    n_ring = max(1, math.ceil((1.0 - CORE) * r / edge - 1e-9))
    sec, quads = _shaft_section(n, r, s_face, n_ring)
    sec, renum = _merge(sec, tol)
    quads = renum[quads]
    # orient every quad so that its extrusion along +y has a positive Jacobian:
    # clockwise in (x, z), since e_x × e_z = −e_y
    e1 = sec[quads[:, 1]] - sec[quads[:, 0]]
    e3 = sec[quads[:, 3]] - sec[quads[:, 0]]
    ccw = e1[:, 0] * e3[:, 1] - e1[:, 1] * e3[:, 0] > 0
    quads[ccw] = quads[ccw][:, ::-1]
    f = _tilt_shift(sec, n, r, a, w, tan_b)
    m2 = len(sec)
    P = np.column_stack([np.tile(sec[:, 0], len(ys)), np.repeat(ys, m2),
                         np.tile(sec[:, 1], len(ys))])
    P[:, 1] += np.tile(f, len(ys))
    lay = base + m2 * np.arange(len(ys) - 1)[:, None, None]
    hexes = np.concatenate([quads[None] + lay, quads[None] + lay + m2], axis=2).reshape(-1, 8)
    pts.append(P)
    cells.append(hexes)
    region.append(np.full(len(hexes), SHAFT))
    strip.append(np.full(len(hexes), -1))
    chamber.append(np.zeros(len(P), dtype=bool))
    shift.append(np.tile(f, len(ys)))

    allp = np.concatenate(pts)
    points, renum = _merge(allp, tol)
    cells_ = renum[np.concatenate(cells)]
    chamber_pts = np.zeros(len(points), dtype=bool)
    chamber_pts[renum[np.concatenate(chamber)]] = True
    sh = np.zeros(len(points))
    sh[renum] = np.concatenate(shift)
    region_ = np.concatenate(region).astype(np.int8)
    materials: list[Material] = [cell.material]
    bottom = cell.bottom_material if cell.bottom_material is not None else cell.material
    if bottom not in materials:
        materials.append(bottom)
    material = np.where(region_ == BOTTOM, materials.index(bottom), 0).astype(np.int16)
    y0 = points[:, 1] - sh
    L = module.length
    return TwistMesh(
        points=points, cells=cells_, region=region_, strip=np.concatenate(strip).astype(np.int16),
        material=material, chamber_points=chamber_pts,
        chamber_faces=renum[np.concatenate(chambers)], shear=sh,
        clamped=np.abs(y0) < tol, mirror=np.zeros(len(points), dtype=bool),
        end_section=np.flatnonzero(np.abs(y0 - L) < tol),
        module=module, strip_mesh=strip_mesh, materials=tuple(materials), radius=r, half_face=a,
        density=density)

