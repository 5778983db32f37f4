"""Material adapter: the package's one energy law, evaluated by tensortrax inside FElupe.

:meth:`multimorph.materials.Material.energy_isochoric_C` evaluates a law from the right
Cauchy–Green tensor through a small math namespace ``xp``. :class:`TensortraxMath` supplies
that namespace over ``tensortrax.math``, so FElupe gets the gradient and Hessian of *the same*
function that the reduced model and the fits differentiate with JAX. No formula is repeated
here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from multimorph.fe._deps import require
from multimorph.materials import Material

__all__ = ["TensortraxMath", "felupe_umat"]


@dataclass(frozen=True)
class TensortraxMath:
    """The energy namespace (``log, exp, sqrt, where, trace, det, second_invariant,
    eigvalsh``) over ``tensortrax.math`` for tensors of shape (3, 3) (trailing axes hidden)."""

    def _tm(self) -> Any:
        return require("tensortrax.math")

    def log(self, x: Any) -> Any:
        return self._tm().log(x)

    def exp(self, x: Any) -> Any:
        return self._tm().exp(x)

    def sqrt(self, x: Any) -> Any:
        return self._tm().sqrt(x)

    def where(self, c: Any, a: Any, b: Any) -> Any:
        return self._tm().if_else(c, a, b)

    def trace(self, C: Any) -> Any:
        return self._tm().trace(C)

    def det(self, C: Any) -> Any:
        return self._tm().linalg.det(C)

    def second_invariant(self, C: Any) -> Any:
        tm = self._tm()
        trC = tm.trace(C)
        return 0.5 * (trC**2 - tm.trace(tm.dot(C, C)))

    def eigvalsh(self, C: Any) -> Any:
        return self._tm().linalg.eigvalsh(C)


TENSORTRAX_MATH = TensortraxMath()


def felupe_umat(material: Material, *, parallel: bool = False) -> Any:
    """FElupe constitutive model of the isochoric energy of ``material`` (tensortrax AD).

    The volumetric part is added by the nearly incompressible body (bulk modulus
    ``material.bulk``); this umat returns the isochoric first Piola–Kirchhoff stress and its
    tangent, in the units of the material's moduli.

    Parameters
    ----------
    material : Material
        Any law of :mod:`multimorph.materials` (moduli in Pa, or scaled; see
        :meth:`Material.scaled`).
    parallel : bool
        Evaluate in threads (no gain on 2 cores in our trial).

    Returns
    -------
    felupe.Hyperelastic
        Accepts ``gradient([F, statevars])`` and ``hessian([F, statevars])``.
    """
    fem = require("felupe")

    def energy(C: Any) -> Any:
        return material.energy_isochoric_C(C, TENSORTRAX_MATH)

    return fem.Hyperelastic(energy, parallel=parallel)
