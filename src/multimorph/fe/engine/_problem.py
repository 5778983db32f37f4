"""A pressure-loaded, nearly incompressible FE problem with explicit state handling.

FElupe's :class:`SolidBodyNearlyIncompressible` (u/p/J̄ with cell-wise constant p and J̄,
condensed) updates p and J̄ on every residual call by a *linearised* step from the previous
call (fe-notes §2). That linearised update is what makes Newton converge in a few
iterations: evaluating the dual fields exactly (J̄ = v/V) after a large linearised step puts
a huge K(J − 1) into the geometric stiffness, and Newton diverges for steps of a few per cent
of μ (measured on the unit cell: 4 iterations per 0.05 μ step with the linearised update,
divergence with the exact one). The price is hidden state, so this class makes it explicit:

* :meth:`PressureProblem.sync` sets the dual fields to their exact values at a displacement
  (J̄_e = v_e/V_e, p_e = K(J̄_e − 1)); call it at every converged point and before every
  Newton solve or retry, which starts from that point;
* :meth:`PressureProblem.residual` advances the state by FElupe's linearised update;
* :meth:`PressureProblem.tangent` reuses the kinematics of the preceding residual call at the
  same displacement (never re-extracting, which would update the state twice).

The residual is ``r(u, P) = f_int(u) − P g(u)`` with the follower pressure load ``g`` at unit
pressure on the chamber faces; the tangent is ``∂r/∂u`` and ``∂r/∂P = −g``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from multimorph.fe._deps import require
from multimorph.fe.engine._material import felupe_umat
from multimorph.fe.engine._plane import PlaneTie
from multimorph.materials import Material

__all__ = ["AssemblyStats", "PressureProblem"]


@dataclass
class AssemblyStats:
    """Counters of assembly work (seconds and calls)."""

    vector_time: float = 0.0
    matrix_time: float = 0.0
    vectors: int = 0
    matrices: int = 0

    @property
    def time(self) -> float:
        return self.vector_time + self.matrix_time


class _ActiveSum:
    """Sums sparse matrices of fixed patterns, restricted to the active DOF, into one CSR.

    FElupe assembles each body's tangent (and the pressure's) on all DOF with a pattern that
    stays the same along a path. The positions of their entries in the summed, restricted
    matrix are computed once; every later call is one ``bincount`` per matrix instead of
    sparse additions, a format conversion and a row/column slice (about 15 ms per tangent
    at 10k DOF). The result is canonical CSR (sorted, no duplicates) and keeps explicit
    zeros, so its pattern, and the solver's symbolic analysis, stay the same along a path.
    A matrix whose pattern differs from the cached one rebuilds the maps.
    """

    def __init__(self, active: np.ndarray, n_all: int) -> None:
        self.n = len(active)
        self._pos = np.full(n_all, -1, dtype=np.int64)
        self._pos[active] = np.arange(self.n)
        self._patterns: list[tuple[np.ndarray, np.ndarray]] = []
        self._map = np.zeros(0, dtype=np.int64)
        self._indptr = self._indices = np.zeros(0, dtype=np.int32)
        self.nnz = 0

    def _matches(self, mats: Sequence[sp.csr_matrix]) -> bool:
        return len(mats) == len(self._patterns) and all(
            np.array_equal(matrix.indptr, ip) and np.array_equal(matrix.indices, ix)
            for matrix, (ip, ix) in zip(mats, self._patterns, strict=True))

    def _build(self, mats: Sequence[sp.csr_matrix]) -> None:
        n, pos = self.n, self._pos
        keys = []
        for matrix in mats:
            rows = pos[np.repeat(np.arange(matrix.shape[0]), np.diff(matrix.indptr))]
            cols = pos[matrix.indices]
            keys.append(np.where((rows >= 0) & (cols >= 0), rows * n + cols, -1))
        union = np.unique(np.concatenate([k[k >= 0] for k in keys]))
        self.nnz = len(union)
        # entries on a fixed DOF go to one extra slot, dropped after the sum
        self._map = np.concatenate([np.where(k >= 0, np.searchsorted(union, k), self.nnz)
                                    for k in keys])
        self._patterns = [(matrix.indptr.copy(), matrix.indices.copy()) for matrix in mats]
        counts = np.bincount(union // n, minlength=n)
        self._indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
        self._indices = (union % n).astype(np.int32)

    def __call__(self, mats: Sequence[sp.csr_matrix], weights: Sequence[float],
                 ) -> sp.csr_matrix:
        if not self._matches(mats):
            self._build(mats)
        values = np.concatenate([matrix.data if w == 1.0 else w * matrix.data
                                 for matrix, w in zip(mats, weights, strict=True)])
        data = np.bincount(self._map, weights=values, minlength=self.nnz + 1)
        K = sp.csr_matrix((data[:-1], self._indices.copy(), self._indptr.copy()),
                          shape=(self.n, self.n))
        K.has_canonical_format = True
        return K


class _MeanDilatationBody:
    """A nearly incompressible FElupe body whose dual fields are set exactly before use."""

    def __init__(self, material: Material, region: Any, field_cls: Any, global_field: Any,
                 ) -> None:
        fem = require("felupe")
        self.field = fem.FieldContainer([field_cls(region, dim=global_field[0].dim)])
        self.field.link(global_field)
        self.solid = fem.SolidBodyNearlyIncompressible(
            felupe_umat(material), self.field, bulk=material.bulk)

    def sync(self) -> None:
        """Set the dual fields to their exact values at the current displacement."""
        res = self.solid.results
        state = res.state
        res.kinematics = state.F = self.field.extract(out=res.kinematics)
        state.u[:] = self.field[0].values
        state.J[:] = state.volume() / self.solid.V
        state.p[:] = self.solid.bulk * (state.J - 1.0)

    def snapshot(self) -> tuple[Any, ...]:
        """Copies of the dual fields, the displacement they were updated from and F."""
        res = self.solid.results
        state = res.state
        return state.u.copy(), state.J.copy(), state.p.copy(), [k.copy() for k in res.kinematics]

    def restore(self, snap: tuple[Any, ...]) -> None:
        res = self.solid.results
        state = res.state
        u, J, p, kin = snap
        state.u[:] = u
        state.J[:] = J
        state.p[:] = p
        for a, b in zip(res.kinematics, kin, strict=True):
            a[...] = b

    def vector(self) -> Any:
        """Internal force; advances the dual fields by FElupe's linearised update."""
        return self.solid.assemble.vector(field=self.field)

    def matrix(self) -> Any:
        """Tangent at the kinematics of the preceding :meth:`vector` call."""
        return self.solid.assemble.matrix()


