"""FE against exact solutions (physics-notes §3.3, §3.6); coarse meshes, each < 1 %."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("felupe")
pytest.importorskip("contique")

from multimorph.fe.analyses import (
    clamped_strip,
    clamped_strip_exact,
    thick_sphere,
    thick_sphere_exact,
    thick_sphere_limit,
)

pytestmark = pytest.mark.slow


def test_exact_formulas() -> None:
    # physics-notes §3.3 table: A/B = 0.5 -> λa* = 1.8281, Pmax/μ = 0.81642
    la, pm = thick_sphere_limit(0.5)
    assert la == pytest.approx(1.8281, abs=1e-4)
    assert pm == pytest.approx(0.81642, abs=1e-5)
    assert thick_sphere_exact(1.0, 0.5) == 0.0
    # §3.6: semicircle λ = π/2 gives P a/(μ H) = 1.31278
    assert float(clamped_strip_exact(np.pi / 2)) == pytest.approx(1.31278, abs=1e-5)


def test_thick_sphere_limit_pressure() -> None:
    """Neo-Hookean thick sphere A/B = 0.5 through its limit point (contique), 6×12 quads."""
    r = thick_sphere(0.5, n_radial=6, n_theta=12)
    assert r.kinematic.max() > 2.2  # the path went well past λa* = 1.83
    assert r.limit_fe == pytest.approx(r.limit_exact, rel=0.01)
    # and the whole path, not only its maximum (K = 5000 μ: compressibility ~0.1 %)
    sel = r.kinematic > 1.05
    assert np.allclose(r.pressure[sel], r.exact[sel], rtol=0.01)
    # the falling branch was traced: pressure drops after the maximum
    assert r.pressure[-1] < 0.99 * r.limit_fe


def test_clamped_strip_bulge() -> None:
    """Plane-strain strip, H/a = 0.01, 100×2 quads: membrane law within 1 % for φ ≥ 0.9.

    The membrane law neglects bending and the difference between the loaded (lower) face
    and the mid-surface, both O(H/a); at small φ bending dominates, so only large bulges
    are compared.
    """
    r = clamped_strip(0.01, n_span=100, n_thick=2, load=1.2)
    sel = r.kinematic >= 0.9
    assert sel.sum() >= 2
    assert np.allclose(r.pressure[sel], r.exact[sel], rtol=0.01)
