"""Small numerical kernels shared by the reduced model and the path tracer.

Everything here is written for JAX tracing (jit/vmap/grad to any order) on tiny, fixed
sizes: safe series forms of functions with removable singularities (so derivatives at a
flat, undeformed wall are exact), Gauss–Legendre nodes, and explicit small-matrix linear
algebra (Gaussian elimination with partial pivoting, Sylvester pivots). ``jnp.linalg.det``
and ``inv`` are avoided on purpose: they hung intermittently inside jitted kernels in an
earlier trial (design.md §3).
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import jax.numpy as jnp
import numpy as np

__all__ = ["c3", "gauss", "pivots", "sinc", "solve_small"]

_SERIES_CUT = 0.1


def sinc(x: Any) -> Any:
    """sin(x)/x (unnormalised), exact to all derivative orders at x = 0.

    For |x| < 0.1 the Maclaurin series to x^8 is used (truncation < 3e-17); elsewhere the
    quotient, evaluated at a guarded argument so that neither branch produces NaN.
    """
    small = jnp.abs(x) < _SERIES_CUT
    xs = jnp.where(small, 1.0, x)
    x2 = x * x
    series = 1.0 - x2 / 6.0 * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0)))
    return jnp.where(small, series, jnp.sin(xs) / xs)


def c3(x: Any) -> Any:
    """(x − sin x)/x³, exact to all derivative orders at x = 0 (series for |x| < 0.1)."""
    small = jnp.abs(x) < _SERIES_CUT
    xs = jnp.where(small, 1.0, x)
    x2 = x * x
    series = (1.0 / 6.0) * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0)))
    return jnp.where(small, series, (xs - jnp.sin(xs)) / (xs * xs * xs))


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
    operations and vectorises under ``vmap``. A zero pivot is replaced by a tiny number
    (the caller checks the result for finiteness and residual).
    """
    n = A.shape[-1]
    M = jnp.concatenate([A, b[:, None]], axis=1)
    rows = jnp.arange(n)
    for k in range(n):
        col = jnp.where(rows >= k, jnp.abs(M[:, k]), -1.0)
        i = jnp.argmax(col)
        rk = M[k]
        ri = M[i]
        M = M.at[i].set(rk).at[k].set(ri)
        piv = M[k, k]
        piv = jnp.where(jnp.abs(piv) > 1e-300, piv, 1e-300)
        f = jnp.where(rows > k, M[:, k] / piv, 0.0)
        M = M - f[:, None] * M[k][None, :]
    x = jnp.zeros(n, dtype=M.dtype)
    for k in range(n - 1, -1, -1):
        s = M[k, n] - jnp.dot(M[k, :n], x)
        piv = jnp.where(jnp.abs(M[k, k]) > 1e-300, M[k, k], 1e-300)
        x = x.at[k].set(s / piv)
    return x


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
