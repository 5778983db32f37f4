"""FE models of problems with exact solutions (the FE oracles of physics-notes §3).

* :func:`thick_sphere` — neo-Hookean thick spherical shell (inner radius A, outer B) under
  internal pressure, axisymmetric quads, traced through its pressure maximum by
  continuation. Exact: P/μ = 2/λb + 1/(2λb⁴) − 2/λa − 1/(2λa⁴), λb³ = 1 + (A/B)³(λa³ − 1).
* :func:`clamped_strip` — long strip (half-span a, thickness H) clamped along both edges,
  plane strain, bulging into a circular arc of half-angle φ. Exact (membrane limit):
  P a/(μ H) = (λ − λ⁻³) sin φ with λ = φ / sin φ.

Both run in units μ = 1 and return FE and exact numbers side by side.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from multimorph.fe._deps import require
from multimorph.fe.engine import (
    PathPoint,
    PressureProblem,
    continuation,
    make_solver,
    pressure_control,
)
from multimorph.materials import Material

__all__ = ["OracleResult", "clamped_strip", "clamped_strip_exact", "thick_sphere",
           "thick_sphere_exact", "thick_sphere_limit"]


@dataclass(frozen=True)
class OracleResult:
    """FE path of an oracle problem and the exact values at the same kinematics.

    Attributes
    ----------
    kinematic : ndarray
        λa (sphere) or φ (strip, rad) along the FE path.
    pressure : ndarray
        FE pressure (units of μ).
    exact : ndarray
        Exact pressure at the same kinematic value.
    limit_fe, limit_exact : float or None
        Largest pressure along the path (sphere), FE and exact.
    ndof : int
    """

    kinematic: np.ndarray
    pressure: np.ndarray
    exact: np.ndarray
    limit_fe: float | None
    limit_exact: float | None
    ndof: int


def thick_sphere_exact(lam_a: np.ndarray, ratio: float) -> np.ndarray:
    """Exact P/μ of a neo-Hookean thick sphere at inner stretch ``lam_a`` (A/B = ratio)."""
    lam_a = np.asarray(lam_a, float)
    lam_b = (1.0 + ratio**3 * (lam_a**3 - 1.0)) ** (1.0 / 3.0)
    return 2 / lam_b + 0.5 / lam_b**4 - 2 / lam_a - 0.5 / lam_a**4


def thick_sphere_limit(ratio: float) -> tuple[float, float]:
    """(λa*, P_max/μ) of the exact solution (golden-section search)."""
    from scipy.optimize import minimize_scalar

    res = minimize_scalar(lambda la: -thick_sphere_exact(la, ratio), bounds=(1.0, 5.0),
                          method="bounded", options={"xatol": 1e-10})
    return float(res.x), float(-res.fun)


def thick_sphere(ratio: float = 0.5, n_radial: int = 6, n_theta: int = 12, *,
                 lam_max: float = 2.6, bulk: float = 5000.0, solver: str = "auto",
                 ) -> OracleResult:
    """Inflate a neo-Hookean thick sphere (A/B = ratio, B = 1, μ = 1) past its limit point.

    A quarter of the meridian (axisymmetric quads, x the axis, y the radius) with mirror
    symmetry at the equator; arc-length continuation (contique) until λa = ``lam_max``.
    """
    fem = require("felupe")
    A, B = ratio, 1.0
    rho = np.linspace(A, B, n_radial + 1)
    theta = np.linspace(0.0, np.pi / 2, n_theta + 1)
    R, T = np.meshgrid(rho, theta, indexing="ij")
    pts = np.column_stack([(R * np.cos(T)).ravel(), (R * np.sin(T)).ravel()])
    idx = np.arange(pts.shape[0]).reshape(R.shape)
    cells = np.column_stack([idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(),
                             idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()])
    mesh = fem.Mesh(pts, cells, "quad")
    fixed = np.zeros_like(pts, dtype=bool)
    fixed[np.isclose(pts[:, 1], 0.0), 1] = True  # on the axis: no radial motion
    fixed[np.isclose(pts[:, 0], 0.0), 0] = True  # equator: mirror plane
    inner = np.isclose(np.hypot(pts[:, 0], pts[:, 1]), A)
    mat = Material("neo-hooke", {"mu": 1.0}, bulk_modulus=bulk)
    prob = PressureProblem(mesh, [(np.arange(len(cells)), mat)], inner, fixed,
                           kind="axisymmetric")
    probe = int(idx[0, -1])  # inner surface at the equator
    lam, pres = [1.0], [0.0]

    def record(pt: PathPoint) -> bool:
        prob.set_x(pt.x)
        la = (pts[probe, 1] + prob.values[probe, 1]) / A
        lam.append(la)
        pres.append(pt.pressure)
        return la >= lam_max

    linear_solver = make_solver(solver)
    try:
        run = pressure_control(prob, 0.5, linear_solver, dp0=0.1, on_point=record)
        continuation(prob, run.points[-1].pressure, linear_solver, dx_max=0.02, dp_max=0.02,
                     max_steps=300, on_point=record)
    finally:
        linear_solver.release()
    lam_a, p = np.array(lam), np.array(pres)
    exact = thick_sphere_exact(lam_a, ratio)
    return OracleResult(lam_a, p, exact, float(p.max()), thick_sphere_limit(ratio)[1],
                        int(prob.nfree))


def clamped_strip_exact(phi: np.ndarray) -> np.ndarray:
    """Exact P a/(μ H) of the neo-Hookean clamped strip at arc half-angle ``phi`` (rad)."""
    phi = np.asarray(phi, float)
    lam = phi / np.sin(phi)
    return (lam - lam**-3) * np.sin(phi)


def clamped_strip(thickness: float = 0.01, n_span: int = 200, n_thick: int = 2, *,
                  load: float = 1.2, bulk: float = 5000.0, solver: str = "auto",
                  ) -> OracleResult:
    """Inflate a clamped neo-Hookean strip (half-span a = 1, thickness H, plane strain).

    Half model x ∈ [0, a] (mirror at x = 0, clamped at x = a), pressure on the lower face up
    to P a/(μ H) = ``load``. The arc half-angle comes from the mid-surface deflection δ at
    the centre, φ = 2 atan(δ/a); the returned pressures are P a/(μ H).
    """
    fem = require("felupe")
    H = thickness
    x = np.linspace(0.0, 1.0, n_span + 1)
    y = np.linspace(0.0, H, n_thick + 1)
    X, Y = np.meshgrid(x, y, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel()])
    idx = np.arange(pts.shape[0]).reshape(X.shape)
    cells = np.column_stack([idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(),
                             idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()])
    mesh = fem.Mesh(pts, cells, "quad")
    fixed = np.zeros_like(pts, dtype=bool)
    fixed[np.isclose(pts[:, 0], 0.0), 0] = True
    fixed[np.isclose(pts[:, 0], 1.0)] = True
    bottom = np.isclose(pts[:, 1], 0.0)
    mat = Material("neo-hooke", {"mu": 1.0}, bulk_modulus=bulk)
    prob = PressureProblem(mesh, [(np.arange(len(cells)), mat)], bottom, fixed,
                           kind="plane_strain")
    mid = idx[0, :]
    phis, pres = [0.0], [0.0]

    def record(pt: PathPoint) -> bool:
        prob.set_x(pt.x)
        delta = float(np.mean(prob.values[mid, 1]))
        phis.append(2.0 * np.arctan(delta))
        pres.append(pt.pressure / H)
        return False

    def stop(pt: PathPoint) -> bool:
        record(pt)
        return pt.pressure >= load * H

    # a thin strip is bending-soft: its first micro-pressure already deflects it by many
    # thicknesses, so trace the path by continuation from the flat state
    linear_solver = make_solver(solver)
    try:
        continuation(prob, 0.0, linear_solver, dx_max=0.02, dp_max=load * H / 10, max_steps=400,
                     on_point=stop)
    finally:
        linear_solver.release()
    phi, p = np.array(phis), np.array(pres)
    with np.errstate(invalid="ignore", divide="ignore"):
        exact = np.where(phi > 0, clamped_strip_exact(np.maximum(phi, 1e-12)), 0.0)
    return OracleResult(phi, p, exact, None, None, int(prob.nfree))
