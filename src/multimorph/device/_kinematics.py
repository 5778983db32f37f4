r"""Rod kinematics: the shape of a device from the strains of its modules.

Each module is a rod segment of reference length L with constant strains in its own (body)
frame: an angular-rate vector :math:`\mathbf u = (u_1, u_2, u_3)` (rad/m) about the body
axes :math:`(\mathbf e_1, \mathbf e_2, \mathbf e_3)` and an axial stretch :math:`\lambda`.
The body axes follow the cell notation: :math:`\mathbf e_1 = x` (across the width),
:math:`\mathbf e_2 = y` (along the axis: the tangent), :math:`\mathbf e_3 = z` (up). So
:math:`u_1` bends in the y–z plane, :math:`u_3` bends in the x–y plane and :math:`u_2` is the
twist rate. Along the segment :math:`R' = R[\mathbf u]_\times`,
:math:`\mathbf r' = \lambda R \mathbf e_2`; for constant strains the segment's rigid transform is
the SE(3) exponential

.. math::
    T = \begin{pmatrix} e^{[\boldsymbol\omega]} & V(\boldsymbol\omega)\,\mathbf v \\ 0 & 1
    \end{pmatrix}, \quad \boldsymbol\omega = L\mathbf u,\ \mathbf v = \lambda L \mathbf e_2,
    \quad V = I + \frac{1-\cos\theta}{\theta^2}[\boldsymbol\omega]
          + \frac{\theta-\sin\theta}{\theta^3}[\boldsymbol\omega]^2 ,

and a chain of segments is the product of their transforms (in order from the base).
A bending cell whose top wall extends (positive cell curvature κ, stiff bottom inside) bends
toward −z: :math:`u_1 = -\kappa`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["RodStrains", "centerline", "chain", "frames_along", "segment_transform"]

E2 = np.array([0.0, 1.0, 0.0])


@dataclass(frozen=True)
class RodStrains:
    """Constant strains of one rod segment in its body frame.

    Parameters
    ----------
    length : float
        Reference length L (m).
    curvature : tuple of float
        Angular rates (u1, u2, u3) about the body axes x, y (tangent: twist), z (rad/m).
    stretch : float
        Axial stretch λ of the centre line (-).
    """

    length: float
    curvature: tuple[float, float, float] = (0.0, 0.0, 0.0)
    stretch: float = 1.0

    @classmethod
    def bend_twist(cls, length: float, *, bend: float = 0.0, twist: float = 0.0,
                   lateral_bend: float = 0.0, stretch: float = 1.0) -> RodStrains:
        """Segment from cell-style strains: ``bend`` κ (1/m, positive bends toward −z),
        ``twist`` (rad/m about the axis), ``lateral_bend`` (1/m, about z), ``stretch``."""
        return cls(length, (-float(bend), float(twist), float(lateral_bend)), float(stretch))


def _hat(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _so3_terms(w: np.ndarray) -> tuple[float, float, float]:
    """Coefficients a = sinθ/θ, b = (1−cosθ)/θ², c = (θ−sinθ)/θ³, series near θ = 0."""
    t2 = float(w @ w)
    t = np.sqrt(t2)
    if t < 1e-4:
        return 1.0 - t2 / 6.0 + t2 * t2 / 120.0, 0.5 - t2 / 24.0 + t2 * t2 / 720.0, (
            1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0)
    return np.sin(t) / t, (1.0 - np.cos(t)) / t2, (t - np.sin(t)) / (t2 * t)


def segment_transform(seg: RodStrains, s: float | None = None) -> np.ndarray:
    """4×4 rigid transform from a segment's start frame to its frame at arc length ``s``
    (reference length; default the whole segment)."""
    s = seg.length if s is None else float(s)
    w = np.asarray(seg.curvature, float) * s
    W = _hat(w)
    a, b, c = _so3_terms(w)
    R = np.eye(3) + a * W + b * W @ W
    V = np.eye(3) + b * W + c * W @ W
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = V @ (seg.stretch * s * E2)
    return T


def chain(segments: Sequence[RodStrains], base: np.ndarray | None = None) -> list[np.ndarray]:
    """Frames (4×4) at the start of the chain and at the end of every segment."""
    T = np.eye(4) if base is None else np.asarray(base, float)
    frames = [T]
    for seg in segments:
        T = T @ segment_transform(seg)
        frames.append(T)
    return frames


def frames_along(segments: Sequence[RodStrains], points_per_segment: int = 16,
                 base: np.ndarray | None = None) -> np.ndarray:
    """Rod frames (n, 4, 4) along the deformed chain: the start and ``points_per_segment``
    equal steps of reference length per segment. Columns 0–2 of each rotation are the body
    axes (e1 across the width, e2 the tangent, e3 up), column 3 the centre-line point (m):
    what a drawing needs to sweep a cross-section so that bend and twist show."""
    T = np.eye(4) if base is None else np.asarray(base, float)
    frames = [T.copy()]
    for seg in segments:
        for s in np.linspace(0.0, seg.length, points_per_segment + 1)[1:]:
            frames.append(T @ segment_transform(seg, s))
        T = T @ segment_transform(seg)
    return np.array(frames)


def centerline(segments: Sequence[RodStrains], points_per_segment: int = 16,
               base: np.ndarray | None = None) -> np.ndarray:
    """Points (n, 3) of the deformed centre line (m), for plots and animations."""
    return frames_along(segments, points_per_segment, base)[:, :3, 3]
