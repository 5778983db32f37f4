"""Physics of the energy laws: oracles, invariants, AD vs finite differences, moduli."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from multimorph.errors import LockupError
from multimorph.materials import LOAD_CASES, Material, drucker_stability, get_law, stretches

# One representative parameter set per law (SI). Chosen with positive small-strain modulus
# and, for the polynomial, a softening middle term as silicones show.
LAWS = {
    "neo-hooke": {"mu": 1.0e5},
    "mooney-rivlin": {"c10": 4.0e4, "c01": 1.0e4},
    "yeoh": {"c10": 5.0e4, "c20": -1.0e3, "c30": 1.0e2},
    "reduced-polynomial-6": {"c10": 5.0e4, "c20": -8.0e2, "c30": 60.0, "c40": -2.0,
                             "c50": 0.05, "c60": 1e-4},
    "gent": {"mu": 1.0e5, "jm": 30.0},
    "ogden-3": {"mu1": 6.3e5, "mu2": 1.2e3, "mu3": -1.0e4,
                "alpha1": 1.3, "alpha2": 5.0, "alpha3": -2.0},
    "arruda-boyce": {"mu": 1.0e5, "lambda_m": 5.0},
}
MATERIALS = {k: Material(k, v, name=k) for k, v in LAWS.items()}


def test_gent_oracle_values() -> None:
    # physics-notes §3.1: Gent mu = 1, Jm = 20 at lambda = 2, derived by hand from
    # P = 2 (lambda - ...) W1 with W1 = (mu/2)/(1 - (I1-3)/Jm); 6-digit tolerance
    gent = Material("gent", {"mu": 1.0, "jm": 20.0})
    expected = {"uniaxial": 1.94444, "equibiaxial": 2.63598, "pure_shear": 2.11268}
    for case, value in expected.items():
        assert float(gent.nominal_stress(case, 2.0)) == pytest.approx(value, abs=5e-6)


def test_gent_closed_form_matches_ad() -> None:
    # the closed forms for an I1 law, over a range of stretches
    mu, jm = 2.0e5, 25.0
    gent = Material("gent", {"mu": mu, "jm": jm})
    lam = np.linspace(0.6, 3.5, 30)
    shapes = {"uniaxial": (lam**2 + 2 / lam, lam - lam**-2.0),
              "equibiaxial": (2 * lam**2 + lam**-4.0, lam - lam**-5.0),
              "pure_shear": (lam**2 + 1 + lam**-2.0, lam - lam**-3.0)}
    for case, (i1, g) in shapes.items():
        w1 = 0.5 * mu / (1 - (i1 - 3) / jm)
        np.testing.assert_allclose(gent.nominal_stress(case, lam), 2 * g * w1, rtol=1e-12)


@pytest.mark.parametrize("model", list(LAWS))
@pytest.mark.parametrize("case", LOAD_CASES)
def test_zero_stress_at_identity(model: str, case: str) -> None:
    m = MATERIALS[model]
    assert abs(float(m.nominal_stress(case, 1.0))) < 1e-9 * m.shear_modulus


@pytest.mark.parametrize("model", list(LAWS))
def test_small_strain_modulus_matches_formula(model: str) -> None:
    # uniaxial: dP/dlambda at lambda = 1 equals Young's modulus 3 mu (incompressible)
    m = MATERIALS[model]
    h = 1e-5
    slope = (float(m.nominal_stress("uniaxial", 1 + h))
             - float(m.nominal_stress("uniaxial", 1 - h))) / (2 * h)
    assert slope == pytest.approx(3 * m.law.shear_modulus(m.params_1972), rel=1e-6)
    # pure shear (plane strain): slope 4 mu
    slope_ps = (float(m.nominal_stress("pure_shear", 1 + h))
                - float(m.nominal_stress("pure_shear", 1 - h))) / (2 * h)
    assert slope_ps == pytest.approx(4 * m.shear_modulus, rel=1e-6)


@pytest.mark.parametrize("model", list(LAWS))
@pytest.mark.parametrize("case", LOAD_CASES)
def test_ad_stress_equals_finite_differences(model: str, case: str) -> None:
    # nominal stress is the derivative of the energy per reference volume along the path
    # (equibiaxial: two loaded directions, hence the factor 1/2). Central differences,
    # h = 1e-6: truncation ~h^2, round-off ~eps W / h ~ 1e-10 relative.
    m = MATERIALS[model]
    h = 1e-6
    for lam in (0.7, 1.3, 2.0, 3.0):
        w = [float(m.energy(*stretches(case, lam + s * h))) for s in (1, -1)]
        fd = (w[0] - w[1]) / (2 * h) * (0.5 if case == "equibiaxial" else 1.0)
        ad = float(m.nominal_stress(case, lam))
        assert ad == pytest.approx(fd, rel=1e-6, abs=1e-6 * m.shear_modulus)


def _random_F(rng: np.random.Generator) -> np.ndarray:
    F = np.eye(3) + 0.4 * rng.standard_normal((3, 3))
    if np.linalg.det(F) < 0:
        F[:, 0] *= -1
    return F


def _rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q = q @ np.diag(np.sign(np.diag(r)))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    return q


@pytest.mark.parametrize("model", list(LAWS))
def test_objectivity_and_isotropy(model: str) -> None:
    m = MATERIALS[model]
    if model == "gent":
        m = Material("gent", {"mu": 1.0e5, "jm": 200.0})  # keep random F below lock-up
    rng = np.random.default_rng(7)
    for _ in range(5):
        F, Q = _random_F(rng), _rotation(rng)
        w = float(m.energy_isochoric_C(F.T @ F))
        # objectivity: a superposed rotation Q F leaves W unchanged
        QF = Q @ F
        assert float(m.energy_isochoric_C(QF.T @ QF)) == pytest.approx(w, rel=1e-9)
        # isotropy: rotating the reference configuration, F Q, leaves W unchanged
        FQ = F @ Q
        assert float(m.energy_isochoric_C(FQ.T @ FQ)) == pytest.approx(w, rel=1e-9)
        # and the tensor form agrees with the principal-stretch form
        J = np.linalg.det(F)
        lam = np.sqrt(np.linalg.eigvalsh(F.T @ F)) / J ** (1 / 3)
        assert float(m.energy_stretches(*lam)) == pytest.approx(w, rel=1e-8)


def test_ogden_convention_round_trip() -> None:
    m72 = MATERIALS["ogden-3"]
    ab = m72.to_convention("abaqus")
    assert ab.convention == "abaqus"
    # Abaqus mu_p = alpha_p mu_p(1972) / 2; the small-strain modulus is sum mu_p there
    assert ab.params["mu1"] == pytest.approx(0.5 * 1.3 * 6.3e5)
    assert sum(ab.params[f"mu{i}"] for i in (1, 2, 3)) == pytest.approx(m72.shear_modulus)
    back = ab.to_convention("ogden1972")
    for k, v in m72.params.items():
        assert back.params[k] == pytest.approx(v, rel=1e-14)
    lam = np.linspace(0.5, 5, 9)
    for case in LOAD_CASES:
        np.testing.assert_allclose(ab.nominal_stress(case, lam), m72.nominal_stress(case, lam),
                                   rtol=1e-12)
    assert Material.from_dict(ab.to_dict()) == ab


def test_gent_lockup_raises_not_nan() -> None:
    gent = Material("gent", {"mu": 1.0, "jm": 10.0}, name="g")
    lam_lock = 3.4  # uniaxial I1 - 3 = 3.4^2 + 2/3.4 - 3 = 9.15 ... just below; 3.5 above
    assert np.isfinite(gent.nominal_stress("uniaxial", lam_lock))
    for case in LOAD_CASES:
        with pytest.raises(LockupError, match="lock-up"):
            gent.nominal_stress(case, [1.5, 6.0])
    with pytest.raises(LockupError):
        gent.energy(*stretches("uniaxial", 4.0))


@settings(max_examples=25, deadline=None)
@given(mu=st.floats(1e3, 1e7), jm=st.floats(2.0, 500.0), frac=st.floats(0.01, 0.95),
       case=st.sampled_from(LOAD_CASES))
def test_gent_stress_sign_and_scaling(mu: float, jm: float, frac: float, case: str) -> None:
    # property: below lock-up the nominal stress has the sign of (lambda - 1), grows
    # with lambda, and scales linearly with the modulus
    gent = Material("gent", {"mu": mu, "jm": jm})
    lam_hi = 1.0 + frac * (math.sqrt(jm + 3.0) - 1.0) / 2.0
    lam_hi = min(lam_hi, 50.0)
    lam = np.linspace(1.0 / lam_hi, lam_hi, 21)
    lam = lam[gent.lockup_fraction(*stretches(case, lam)) < 0.99]
    p = gent.nominal_stress(case, lam)
    assert np.all(np.isfinite(p))
    assert np.all(np.sign(p[np.abs(lam - 1) > 1e-9]) == np.sign(lam - 1)[np.abs(lam - 1) > 1e-9])
    assert np.all(np.diff(p) > 0)
    # (round-off near lambda = 1, where the stress cancels, sets the absolute tolerance)
    np.testing.assert_allclose(gent.scaled(3.0).nominal_stress(case, lam), 3.0 * p, rtol=1e-10,
                               atol=1e-9 * mu)


def test_drucker_verdicts() -> None:
    assert drucker_stability(MATERIALS["gent"]).all_stable
    assert drucker_stability(MATERIALS["neo-hooke"]).all_stable
    # Mooney-Rivlin with a negative C01 loses stability at large stretch
    mr = Material("mooney-rivlin", {"c10": 5e4, "c01": -1e4})
    rep = drucker_stability(mr, (0.1, 10.0))
    assert not rep.all_stable
    assert any(t is not None and t > 1 for _, t in rep.first_unstable.values())


def test_registry_bounds_cover_every_law() -> None:
    for model, params in LAWS.items():
        law = get_law(model)
        assert set(law.param_names) == set(params)
        assert len(law.lower) == len(law.upper) == len(law.param_names)
