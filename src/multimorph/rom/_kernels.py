"""Small numerical kernels shared by the reduced model and the path tracer.

Everything here is written for JAX tracing (jit/vmap/grad to any order) on tiny, fixed
sizes: safe series forms of functions with removable singularities (so derivatives at a
flat, undeformed wall are exact), Gauss–Legendre nodes, and explicit small-matrix linear
algebra (Gaussian elimination with partial pivoting, Sylvester pivots). ``jnp.linalg.det``
and ``inv`` are avoided on purpose: they hung intermittently inside jitted kernels in an
earlier trial (design.md §3).
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any

import jax.numpy as jnp
import numpy as np

__all__ = ["c3", "dsinc", "gauss", "pivots", "sinc", "solve_small"]

# Maclaurin coefficients (in x²) of sin(x)/x, d/dx sin(x)/x (divided by x) and
# (x − sin x)/x³. Thirteen terms are exact to ~1e-14 for |x| ≤ π (a bulge
# half-angle never exceeds π); a branch-free polynomial compiles and differentiates faster
# than a guarded quotient and is smooth to every order at x = 0.
_N_TERMS = 13
_SINC = np.array([(-1.0) ** k / math.factorial(2 * k + 1) for k in range(_N_TERMS)])
_DSINC = np.array([2 * k * c for k, c in enumerate(_SINC)])[1:]     # sinc'(x) = x Σ ...
_C3 = np.array([(-1.0) ** k / math.factorial(2 * k + 3) for k in range(_N_TERMS)])


def _horner(coef: np.ndarray, x2: Any) -> Any:
    acc = coef[-1] * jnp.ones_like(x2)
    for c in coef[-2::-1]:
        acc = acc * x2 + c
    return acc


def sinc(x: Any) -> Any:
    """sin(x)/x (unnormalised) as a branch-free polynomial, exact for |x| ≤ 4."""
    return _horner(_SINC, x * x)


def dsinc(x: Any) -> Any:
    """d/dx sin(x)/x = (cos x − sinc x)/x, branch-free, exact for |x| ≤ 4."""
    return x * _horner(_DSINC, x * x)


def c3(x: Any) -> Any:
    """(x − sin x)/x³, branch-free, exact for |x| ≤ 4 (the segment area needs x = 2 phi ≤ 2π:
    beyond 4 the error grows smoothly; bulges that large are past any lock-up)."""
    return _horner(_C3, x * x)


@lru_cache(maxsize=64)
def gauss(n: int, a: float = 0.0, b: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights on [a, b] (n points, exact for degree 2n − 1)."""
    x, w = np.polynomial.legendre.leggauss(n)
    x = 0.5 * (b - a) * x + 0.5 * (b + a)
    w = 0.5 * (b - a) * w
    x.setflags(write=False)
    w.setflags(write=False)
    return x, w


def solve_small(A: Any, b: Any) -> Any:
    """Solve ``A x = b`` for a small dense matrix by Gaussian elimination with partial pivoting.

    Unrolled over the (static) size, so it traces to a handful of fused element-wise
    operations and vectorises under ``vmap``: the row swaps use one-hot masks rather than
    dynamic indexing (a batched index would become a scatter, which is slow on CPUs). A
    zero pivot is replaced by a tiny number (the caller checks the result for finiteness
    and residual).
    """
    n = A.shape[-1]
    M = jnp.concatenate([A, b[:, None]], axis=1)
    rows = jnp.arange(n)
    for k in range(n):
        col = jnp.where(rows >= k, jnp.abs(M[:, k]), -1.0)
        hot = (rows == jnp.argmax(col))[:, None]
        rk = M[k]
        ri = jnp.sum(jnp.where(hot, M, 0.0), axis=0)
        M = jnp.where(hot, rk[None, :], M)
        M = jnp.where((rows == k)[:, None], ri[None, :], M)
        piv = ri[k]
        piv = jnp.where(jnp.abs(piv) > 1e-300, piv, 1e-300)
        f = jnp.where(rows > k, M[:, k] / piv, 0.0)
        M = M - f[:, None] * ri[None, :]
    x = []
    for k in range(n - 1, -1, -1):
        s = M[k, n] - sum((M[k, j] * x[n - 1 - j] for j in range(k + 1, n)), 0.0)
        piv = jnp.where(jnp.abs(M[k, k]) > 1e-300, M[k, k], 1e-300)
        x.append(s / piv)
    return jnp.stack(x[::-1])


def pivots(K: Any) -> Any:
    """Pivots of the unpivoted symmetric elimination of ``K`` (Sylvester's criterion).

    ``K`` is positive definite exactly when every pivot is positive; the number of negative
    pivots is the number of negative eigenvalues (while no pivot vanishes). After a
    non-positive pivot the later ones are meaningless (the caller takes ``all(p > 0)``).
    """
    n = K.shape[-1]
    M = K
    out = []
    for k in range(n):
        piv = M[k, k]
        out.append(piv)
        safe = jnp.where(jnp.abs(piv) > 1e-300, piv, 1e-300)
        f = M[:, k] / safe
        f = jnp.where(jnp.arange(n) > k, f, 0.0)
        M = M - f[:, None] * M[k][None, :]
    return jnp.stack(out)
