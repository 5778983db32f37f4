"""The small math namespace every energy law is written against.

A law is written once, e.g. ``-0.5 * mu * jm * xp.log(1 - (I1 - 3) / jm)``, and evaluated by
whoever supplies ``xp``: the reduced model and the fits pass :data:`JAX_MATH` (float64 JAX, so
stresses and tangents come from automatic differentiation); the FE room passes an adapter over
``tensortrax.math`` with the same attribute names. The namespace needs only:

``log, exp, sqrt, where, trace(C), det(C), cofactor_trace(C) (= I2), eigvalsh(C)``

3×3 determinants are written out explicitly: ``jnp.linalg.det``/``inv`` inside jitted kernels
hung intermittently in an earlier trial (design.md §3).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = ["JAX_MATH", "JaxMath"]


@dataclass(frozen=True)
class JaxMath:
    """JAX implementation of the energy namespace (arrays of shape (..., 3, 3) for tensors).

    JAX is imported where a function is first called, not with this module: building a
    :class:`~multimorph.materials.Material` (every spec, every CLI call) does not pay for
    importing JAX (about a second) where no energy is evaluated."""

    def log(self, x: Any) -> Any:
        import jax.numpy as jnp

        return jnp.log(x)

    def exp(self, x: Any) -> Any:
        import jax.numpy as jnp

        return jnp.exp(x)

    def sqrt(self, x: Any) -> Any:
        import jax.numpy as jnp

        return jnp.sqrt(x)

    def where(self, c: Any, a: Any, b: Any) -> Any:
        import jax.numpy as jnp

        return jnp.where(c, a, b)

    def trace(self, C: Any) -> Any:
        return C[..., 0, 0] + C[..., 1, 1] + C[..., 2, 2]

    def det(self, C: Any) -> Any:
        return (
            C[..., 0, 0] * (C[..., 1, 1] * C[..., 2, 2] - C[..., 1, 2] * C[..., 2, 1])
            - C[..., 0, 1] * (C[..., 1, 0] * C[..., 2, 2] - C[..., 1, 2] * C[..., 2, 0])
            + C[..., 0, 2] * (C[..., 1, 0] * C[..., 2, 1] - C[..., 1, 1] * C[..., 2, 0])
        )

    def second_invariant(self, C: Any) -> Any:
        import jax.numpy as jnp

        trC = self.trace(C)
        trC2 = jnp.einsum("...ij,...ji->...", C, C)
        return 0.5 * (trC**2 - trC2)

    def eigvalsh(self, C: Any) -> Any:
        import jax.numpy as jnp

        return jnp.linalg.eigvalsh(C)


JAX_MATH = JaxMath()
