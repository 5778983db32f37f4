"""The FE material adapter evaluates the package's own energy: FE stress = JAX stress."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("felupe")
pytest.importorskip("tensortrax")

from multimorph.fe.engine import felupe_umat
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


@pytest.mark.parametrize("material", [m for m in MATERIALS if m.law.variables == "invariants"]
                         + [Material("arruda-boyce", {"mu": 1.0e5, "lambda_m": 3.0})],
                         ids=lambda m: m.model)
def test_analytic_invariant_tangent_equals_the_tensor_route(material: Material) -> None:
    """Invariant laws take the analytic-kinematics route; it must equal tensortrax's AD of
    the whole W(C) (the same energy function) to round-off, at general (compressible,
    non-symmetric) F."""
    import felupe as fem

    from multimorph.fe.engine import TENSORTRAX_MATH, InvariantHyperelastic

    u = felupe_umat(material)
    assert isinstance(u, InvariantHyperelastic)
    ref = fem.Hyperelastic(lambda C: material.energy_isochoric_C(C, TENSORTRAX_MATH))
    rng = np.random.default_rng(7)
    F = np.eye(3)[:, :, None, None] + 0.15 * rng.standard_normal((3, 3, 4, 50))
    assert np.all(np.linalg.det(np.moveaxis(F, (0, 1), (-2, -1))) > 0.2)
    P, P0 = u.gradient([F, None])[0], ref.gradient([F, None])[0]
    A, A0 = u.hessian([F, None])[0], ref.hessian([F, None])[0]
    assert P.shape == P0.shape and A.shape == A0.shape
    assert np.abs(P - P0).max() <= 1e-12 * np.abs(P0).max()
    assert np.abs(A - A0).max() <= 1e-12 * np.abs(A0).max()
    # major symmetry A_iJkL = A_kLiJ (a hyperelastic tangent)
    assert np.allclose(A, A.transpose(2, 3, 0, 1, 4, 5), rtol=0, atol=1e-12 * np.abs(A).max())


def test_principal_stretch_laws_keep_the_tensor_route() -> None:
    from multimorph.fe.engine import InvariantHyperelastic

    assert not isinstance(felupe_umat(MATERIALS[-1]), InvariantHyperelastic)
