"""A penalty tie that keeps points on a plane that may move and turn, while they slide in it.

FElupe's :class:`~felupe.MultiPointConstraint` ties points rigidly to a centre point: the
section keeps its shape. A mirror plane of a periodic structure only keeps its points *on* a
plane; in the plane they are free (a cell inside a long module: the mid-plane of every
partition stays a plane section, and the partition and the bottom layer stretch in it as the
chamber balloons). :class:`PlaneTie` is that constraint, by the penalty

    Π = k/2 Σ_i g_i²,   g_i = n(θ) · x_i − (Y + s),   n(θ) = (0, cos θ, sin θ),

for the points ``x_i = X_i + u_i`` of the section y = Y: the plane's normal turns about the
x axis by θ (the x value of a rotation node, a node of no element) and the plane moves by s
along y (the y value of a centre node). Bending about x and axial stretch are what a straight
bending or stretching cell does; a tilted cell's sections turn about other axes and keep the
rigid tie.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp

__all__ = ["PlaneTie"]


class PlaneTie:
    """Points kept on a plane y = Y + s turned about x by θ (penalty ``k``).

    Parameters
    ----------
    points : ndarray (i,)
        Nodes of the section (all on y = Y in the reference state).
    center : int
        A node of no element whose y displacement is the plane's offset s (its x and z
        displacements do not enter: fix them).
    rotation : int
        A node of no element whose x displacement is the plane's turn θ (rad; fix y and z).
    multiplier : float
        The penalty k (force per length in the problem's units).
    mesh_points : ndarray (n, 3)
        Reference coordinates of the problem's nodes.

    The item has FElupe's interface (``assemble.vector(field=...)`` and
    ``assemble.matrix(field=...)`` on all DOF of a 3d displacement field), so
    :class:`~multimorph.fe.engine.PressureProblem` sums it like a FElupe tie. The matrix
    keeps its sparsity pattern along a path (explicit zeros are kept).
    """

    def __init__(self, points: np.ndarray, center: int, rotation: int, multiplier: float,
                 mesh_points: np.ndarray) -> None:
        self.points = np.asarray(points, dtype=np.int64)
        self.center, self.rotation = int(center), int(rotation)
        self.multiplier = float(multiplier)
        self.reference = np.asarray(mesh_points, dtype=float)[self.points]
        self.offset = float(self.reference[:, 1].mean())
        self.npoints = len(mesh_points)
        m = len(self.points)
        # DOF of every gradient entry: the point's y and z, the centre's y, the rotation's x
        dofs = np.empty((m, 4), dtype=np.int64)
        dofs[:, 0] = 3 * self.points + 1
        dofs[:, 1] = 3 * self.points + 2
        dofs[:, 2] = 3 * self.center + 1
        dofs[:, 3] = 3 * self.rotation
        self._dofs = dofs
        self._rows = np.repeat(dofs, 4, axis=1).ravel()
        self._cols = np.tile(dofs, (1, 4)).ravel()
        self.assemble = self

    def _state(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """(gap g_i, gradient (i, 4), x_i, θ) at the displacement ``values`` (n, 3)."""
        x = self.reference + values[self.points]
        s = values[self.center, 1]
        theta = values[self.rotation, 0]
        c, sn = np.cos(theta), np.sin(theta)
        g = c * x[:, 1] + sn * x[:, 2] - (self.offset + s)
        grad = np.empty((len(self.points), 4))
        grad[:, 0], grad[:, 1], grad[:, 2] = c, sn, -1.0
        grad[:, 3] = -sn * x[:, 1] + c * x[:, 2]
        return g, grad, x, theta

    def vector(self, field: Any) -> np.ndarray:
        """The penalty's force ∂Π/∂u on all DOF (flat, 3 per node)."""
        g, grad, _, _ = self._state(np.asarray(field[0].values))
        out = np.zeros(3 * self.npoints)
        np.add.at(out, self._dofs.ravel(), (self.multiplier * g[:, None] * grad).ravel())
        return out

    def matrix(self, field: Any) -> sp.csr_matrix:
        """The penalty's tangent ∂²Π/∂u² on all DOF (CSR, a fixed pattern)."""
        g, grad, x, theta = self._state(np.asarray(field[0].values))
        c, sn = np.cos(theta), np.sin(theta)
        k = self.multiplier
        blocks = k * grad[:, :, None] * grad[:, None, :]
        # g ∂²g: ∂²g/∂θ² = −n·x, ∂²g/∂θ∂u_y = −sin θ, ∂²g/∂θ∂u_z = cos θ
        blocks[:, 3, 3] += k * g * -(c * x[:, 1] + sn * x[:, 2])
        for j, d in ((0, -sn), (1, c)):
            blocks[:, 3, j] += k * g * d
            blocks[:, j, 3] += k * g * d
        n = 3 * self.npoints
        return sp.coo_matrix((blocks.ravel(), (self._rows, self._cols)), shape=(n, n)).tocsr()
