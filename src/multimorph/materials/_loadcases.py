r"""Homogeneous load cases of an incompressible material, and Drucker stability.

Stretch states (loading direction 1, direction 3 traction-free):

=============  ==========================  ============================================
case           stretches                    nominal stress :math:`P_1`
=============  ==========================  ============================================
uniaxial       (λ, λ^-1/2, λ^-1/2)          :math:`dw/dλ`, :math:`w(λ) = W(λ, λ^{-1/2}, λ^{-1/2})`
equibiaxial    (λ, λ, λ^-2)                 :math:`\tfrac12\, dw/dλ`, :math:`w = W(λ, λ, λ^{-2})`
pure shear     (λ, 1, λ^-1)                 :math:`dw/dλ`, :math:`w = W(λ, 1, λ^{-1})`
=============  ==========================  ============================================

The energy route (virtual work per reference volume) gives the nominal stress by automatic
differentiation of the one energy function; no law carries its own stress formula.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Any, Protocol

import jax
import jax.numpy as jnp
import numpy as np

from multimorph.errors import SpecError
from multimorph.materials._math import JAX_MATH
from multimorph.materials._registry import Law, get_law


class LoadCaseMaterial(Protocol):
    """What a load case needs of a material (:class:`~multimorph.materials.Material` is
    one): its law, its parameters in the Ogden 1972 convention and the lock-up guard."""

    model: str

    @property
    def params_1972(self) -> dict[str, float]: ...

    def lockup_fraction(self, l1: Any, l2: Any, l3: Any) -> np.ndarray: ...

    def check_lockup(self, l1: Any, l2: Any, l3: Any, what: str = "") -> None: ...


__all__ = [
    "LOAD_CASES",
    "LoadCaseMaterial",
    "StabilityReport",
    "drucker_stability",
    "nominal_stress",
    "stress_function",
    "stretches",
]

LOAD_CASES = ("uniaxial", "equibiaxial", "pure_shear")
_ALIASES = {"ut": "uniaxial", "uniaxial": "uniaxial", "tension": "uniaxial",
            "et": "equibiaxial", "equibiaxial": "equibiaxial", "biaxial": "equibiaxial",
            "ps": "pure_shear", "pure_shear": "pure_shear", "pure-shear": "pure_shear",
            "planar": "pure_shear", "pureshear": "pure_shear"}
_WEIGHT = {"uniaxial": 1.0, "equibiaxial": 0.5, "pure_shear": 1.0}


def canonical_case(case: str) -> str:
    """Normalise a load-case name (``"UT"``, ``"pure-shear"``, ``"planar"`` …)."""
    key = str(case).strip().lower().replace(" ", "_")
    if key not in _ALIASES:
        raise SpecError(f"unknown load case {case!r}; expected one of {', '.join(LOAD_CASES)}")
    return _ALIASES[key]


def stretches(case: str, lam: Any) -> tuple[Any, Any, Any]:
    """Principal stretches of ``case`` at loading stretch ``lam`` (works on JAX arrays)."""
    case = canonical_case(case)
    if case == "uniaxial":
        t = lam**-0.5
        return lam, t, t
    if case == "equibiaxial":
        return lam, lam, lam**-2.0
    return lam, 1.0 + 0.0 * lam, 1.0 / lam


def _energy(law: Law, p: dict[str, Any], l1: Any, l2: Any, l3: Any) -> Any:
    if law.variables == "stretches":
        return law.energy(l1, l2, l3, xp=JAX_MATH, **p)
    a, b, c = l1 * l1, l2 * l2, l3 * l3
    return law.energy(a + b + c, a * b + b * c + c * a, xp=JAX_MATH, **p)


@cache
def stress_function(model: str, case: str) -> Callable[[dict[str, Any], Any], Any]:
    """Jitted ``f(params_1972, lam) -> nominal stress`` for a law and load case (JAX, AD).

    ``params_1972`` is a dict of scalars (Ogden in the 1972 convention); ``lam`` an array.
    """
    law = get_law(model)
    case = canonical_case(case)
    w = _WEIGHT[case]

    def w_of(lam: Any, p: dict[str, Any]) -> Any:
        return _energy(law, p, *stretches(case, lam))

    dw = jax.grad(w_of, argnums=0)

    @jax.jit
    def f(p: dict[str, Any], lam: Any) -> Any:
        lam = jnp.asarray(lam, dtype=jnp.float64)
        return w * jax.vmap(dw, in_axes=(0, None))(jnp.ravel(lam), p).reshape(lam.shape)

    return f


def nominal_stress(material: LoadCaseMaterial, case: str, stretch: Any) -> np.ndarray:
    """Nominal (first Piola–Kirchhoff) stress (Pa) of ``material`` in ``case``.

    Parameters
    ----------
    material : Material
    case : {"uniaxial", "equibiaxial", "pure_shear"}
    stretch : array_like
        Loading stretch λ (-), > 0.

    Raises
    ------
    LockupError
        If any stretch reaches Gent's lock-up (never returns NaN for that reason).

    Examples
    --------
    >>> from multimorph.materials import Material
    >>> gent = Material("gent", {"mu": 1.0, "jm": 20.0})
    >>> [round(float(gent.nominal_stress(c, 2.0)), 5)
    ...  for c in ("uniaxial", "equibiaxial", "pure_shear")]
    [1.94444, 2.63598, 2.11268]
    """
    case = canonical_case(case)
    lam = np.asarray(stretch, dtype=float)
    if np.any(~(lam > 0)):
        raise SpecError(f"{case}: stretches must be positive numbers")
    material.check_lockup(*(np.asarray(stretch_i) for stretch_i in stretches(case, lam)), what=case)
    out = stress_function(material.model, case)(material.params_1972, lam)
    return np.asarray(out)


@dataclass(frozen=True)
class StabilityReport:
    """Drucker stability of a material per load case over a stretch range.

    ``stable[case]`` is True when the material is Drucker-stable over the whole range in
    that case; ``first_unstable[case]`` gives (compression, tension) stretches nearest to 1 at
    which stability is first lost (``None`` when it is not).
    """

    stretch_range: tuple[float, float]
    stable: dict[str, bool]
    first_unstable: dict[str, tuple[float | None, float | None]]

    @property
    def all_stable(self) -> bool:
        return all(self.stable.values())

    def to_dict(self) -> dict[str, Any]:
        return {"stretch_range": list(self.stretch_range), "stable": dict(self.stable),
                "first_unstable": {k: list(v) for k, v in self.first_unstable.items()}}


@cache
def _drucker_eigs(model: str) -> Callable[[dict[str, Any], Any], Any]:
    """Jitted smallest Hessian eigenvalue of W(e1, e2) at log strains ``e`` (shape (N, 2)).

    One kernel per law serves every load case (the case only decides the log strains), so
    a stability check compiles once per law.
    """
    law = get_law(model)

    def wt(e: Any, p: dict[str, Any]) -> Any:
        # energy of the two independent log strains (incompressible: e3 = -e1 - e2)
        return _energy(law, p, jnp.exp(e[0]), jnp.exp(e[1]), jnp.exp(-e[0] - e[1]))

    hess = jax.hessian(wt, argnums=0)

    @jax.jit
    def f(p: dict[str, Any], e: Any) -> Any:
        H = jax.vmap(hess, in_axes=(0, None))(e, p)
        # eigenvalues of the symmetric 2x2 Hessians, explicitly
        a, b, c = H[:, 0, 0], H[:, 0, 1], H[:, 1, 1]
        return 0.5 * (a + c) - jnp.sqrt(0.25 * (a - c) ** 2 + b * b)

    return f


def drucker_stability(
    material: LoadCaseMaterial,
    stretch_range: tuple[float, float] = (0.1, 10.0),
    n: int = 400,
) -> StabilityReport:
    r"""Drucker stability check per load case over ``stretch_range`` (Abaqus-style).

    Drucker's postulate :math:`d\sigma : d\varepsilon > 0` (Cauchy stress, logarithmic strain)
    for an incompressible isotropic material with coaxial increments reads: the Hessian of
    :math:`\tilde W(\varepsilon_1, \varepsilon_2) = W(e^{\varepsilon_1}, e^{\varepsilon_2},
    e^{-\varepsilon_1-\varepsilon_2})` is positive definite. It is checked at every stretch
    of each load case, in compression (λ < 1) and tension (λ > 1). Points beyond a Gent
    lock-up are outside the material's domain and are not checked.
    """
    lo, hi = float(stretch_range[0]), float(stretch_range[1])
    if not 0 < lo < 1 < hi:
        raise SpecError(f"stretch_range must satisfy 0 < low < 1 < high, got {stretch_range}")
    lam_c = np.geomspace(1.0, lo, n // 2)[1:]
    lam_t = np.geomspace(1.0, hi, n // 2)[1:]
    # every case and direction in one fixed-size evaluation (points past a Gent lock-up are
    # replaced by λ = 1 and ignored), so the kernel is traced once per law, not per Jm
    blocks = [(case, lam) for case in LOAD_CASES for lam in (lam_c, lam_t)]
    valid, strains = [], []
    for case, lam in blocks:
        ok_pts = material.lockup_fraction(*stretches(case, lam)) < 0.999
        l1, l2, _ = stretches(case, np.where(ok_pts, lam, 1.0))
        valid.append(ok_pts)
        strains.append(np.stack([np.log(l1), np.log(l2 + 0.0 * l1)], axis=-1))
    eig = np.asarray(_drucker_eigs(material.model)(material.params_1972,
                                                    np.concatenate(strains)))
    eig = eig.reshape(len(blocks), -1)
    stable: dict[str, bool] = {}
    first: dict[str, tuple[float | None, float | None]] = {}
    for k, case in enumerate(LOAD_CASES):
        out: list[float | None] = []
        for j in (2 * k, 2 * k + 1):
            lam = blocks[j][1]
            bad = np.flatnonzero(valid[j] & ~(eig[j] > 0))
            out.append(float(lam[bad[0]]) if bad.size else None)
        stable[case] = out[0] is None and out[1] is None
        first[case] = (out[0], out[1])
    return StabilityReport((lo, hi), stable, first)
