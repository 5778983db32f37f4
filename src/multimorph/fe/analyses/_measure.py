"""Measurements from node coordinates, as the reference paper did with its FE results.

Every function takes reference and deformed node coordinates (any consistent length unit)
and returns plain numbers, so it works for FE states and for tests with synthetic shapes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from multimorph.fe.mesh import REGION_NAMES

__all__ = ["StripStrain", "bend_and_twist", "chamber_volume", "circle_fit_curvature",
           "largest_stretch", "line_stretch", "peak_element", "peak_stretch", "peak_summary",
           "section_motion", "strip_strain", "unwrapped"]

# 2×2 Gauss points on [0, 1]² with weights 1/4
_G = 0.5 + np.array([-1.0, 1.0]) / (2.0 * np.sqrt(3.0))


def chamber_volume(x: np.ndarray, faces: np.ndarray, *, mirror_x: float | None = None,
                   ) -> float:
    """Volume enclosed by bilinear quad faces (divergence theorem, exact 2×2 Gauss).

    ``V = ∮ (x − x_s) n_x dA`` with the face normals pointing out of the enclosed region.
    With ``mirror_x`` given, the faces close the region together with the plane
    ``x = mirror_x`` (where the integrand vanishes) and the volume of both halves is returned.

    Parameters
    ----------
    x : ndarray (n, 3)
        Node coordinates.
    faces : ndarray (k, 4)
        Quads, counter-clockwise seen from outside the enclosed region.
    mirror_x : float, optional
        x of the mirror plane of a half model.
    """
    X = x[faces]  # (k, 4, 3)
    xs = 0.0 if mirror_x is None else mirror_x
    vol = 0.0
    for s in _G:
        for t in _G:
            N = np.array([(1 - s) * (1 - t), s * (1 - t), s * t, (1 - s) * t])
            dNs = np.array([-(1 - t), 1 - t, t, -t])
            dNt = np.array([-(1 - s), -s, s, 1 - s])
            p = np.einsum("a,kai->ki", N, X)
            a = np.einsum("a,kai->ki", dNs, X)
            b = np.einsum("a,kai->ki", dNt, X)
            n = np.cross(a, b)
            vol += 0.25 * np.sum((p[:, 0] - xs) * n[:, 0])
    return float(2.0 * vol if mirror_x is not None else vol)


def circle_fit_curvature(y: np.ndarray, z: np.ndarray) -> float:
    """Signed curvature of the least-squares circle through points (y_i, z_i).

    Algebraic (Kåsa) fit. The sign is positive when the line turns towards −z as y grows
    (the top outward, the bottom on the inside of the bend); 0 for a straight line.
    """
    y = np.asarray(y, float)
    z = np.asarray(z, float)
    chord = np.array([y[-1] - y[0], z[-1] - z[0]])
    length = float(np.hypot(*chord))
    normal = np.array([-chord[1], chord[0]]) / length
    sag = (y - y[0]) * normal[0] + (z - z[0]) * normal[1]
    if np.max(np.abs(sag)) < 1e-9 * length:
        return 0.0  # straight
    # centre (yc, zc) and radius from y² + z² + D y + E z + F = 0 (shifted for conditioning)
    ys, zs = y - y.mean(), z - z.mean()
    A = np.column_stack([ys, zs, np.ones_like(ys)])
    sol, *_ = np.linalg.lstsq(A, -(ys**2 + zs**2), rcond=None)
    D, E, F = sol
    r2 = D**2 / 4 + E**2 / 4 - F
    if not np.isfinite(r2) or r2 <= 0:
        return 0.0
    k = 1.0 / np.sqrt(r2)
    # turning direction: the sign of the sagitta relative to the chord's left normal
    turn = np.sign(np.sum(sag))
    return float(k if turn > 0 else -k)


def line_stretch(X: np.ndarray, x: np.ndarray) -> float:
    """Arc-length ratio of a polyline (deformed / reference)."""
    L0 = np.sum(np.linalg.norm(np.diff(X, axis=0), axis=1))
    L = np.sum(np.linalg.norm(np.diff(x, axis=0), axis=1))
    return float(L / L0)


def _kabsch(X: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The rotation R that best maps the centred points ``X`` onto ``x`` (Kabsch)."""
    Xc = X - X.mean(0)
    xc = x - x.mean(0)
    H = Xc.T @ xc
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T))
    D = np.diag([1.0, 1.0, d])
    return Vt.T @ D @ U.T


