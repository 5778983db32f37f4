"""IFT sensitivities of traced cell paths against finite differences of re-traced paths.

The IFT gives, from derivatives at each path point alone, how the point moves when a cell
length changes; the oracle re-traces the whole path at G ± h and compares at the same
pressures (interpolated) or compares the re-estimated Pc and Ph. One compiled kernel (Gent
walls and bottom, default options) serves every case; its first compilation dominates.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

import multimorph  # noqa: F401  (float64)
from _cells import MU, ref_cell
from multimorph.errors import SpecError
from multimorph.rom import (
    LENGTHS,
    characteristic_sensitivity,
    path_sensitivity,
    solve_cell,
)

pytestmark = pytest.mark.slow

P_MAX = 1.2 * MU


@pytest.fixture(scope="module")
def reference():
    cell = ref_cell()
    r = solve_cell(cell, P_MAX)
    return cell, r, path_sensitivity(cell, r.path)


def retraced(name: str, value: float):
    return solve_cell(ref_cell(**{name: value}), P_MAX)


@pytest.mark.parametrize("name", ["length", "width", "top_wall", "side_wall"])
def test_curvature_at_fixed_pressure_matches_retraced_paths(reference, name):
    """dκ_i/dG at fixed P_i = −K⁻¹ ∂R/∂G vs central differences of re-traced paths.

    Tolerance 2e-3 of the largest |dκ/dG|: the central difference (h = 1 % of G) has a
    truncation error ~1e-4 relative, and interpolating each re-traced path (its own adaptive
    nodes, ~0.02-0.1 apart in scaled arc length) at the reference pressures by a cubic spline
    adds ~1e-4; measured agreement 3e-4 (top wall).
    """
    cell, r, s = reference
    j = LENGTHS.index(name)
    g = getattr(cell, name)
    h = 0.01 * g
    rp, rm = retraced(name, g + h), retraced(name, g - h)
    P = r.path.pressure[1:-1]
    fd = (CubicSpline(rp.path.pressure, rp.path.curvature)(P)
          - CubicSpline(rm.path.pressure, rm.path.curvature)(P)) / (2 * h)
    ift = s.curvature_at_pressure[1:-1, j]
    assert s.regular.all()                      # no limit point on this path
    assert np.all(np.isfinite(ift))
    np.testing.assert_allclose(ift, fd, rtol=0, atol=2e-3 * np.max(np.abs(fd)))


def test_normal_motion_is_the_fixed_pressure_motion_slid_along_the_path(reference):
    """The normal motion of a node plus a slide along the tangent is its motion at fixed
    pressure: δκ_P = δκ_n − (dκ/dP) δP_n, with dκ/dP taken from the path itself; the last
    node moves at fixed pressure (the trace ends at p_max)."""
    _, r, s = reference
    P, k = r.path.pressure, r.path.curvature
    slope = np.gradient(k, P)
    inner = slice(5, len(P) - 5)
    fixed = s.curvature[inner] - slope[inner, None] * s.pressure[inner]
    scale = np.max(np.abs(s.curvature_at_pressure), axis=0)
    # np.gradient's slope is second-order accurate on the path's nodes: ~1e-3 measured
    assert np.all(np.abs(fixed - s.curvature_at_pressure[inner]) <= 1e-2 * scale)
    assert np.all(s.pressure[-1] == 0.0)
    np.testing.assert_array_equal(s.curvature[-1], s.curvature_at_pressure[-1])


@pytest.mark.parametrize("name", ["width", "top_wall", "side_wall", "end_wall"])
def test_pc_ph_sensitivities_match_retraced(reference, name):
    """dPc/dG and dPh/dG of the estimators on the linearised path vs re-traced Pc and Ph.

    The estimators are applied to curves whose nodes are fixed (linearised path) while a
    re-traced path has its own adaptive nodes, so the two differ by the derivative of the
    estimators' discretisation error: 1-4 % measured on this cell. Tolerance: 8 % of the
    derivative, or 0.01 in elasticity (G/Pc)·dPc/dG where the derivative itself is small.
    """
    cell, r, s = reference
    G = np.array([getattr(cell, k) for k in LENGTHS])
    cs = characteristic_sensitivity(r.path, s, G)
    j = LENGTHS.index(name)
    g = G[j]
    h = 0.02 * g
    rp, rm = retraced(name, g + h), retraced(name, g - h)
    ch = r.characteristic
    for key, p0 in (("critical", ch.critical), ("hardening", ch.hardening)):
        fd = (getattr(rp.characteristic, key) - getattr(rm.characteristic, key)) / (2 * h)
        ift = cs[key][j]
        assert abs(ift - fd) <= max(0.08 * abs(fd), 0.01 * p0 / g), (key, ift, fd)
    # the physics: thicker top and side walls delay the ballooning; wider cells advance it
    sign = -1.0 if name == "width" else 1.0
    assert sign * cs["critical"][j] > 0 and sign * cs["hardening"][j] > 0


def test_needs_reduced_model_coordinates(reference):
    cell, r, _ = reference
    from dataclasses import replace

    bare = replace(r.path, extra={})
    with pytest.raises(SpecError, match="extra\\['q'\\]"):
        path_sensitivity(cell, bare)