@dataclass(eq=False)
class PressureProblem:
    """Nearly incompressible bodies on one mesh, a follower pressure, fixed DOF (u = 0).

    Units are whatever the caller scaled to (the cell model uses lengths in units of the cell
    length and stresses in units of the wall shear modulus).

    Parameters
    ----------
    mesh : felupe.Mesh
        The whole mesh (all bodies share its points).
    bodies : sequence of (cell indices, Material)
        One nearly incompressible body per material region.
    pressure_mask : ndarray (npoints,) of bool
        Nodes of the pressurised faces (a face is loaded when all its nodes are).
    fixed : ndarray (npoints, dim) of bool
        Fixed displacement components.
    kind : {"3d", "axisymmetric", "plane_strain"}
    ties : sequence of (points, center, rotation[, kind])
        Rigid joints (3d, ``kind="rigid"``, the default): FElupe ``MultiPointConstraint``
        items that keep the arms from node ``center`` to ``points`` up to the rotation whose
        rotation vector is the value at node ``rotation`` (a node of no element). The
        rotation is the total one from the undeformed state (FElupe's converged-rotation
        state is never advanced), which is well defined below a full turn and keeps the
        problem free of hidden state. ``kind="plane"``: a :class:`PlaneTie` (the points stay
        on a plane y = Y + s turned about x, free to slide in it; s and the turn are the y
        value of ``center`` and the x value of ``rotation``).
    tie_stiffness : float
        The penalty of the ties (force per length, in the caller's units).
    """

    mesh: Any
    bodies: Sequence[tuple[np.ndarray, Material]]
    pressure_mask: np.ndarray
    fixed: np.ndarray
    kind: str = "3d"
    ties: Sequence[tuple[Any, ...]] = ()
    tie_stiffness: float = 0.0
    stats: AssemblyStats = field(default_factory=AssemblyStats)

    def __post_init__(self) -> None:
        fem = require("felupe")
        dim = self.mesh.points.shape[1]
        if self.kind == "3d":
            region_cls, bregion_cls, field_cls = (fem.RegionHexahedron,
                                                  fem.RegionHexahedronBoundary, fem.Field)
            bkw: dict[str, Any] = {}
        else:
            region_cls, bregion_cls = fem.RegionQuad, fem.RegionQuadBoundary
            field_cls = (fem.FieldAxisymmetric if self.kind == "axisymmetric"
                         else fem.FieldPlaneStrain)
            bkw = {"ensure_3d": True}
        region = region_cls(self.mesh)
        self.field = fem.FieldContainer([field_cls(region, dim=dim)])
        self._bodies = []
        for cells, material in self.bodies:
            sub = self.mesh.copy()
            sub.update(cells=self.mesh.cells[np.asarray(cells)])
            self._bodies.append(_MeanDilatationBody(material, region_cls(sub), field_cls,
                                                    self.field))
        bregion = bregion_cls(self.mesh, only_surface=True, mask=self.pressure_mask, **bkw)
        if bregion.mesh.ncells == 0:
            raise ValueError("no pressurised faces selected")
        bfield = fem.FieldContainer([field_cls(bregion, dim=dim)])
        self._pressure = fem.SolidBodyPressure(bfield, pressure=1.0)
        if self.ties and not self.tie_stiffness > 0:
            raise ValueError("ties need a positive tie_stiffness")
        self._ties = [self._tie(fem, *tie) for tie in self.ties]
        self.fixed = np.asarray(self.fixed, dtype=bool).reshape(-1, dim)
        self.active = np.flatnonzero(~self.fixed.ravel())
        self.dim = dim
        self._last_x: np.ndarray | None = None
        self._sum = _ActiveSum(self.active, self.fixed.size)

    def _tie(self, fem: Any, points: np.ndarray, center: int, rotation: int,
             kind: str = "rigid") -> Any:
        if kind == "rigid":
            return fem.MultiPointConstraint(self.field, np.asarray(points), centerpoint=int(center),
                                            rotationpoint=int(rotation),
                                            multiplier=self.tie_stiffness)
        if kind == "plane":
            return PlaneTie(points, center, rotation, self.tie_stiffness, self.mesh.points)
        raise ValueError(f"tie kind: expected 'rigid' or 'plane', got {kind!r}")

    # ------------------------------------------------------------------ state
    @property
    def values(self) -> np.ndarray:
        """Nodal displacements (npoints, dim), a live view."""
        return self.field[0].values

    def get_x(self) -> np.ndarray:
        """Active displacement components (copy)."""
        return self.values.ravel()[self.active].copy()

    def set_x(self, x: np.ndarray) -> None:
        flat = self.values.reshape(-1)
        flat[self.active] = x

    @property
    def nfree(self) -> int:
        return len(self.active)

    # ------------------------------------------------------------------ assembly
    def _vec(self, v: Any) -> np.ndarray:
        return np.asarray(v.toarray()).ravel() if sp.issparse(v) else np.asarray(v).ravel()

    def internal_force(self) -> np.ndarray:
        """Internal force vector (all DOF)."""
        t = time.perf_counter()
        r = sum(self._vec(b.vector()) for b in self._bodies)
        for tie in self._ties:
            r = r + self._vec(tie.assemble.vector(field=self.field))
        self.stats.vector_time += time.perf_counter() - t
        self.stats.vectors += 1
        return np.asarray(r)

    def pressure_load(self) -> np.ndarray:
        """Follower load g(u) of unit pressure (all DOF)."""
        return self._vec(self._pressure.assemble.vector(field=self.field, pressure=1.0))

    def sync(self, x: np.ndarray) -> None:
        """Set the displacement to ``x`` and the bodies' dual fields exactly (a restore)."""
        self.set_x(x)
        for b in self._bodies:
            b.sync()
        self._last_x = None

    def snapshot(self) -> tuple[Any, ...]:
        """Everything a residual evaluation leaves behind for the next residual (the dual
        fields' linearised update) and for the tangent (the kinematics): restoring it
        afterwards is the same as evaluating that residual again."""
        return (self.values.copy(), [b.snapshot() for b in self._bodies],
                self._pressure.results.kinematics,
                None if self._last_x is None else self._last_x.copy())

    def restore(self, snap: tuple[Any, ...]) -> None:
        values, bodies, pressure_kinematics, last_x = snap
        self.values[...] = values
        for b, sb in zip(self._bodies, bodies, strict=True):
            b.restore(sb)
        self._pressure.results.kinematics = pressure_kinematics  # fresh arrays per extract
        self._last_x = None if last_x is None else last_x.copy()

    def residual(self, x: np.ndarray, p: float) -> tuple[np.ndarray, np.ndarray]:
        """Residual ``r = f_int − p g`` and the unit load ``g`` on the active DOF at ``x``.

        Advances the dual fields (linearised update from the previous evaluation).
        """
        self.set_x(x)
        fi = self.internal_force()
        g = self.pressure_load()
        self._last_x = np.array(x, copy=True)
        return (fi - p * g)[self.active], g[self.active]

    def tangent(self, x: np.ndarray, p: float) -> sp.csr_matrix:
        """Tangent ``∂r/∂u`` on the active DOF at ``x`` (CSR).

        Uses the kinematics of the preceding :meth:`residual` call, which must have been at
        the same ``x`` (otherwise the residual is evaluated first).
        """
        if self._last_x is None or not np.array_equal(self._last_x, x):
            self.residual(x, p)
        t = time.perf_counter()
        mats = [b.matrix().tocsr() for b in self._bodies]
        mats.append(self._pressure.assemble.matrix(pressure=1.0).tocsr())
        mats += [tie.assemble.matrix(field=self.field).tocsr() for tie in self._ties]
        K = self._sum(mats, [1.0] * len(self._bodies) + [-p] + [1.0] * len(self._ties))
        self.stats.matrix_time += time.perf_counter() - t
        self.stats.matrices += 1
        return K

    def deformation_gradient(self) -> np.ndarray:
        """F at the quadrature points, shape (3, 3, q, cells) (plane/axisymmetric: 3×3)."""
        return self.field.extract()[0]
