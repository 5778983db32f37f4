"""Known-answer cases for the path tracer and the cell model (physics-notes §3).

* clamped plane-strain strip (§3.6): the cell model with every wall but the top rigid;
* thin Gent sphere (§3.2) and closed-end thin Gent tube (§3.4): the limit point exists only
  above Jm ≈ 17.64 (sphere) and ≈ 18.23 (tube); found here by bisection on the tracer's
  limit-point detection (sign change of dp/ds along the path);
* thin neo-Hookean sphere: limit point at λ = 7^(1/6), P R/(μ H) = 1.23946.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

import multimorph  # noqa: F401  (float64)
from multimorph.geometry import CellGeometry
from multimorph.materials import Material
from multimorph.rom import ContinuationError, RomOptions, TracerSettings, solve_cell, trace_path

FINE = TracerSettings(ds0=0.01, ds_max=0.02, n_steps=600)


def gent_sphere(q, p, th):
    """Thin Gent sphere, Π/(4π R² H μ); p = P R/(μ H), q = (λ,)."""
    lam = q[0]
    i1 = 2 * lam**2 + lam**-4
    return -0.5 * th["jm"] * jnp.log(1 - (i1 - 3) / th["jm"]) - p * (lam**3 - 1) / 3


def gent_sphere_lock(q, th):
    lam = q[0]
    return (2 * lam**2 + lam**-4 - 3) / th["jm"]


def gent_tube(q, p, th):
    """Closed-end thin Gent tube, Π/(2π R H L μ); p = P R/(μ H), q = (λθ, λz)."""
    lt, lz = q[0], q[1]
    i1 = lt**2 + lz**2 + (lt * lz) ** -2
    return -0.5 * th["jm"] * jnp.log(1 - (i1 - 3) / th["jm"]) - 0.5 * p * (lt**2 * lz - 1)


def gent_tube_lock(q, th):
    lt, lz = q[0], q[1]
    return (lt**2 + lz**2 + (lt * lz) ** -2 - 3) / th["jm"]


def neo_sphere(q, p, th):
    lam = q[0]
    return 0.5 * (2 * lam**2 + lam**-4 - 3) - p * (lam**3 - 1) / 3


def _has_limit(energy, lock, q0, jm):
    raw = trace_path(energy, q0, {"jm": jnp.asarray(jm)}, 3.0, settings=FINE, admissible=lock)
    assert np.all(np.isfinite(raw.q)) and np.all(np.isfinite(raw.p))
    return raw.limit_points().size > 0, raw


def _threshold(energy, lock, q0, lo, hi, tol=0.02):
    assert not _has_limit(energy, lock, q0, lo)[0]
    assert _has_limit(energy, lock, q0, hi)[0]
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if _has_limit(energy, lock, q0, mid)[0]:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def test_gent_sphere_threshold():
    # physics-notes §3.2: the limit point disappears below Jm* = 17.638
    jm = _threshold(gent_sphere, gent_sphere_lock, [1.0], 16.5, 19.0)
    assert jm == pytest.approx(17.638, rel=5e-3)


def test_gent_tube_threshold():
    # physics-notes §3.4: closed ends, free axially; threshold 18.23 (not the sphere's 17.64)
    jm = _threshold(gent_tube, gent_tube_lock, [1.0, 1.0], 17.0, 19.5)
    assert jm == pytest.approx(18.23, rel=5e-3)


def test_gent_sphere_limit_and_hysteresis_values():
    # physics-notes §3.8, Jm = 30: P_max 1.2926 at λ 1.4451, P_min 1.1575 at λ 2.3180
    has, raw = _has_limit(gent_sphere, gent_sphere_lock, [1.0], 30.0)
    assert has
    i_max = int(np.argmax(np.where(raw.q[:, 0] < 2.0, raw.p, -1)))
    upper = raw.q[:, 0] > 1.8
    i_min = int(np.flatnonzero(upper)[np.argmin(raw.p[upper & (raw.q[:, 0] < 3)])])
    assert raw.p[i_max] == pytest.approx(1.2926, rel=1e-3)
    assert raw.p[i_min] == pytest.approx(1.1575, rel=1e-3)
    # unstable exactly on the falling branch (Hessian at fixed pressure)
    falling = (raw.q[:, 0] > 1.47) & (raw.q[:, 0] < 2.29)
    assert not raw.stable[falling].any()
    assert raw.stable[raw.q[:, 0] < 1.42].all() and raw.stable[raw.q[:, 0] > 2.35].all()


def test_neo_hooke_sphere_limit_point_and_runaway_error():
    raw = trace_path(neo_sphere, [1.0], {}, 1.2, settings=FINE)
    assert raw.ok and raw.stable.all()
    # beyond the limit point there is no equilibrium: a clear error, not NaN
    with pytest.raises(ContinuationError, match=r"p = .*of 1\.3"):
        trace_path(neo_sphere, [1.0], {}, 1.3, settings=TracerSettings(n_steps=150))
    raw = trace_path(neo_sphere, [1.0], {}, 1.3, settings=FINE, raise_on_failure=False)
    i = int(np.argmax(raw.p))
    assert raw.p[i] == pytest.approx(12 / 7 * 7 ** (-1 / 6), rel=1e-4)
    assert raw.q[i, 0] == pytest.approx(7 ** (1 / 6), rel=2e-2)
    assert np.all(np.isfinite(raw.q))


def test_gent_far_past_lockup_never_nan():
    # a huge pressure drives the sphere towards lock-up: the tracer stays admissible
    raw = trace_path(gent_sphere, [1.0], {"jm": jnp.asarray(5.0)}, 200.0,
                     admissible=gent_sphere_lock,
                     settings=TracerSettings(ds_max=5.0, n_steps=300))
    lam = raw.q[:, 0]
    assert raw.ok and np.all(np.isfinite(lam))
    assert np.all((2 * lam**2 + lam**-4 - 3) / 5.0 < 1.0)


# ----------------------------------------------------------------- clamped strip (§3.6)
def _strip_cell(jm: float, dc_over_wc: float = 99.0) -> CellGeometry:
    m = Material("gent", {"mu": 1.0e5, "jm": jm})
    wc, ht = 0.01, 5e-5                       # half-span a = 5 mm, H/a = 0.01
    d = wc * dc_over_wc + 2 * 0.005
    return CellGeometry(d, wc + 0.01, 0.02, ht, 0.005, 0.005, 0.005, material=m)


def _strip_pressure(phi, jm, a, H, mu):
    lam = phi / np.sin(phi)
    return mu * H / a * (lam - lam**-3) * np.sin(phi) / (1 - (lam**2 + lam**-2 - 2) / jm)


@pytest.mark.slow  # compiles the cell kernel
@pytest.mark.parametrize("jm", [10.0, 30.0])
def test_rigid_walls_plane_strain_is_the_exact_strip(jm):
    cell = _strip_cell(jm)
    opts = RomOptions(rigid_walls=True, end_taper=False, wall_bending=False)
    r = solve_cell(cell, 0.02 * cell.mu, options=opts)
    phi = r.path.extra["q"][:, 1]
    P = r.path.pressure
    sel = phi > 1e-3
    exact = _strip_pressure(phi[sel], jm, 0.5 * cell.chamber_width, cell.top_wall, cell.mu)
    # exact up to the corrector tolerance (1e-9 of the load vector of 0.2 μ)
    np.testing.assert_allclose(P[sel], exact, rtol=1e-5)
    assert np.all(r.path.curvature == 0.0)


@pytest.mark.slow  # compiles the cell kernel
def test_rigid_walls_long_chamber_within_two_percent_of_strip():
    # the default model (bulge tapering to the end walls, plate bending of the wall) with every
    # wall but the top rigid, on a long thin-walled chamber (dc = 99 wc, H/a = 0.01): along the
    # path (phi >= 0.15) the mid-chamber bulge obeys the strip law within 2 %
    jm = 20.0
    cell = _strip_cell(jm)
    r = solve_cell(cell, 0.025 * cell.mu, options=RomOptions(rigid_walls=True))
    phi = r.path.extra["q"][:, 1]
    sel = phi > 0.15
    assert sel.sum() > 10 and phi.max() > 2.0
    exact = _strip_pressure(phi[sel], jm, 0.5 * cell.chamber_width, cell.top_wall, cell.mu)
    err = np.abs(r.path.pressure[sel] / exact - 1)
    assert err.max() < 0.02
