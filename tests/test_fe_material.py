"""The FE material adapter evaluates the package's own energy: FE stress = JAX stress."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("felupe")
pytest.importorskip("tensortrax")

from multimorph.fe._material import felupe_umat
from multimorph.materials import Material, nominal_stress

MATERIALS = [
    Material("neo-hooke", {"mu": 2.0e5}),
    Material("gent", {"mu": 1.0e5, "jm": 20.0}),
    Material("mooney-rivlin", {"c10": 4e4, "c01": 1e4}),
    Material("yeoh", {"c10": 5e4, "c20": -1e3, "c30": 50.0}),
    Material("ogden-2", {"mu1": 1.2e5, "alpha1": 2.5, "mu2": -1e4, "alpha2": -2.0}),
]


def _uniaxial_nominal_fe(material: Material, lam: float) -> float:
    """Uniaxial nominal stress from the FE umat at an isochoric uniaxial F.

    The umat returns the isochoric first Piola–Kirchhoff stress; the traction-free lateral
    faces fix the hydrostatic part: P11 − P22 λ2/λ1 (λ2 = λ^-1/2).
    """
    u = felupe_umat(material)
    F = np.diag([lam, lam**-0.5, lam**-0.5]).reshape(3, 3, 1, 1)
    P = u.gradient([F, None])[0]
    return float(P[0, 0, 0, 0] - P[1, 1, 0, 0] * lam**-0.5 / lam)


@pytest.mark.parametrize("material", MATERIALS, ids=lambda m: m.model)
@pytest.mark.parametrize("lam", [0.7, 1.3, 2.0, 3.0])
def test_uniaxial_stress_matches_jax(material: Material, lam: float) -> None:
    fe = _uniaxial_nominal_fe(material, lam)
    ref = float(nominal_stress(material, "uniaxial", lam))
    # same energy function, two AD engines: agreement to round-off (eigenvalue perturbation
    # in tensortrax's eigvalsh limits Ogden to ~1e-7 relative)
    assert fe == pytest.approx(ref, rel=1e-6, abs=1e-6 * material.shear_modulus)


@pytest.mark.parametrize("material", MATERIALS[:3], ids=lambda m: m.model)
def test_zero_stress_and_shear_modulus_at_identity(material: Material) -> None:
    u = felupe_umat(material)
    F = np.eye(3).reshape(3, 3, 1, 1)
    P = u.gradient([F, None])[0][..., 0, 0]
    assert np.allclose(P, 0.0, atol=1e-9 * material.shear_modulus)
    A = u.hessian([F, None])[0][..., 0, 0]
    # isochoric tangent at F = I: A_ijkl v_ij v_kl for simple shear = μ
    v = np.zeros((3, 3))
    v[0, 1] = 1.0
    assert np.einsum("ijkl,ij,kl->", A, v, v) == pytest.approx(material.shear_modulus,
                                                                 rel=1e-6)
