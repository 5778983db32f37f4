"""The sparse linear solvers of the FE room: PARDISO with a kept symbolic analysis, SuperLU,
and the refusal of non-finite systems."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from multimorph.fe import NonFiniteSystemError, make_solver
from multimorph.fe.engine import pardiso_available


def _laplacian(n: int, shift: float) -> sp.csr_matrix:
    """A symmetric 2D 5-point Laplacian (n² unknowns) shifted by ``shift`` on the diagonal;
    a negative shift makes it indefinite."""
    T = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(n, n))
    eye = sp.identity(n)
    return (sp.kron(T, eye) + sp.kron(eye, T) + shift * sp.identity(n * n)).tocsr()


needs_pardiso = pytest.mark.skipif(not pardiso_available(), reason="pypardiso not installed")


@needs_pardiso
def test_pardiso_reuses_its_analysis_for_an_unchanged_pattern() -> None:
    rng = np.random.default_rng(0)
    s = make_solver("pardiso")
    ref = make_solver("superlu")
    b = rng.standard_normal((400, 2))
    # the same pattern, new values each time (as along an FE path), one of them indefinite
    for shift in (0.5, 1.0, -0.3):
        K = _laplacian(20, shift)
        x = s.solve(K, b)
        np.testing.assert_allclose(x, ref.solve(K, b), rtol=1e-9, atol=1e-12)
    assert s.analyses == 1
    # the inertia comes from the refactorisation, not the first analysis
    assert s.inertia is not None and s.inertia[1] > 0
    # a new pattern is analysed again, and solved right
    K2 = (_laplacian(20, 1.0) + sp.diags([0.1], [5], shape=(400, 400))
          + sp.diags([0.1], [-5], shape=(400, 400))).tocsr()
    np.testing.assert_allclose(s.solve(K2, b), ref.solve(K2, b), rtol=1e-9, atol=1e-12)
    assert s.analyses == 2
    s.release()
    np.testing.assert_allclose(s.solve(K2, b), ref.solve(K2, b), rtol=1e-9, atol=1e-12)
    assert s.analyses == 3


@pytest.mark.parametrize("kind", ["superlu", pytest.param("pardiso", marks=needs_pardiso)])
def test_non_finite_systems_are_refused(kind: str) -> None:
    s = make_solver(kind)
    K = _laplacian(5, 1.0)
    K.data[3] = np.nan
    with pytest.raises(NonFiniteSystemError):
        s.solve(K, np.ones(25))
    with pytest.raises(NonFiniteSystemError):
        s.solve(_laplacian(5, 1.0), np.full(25, np.inf))


def test_superlu_symmetric_mode_solves_indefinite_systems_and_falls_back() -> None:
    """SuperLU factorises in symmetric mode (diagonal pivots). An indefinite but well-pivoted
    tangent is solved that way; a tiny diagonal (a saddle-point block, where diagonal
    pivoting is unstable) is caught by the backward-error check and solved with pivoting."""
    rng = np.random.default_rng(3)
    s = make_solver("superlu")
    K = _laplacian(20, -1.3)                       # indefinite, nonsingular
    b = rng.standard_normal(400)
    x = s.solve(K, b)
    assert np.linalg.norm(K @ x - b) <= 1e-10 * np.linalg.norm(b)
    assert s.pivoted_refactorisations == 0
    # [[εI, Bᵀ], [B, 0]]: a pivot of 1e-14 then Schur complements of 1e14
    n = 50
    B = sp.diags([1.0, 0.3], [0, 1], shape=(n, n))
    S = sp.bmat([[1e-14 * sp.identity(n), B.T], [B, None]]).tocsr()
    c = rng.standard_normal(2 * n)
    y = s.solve(S, c)
    assert np.linalg.norm(S @ y - c) <= 1e-10 * np.linalg.norm(c)
    assert s.pivoted_refactorisations == 1


@pytest.mark.parametrize("kind", ["superlu", pytest.param("pardiso", marks=needs_pardiso)])
def test_inertia_counts_the_negative_eigenvalues(kind: str) -> None:
    """The stability of an FE path point is read from the inertia of its tangent. The
    shifted Laplacian's eigenvalues are known in closed form (λ_ij = 4 − 2 cos(iπ/(n+1))
    − 2 cos(jπ/(n+1)) + shift), so the count of negative ones is exact. SuperLU's inertia
    comes from its symmetric-mode factors (Sylvester's law), PARDISO reports its own; a
    factorisation with off-diagonal pivots tells nothing (None)."""
    n = 20
    c = 2.0 * np.cos(np.arange(1, n + 1) * np.pi / (n + 1))
    lam = 4.0 - c[:, None] - c[None, :]
    s = make_solver(kind)
    for shift in (0.5, -0.37, -1.3, -4.1):
        s.solve(_laplacian(n, shift), np.ones(n * n))
        neg = int(np.count_nonzero(lam + shift < 0))
        assert s.inertia == (n * n - neg, neg)
    if kind == "superlu":
        m = 50
        B = sp.diags([1.0, 0.3], [0, 1], shape=(m, m))
        S = sp.bmat([[1e-14 * sp.identity(m), B.T], [B, None]]).tocsr()
        s.solve(S, np.ones(2 * m))
        assert s.pivoted_refactorisations == 1 and s.inertia is None