def section_motion(X: np.ndarray, x: np.ndarray, start: np.ndarray, end: np.ndarray,
                   mirror_x: float | None, Q: np.ndarray | None = None,
                   ) -> tuple[float, float, float]:
    """Bend and twist (rad) of section ``end`` relative to section ``start`` (node indices
    into the reference and deformed coordinates ``X``, ``x``) and the y–z chord of their
    node centroids (same length unit), in the frame whose axes are the columns of ``Q``
    (default the mesh frame).

    A half model's sections are completed by the mirror images (x → 2 x_m − x) of their nodes
    off the mirror plane ``mirror_x``, so the best-fit rotations are those of the whole
    sections, node for node: exactly about x, composing additively along a device, and
    equal to the whole model's.
    """
    def whole(P: np.ndarray, nodes: np.ndarray) -> np.ndarray:
        if Q is not None:
            P = P @ Q  # rows: coordinates along Q's columns
        if mirror_x is None:
            return P
        off = np.abs(X[nodes, 0] - mirror_x) > 1e-9 * max(abs(mirror_x), 1e-3)
        return np.concatenate([P, P[off] * [-1.0, 1.0, 1.0] + [2.0 * mirror_x, 0.0, 0.0]])

    Xs, xs = whole(X[start], start), whole(x[start], start)
    Xe, xe = whole(X[end], end), whole(x[end], end)
    Rs = _kabsch(Xs, xs)
    bend, twist = bend_and_twist(Xe, xe @ Rs)  # rows rotated by Rsᵀ: Rsᵀ R_e
    chord = float(np.linalg.norm(xe[:, 1:].mean(0) - xs[:, 1:].mean(0)))
    return bend, twist, chord


def unwrapped(angle: float, previous: float) -> float:
    """``angle`` (rad) shifted by whole turns to lie within half a turn of ``previous``: an
    angle continuous along a path (a module may bend or twist past ±180°)."""
    turn = 2.0 * math.pi
    return angle + turn * round((previous - angle) / turn)


def bend_and_twist(X: np.ndarray, x: np.ndarray) -> tuple[float, float]:
    """Bend angle about x and twist angle about the deformed axis of a cross-section (rad).

    The section's best-fit rotation R (Kabsch) maps the axis e_y to t = R e_y. The bend
    angle is the rotation of t in the y–z plane, positive towards −z (top outward); the
    twist is the rotation of R e_x about t, measured from e_x projected normal to t.
    """
    R = _kabsch(X, x)
    t = R[:, 1]
    bend = float(np.arctan2(-t[2], t[1]))
    b = R[:, 0]
    u = np.array([1.0, 0.0, 0.0]) - t[0] * t
    nu = np.linalg.norm(u)
    if nu < 1e-12:
        return bend, 0.0
    u /= nu
    twist = float(np.arctan2(np.dot(np.cross(u, b), t), np.dot(u, b)))
    return bend, twist


def largest_stretch(F: np.ndarray) -> np.ndarray:
    """Largest principal stretch at every quadrature point, shape (q, c), from F (3, 3, q, c).

    Closed form for the largest eigenvalue of C = FᵀF (the trigonometric solution of the
    characteristic cubic of a symmetric 3 × 3 matrix): six times faster than a batched
    ``eigvalsh`` at 21k points, equal to it within 1e-8 relative (tested). The worst case
    is two equal largest eigenvalues (equibiaxial stretch), where the cubic's angle is only
    accurate to O(√ε): 2e-9 relative there.
    """
    C = np.einsum("kiqc,kjqc->ijqc", F, F)
    q = (C[0, 0] + C[1, 1] + C[2, 2]) / 3.0
    B = C.copy()
    for i in range(3):
        B[i, i] -= q
    p = np.sqrt(np.einsum("ij...,ij...->...", B, B) / 6.0)
    detB = (B[0, 0] * (B[1, 1] * B[2, 2] - B[1, 2] * B[2, 1])
            - B[0, 1] * (B[1, 0] * B[2, 2] - B[1, 2] * B[2, 0])
            + B[0, 2] * (B[1, 0] * B[2, 1] - B[1, 1] * B[2, 0]))
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.where(p > 0, detB / (2.0 * p**3), 1.0)
    phi = np.arccos(np.clip(r, -1.0, 1.0)) / 3.0
    return np.sqrt(q + 2.0 * p * np.cos(phi))


def peak_stretch(F: np.ndarray) -> tuple[float, int, int]:
    """Largest principal stretch over quadrature points; returns (value, point, cell).

    Parameters
    ----------
    F : ndarray (3, 3, q, c)
        Deformation gradients.
    """
    ev = largest_stretch(F)
    q, c = np.unravel_index(np.argmax(ev), ev.shape)
    return float(ev[q, c]), int(q), int(c)


def peak_element(ev: np.ndarray, among: np.ndarray | None = None) -> int:
    """The element that carries the largest principal stretch ``ev`` (q, cells), over all
    elements or over the element indices ``among``."""
    cell_peak = ev.max(axis=0)
    if among is None:
        return int(np.argmax(cell_peak))
    return int(among[np.argmax(cell_peak[among])])


def peak_summary(path: Any) -> dict[str, Any]:
    """A path's last largest principal stretch, where it is (reference centroid of its
    element, m: ``extra["peak_location"]``) and that element's region, for JSON."""
    return {"peak_stretch": float(path.peak_stretch[-1]),
            "peak_location_m": [float(v) for v in path.extra["peak_location"][-1]],
            "peak_region": REGION_NAMES[int(path.extra["peak_region"][-1])]}


@dataclass(frozen=True)
class StripStrain:
    """Mean in-plane strain of a strip (x across, y along; small-strain measures, -).

    Attributes
    ----------
    gradient : ndarray (3, 3)
        Mean displacement gradient H = ∂u/∂X (rows u_x, u_y, u_z; columns x, y, z).
    shear : float
        Engineering shear γ = H_xy + H_yx: the change of the right angle between the strip's
        axis and its cross direction, positive when it closes.
    slope : float
        H_xy = ∂u_x/∂y, the lateral slope of the strip's centre line.
    axial : float
        H_yy = ∂u_y/∂y, the axial strain.
    lateral : float
        H_xx = ∂u_x/∂x, the strain across the strip.
    rotation : float
        (H_yx − H_xy)/2, the mean in-plane rotation (rad, about z).
    """

    gradient: np.ndarray
    shear: float
    slope: float
    axial: float
    lateral: float
    rotation: float


def strip_strain(X: np.ndarray, x: np.ndarray, weights: np.ndarray) -> StripStrain:
    """Mean displacement gradient of a strip by a weighted affine fit of its displacement.

    The displacement u = x − X of the given nodes (in practice: the nodes of two or more
    cross-sections of the strip, weighted by their share of the section area) is fitted by
    ``u ≈ a + H (X − X̄)`` in weighted least squares. For sections that share one layout
    across the strip (the cells of a module), H_xy is the slope of the lateral displacement
    of the sections' area centroids along the strip. A linear (small-strain) measure: a bend
    of the strip out of its plane enters only at second order.

    Parameters
    ----------
    X, x : ndarray (n, 3)
        Reference and deformed node coordinates (one length unit).
    weights : ndarray (n,)
        Non-negative weights (e.g. tributary areas).
    """
    w = np.asarray(weights, float)
    Xc = X - np.average(X, axis=0, weights=w)
    A = np.column_stack([np.ones(len(X)), Xc]) * np.sqrt(w)[:, None]
    b = (x - X) * np.sqrt(w)[:, None]
    sol, *_ = np.linalg.lstsq(A, b, rcond=None)
    H = sol[1:].T
    return StripStrain(gradient=H, shear=float(H[0, 1] + H[1, 0]), slope=float(H[0, 1]),
                       axial=float(H[1, 1]), lateral=float(H[0, 0]),
                       rotation=float(0.5 * (H[1, 0] - H[0, 1])))
