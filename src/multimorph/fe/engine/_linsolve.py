"""Sparse linear solvers for symmetric FE tangents: PARDISO (MKL) or SuperLU.

PARDISO runs in real symmetric-indefinite mode (``mtype=-2``) on the upper triangle; it was
the fastest solver in the FE trials (fe-notes §3). The tangent's sparsity pattern does
not change along a path, so the symbolic analysis (fill-reducing ordering, about half the
cost of a solve at 10k DOF) is done once per pattern and kept: later solves only refactorise
numerically (PARDISO phase 23) while the pattern stays the same, and a matrix equal to the
last one factorised (contique restarts every cycle of a step from the same converged point,
so the same tangent comes back several times) is not factorised again at all: only the
triangular solves run (phase 33; SuperLU: the kept LU factors). It is an optional extra
(``multimorph[fast]``); without it SuperLU is used. Either way a matrix or right-hand side
with NaN/inf entries is refused *before* the factorisation: MKL crashed (segfault) on such a
matrix in a trial (a Newton trial state beyond Gent's lock-up), so a failed iterate becomes a
clean :class:`NonFiniteSystemError` that the step control answers with a cutback.
"""

from __future__ import annotations

import importlib.metadata
import os
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from multimorph.errors import MultimorphError

__all__ = ["LinearSolver", "NonFiniteSystemError", "make_solver", "pardiso_available"]


class NonFiniteSystemError(MultimorphError, ArithmeticError):
    """The tangent or the right-hand side contains NaN or inf."""


def _name_mkl_runtime() -> None:
    """Tell pypardiso where the MKL wheel's runtime library is.

    Without ``PYPARDISO_MKL_RT``, every ``PyPardisoSolver()`` (one at pypardiso's import,
    one per solver of ours) searches ``sys.prefix`` recursively for it: 0.65 s each in our
    virtual environment, a sixtieth of a whole fine-mesh path. The ``mkl`` distribution's
    file list names it directly. A path set by the user is kept.
    """
    if os.environ.get("PYPARDISO_MKL_RT"):
        return
    try:
        files = importlib.metadata.files("mkl") or []
    except importlib.metadata.PackageNotFoundError:
        return
    found = sorted((str(f.locate().resolve()) for f in files if "mkl_rt" in f.name), key=len)
    for path in found:
        if os.path.isfile(path):
            os.environ["PYPARDISO_MKL_RT"] = path
            return


def pardiso_available() -> bool:
    """Whether pypardiso (MKL) can be imported (cached after the first call)."""
    global _PARDISO_OK
    if _PARDISO_OK is None:
        if os.environ.get("MULTIMORPH_NO_PARDISO"):
            _PARDISO_OK = False
        else:
            _name_mkl_runtime()
            try:
                import pypardiso  # noqa: F401

                _PARDISO_OK = True
            except Exception:  # ImportError, or an MKL that fails to load
                _PARDISO_OK = False
    return _PARDISO_OK


_PARDISO_OK: bool | None = None


@dataclass
class LinearSolver:
    """Solve ``K x = b`` for a symmetric sparse ``K`` (one or several right-hand sides).

    Attributes
    ----------
    name : str
        ``"pardiso-sym-indef"`` or ``"superlu"``.
    time : float
        Seconds spent in factorisations and solves.
    calls : int
    """

    name: str
    time: float = 0.0
    calls: int = 0
    #: (positive, negative) eigenvalue counts of the last factorised matrix (PARDISO, or
    #: SuperLU factors with diagonal pivots; None where the factorisation does not tell)
    inertia: tuple[int, int] | None = None
    #: symbolic analyses done (PARDISO; one per distinct sparsity pattern)
    analyses: int = 0
    #: numerical factorisations done (solves of an unchanged matrix reuse the last one)
    factorisations: int = 0
    #: SuperLU: symmetric-mode factors refused by the residual check and redone with pivoting
    pivoted_refactorisations: int = 0

    def __post_init__(self) -> None:
        self._pardiso: Any = None
        self._pattern: tuple[np.ndarray, np.ndarray] | None = None
        self._values: np.ndarray | None = None   # entries of the matrix last factorised
        self._lu: Any = None
        self._knorm = 0.0                          # ‖K‖∞ of the matrix last factorised
        self._triu: tuple[np.ndarray, ...] | None = None  # upper-triangle map of a pattern
        if self.name == "pardiso-sym-indef":
            _name_mkl_runtime()
            import pypardiso

            self._pardiso = pypardiso.PyPardisoSolver(mtype=-2)

    def release(self) -> None:
        """Free PARDISO's factors and analysis (the next solve analyses again)."""
        if self._pardiso is not None and self._pattern is not None:
            self._pardiso.free_memory()
        self._pattern = None
        self._values = None
        self._lu = None

    def _upper(self, K: sp.csr_matrix) -> sp.csr_matrix:
        """The upper triangle of ``K`` (sorted CSR); which entries it takes is worked out
        once per pattern (the tangent's pattern is fixed along a path)."""
        c = self._triu
        if c is None or not (np.array_equal(c[0], K.indptr) and np.array_equal(c[1], K.indices)):
            K = K.copy()
            K.sum_duplicates()                          # canonical: sorted, no duplicates
            n = K.shape[0]
            rows = np.repeat(np.arange(n), np.diff(K.indptr))
            keep = np.flatnonzero(K.indices >= rows)
            indptr = np.concatenate([[0], np.cumsum(np.bincount(rows[keep], minlength=n))])
            c = self._triu = (K.indptr.copy(), K.indices.copy(), keep,
                              indptr.astype(K.indptr.dtype), K.indices[keep])
        U = sp.csr_matrix((K.data[c[2]], c[4].copy(), c[3].copy()), shape=K.shape)
        U.has_sorted_indices = True
        return U

    def _same_values(self, data: np.ndarray) -> bool:
        return self._values is not None and np.array_equal(self._values, data)

    def _pardiso_solve(self, U: sp.csr_matrix, b: np.ndarray) -> np.ndarray:
        """Solve with the upper triangle ``U``, reusing the analysis of an equal pattern."""
        ps = self._pardiso
        if not hasattr(ps, "_call_pardiso"):  # pypardiso without the phase interface
            x = ps.solve(U, b)
            ps.free_memory()
            self.analyses += 1
            return np.asarray(x)
        b = ps._check_b(U, b)
        pat = self._pattern
        if pat is not None and np.array_equal(pat[0], U.indptr) and np.array_equal(
                pat[1], U.indices):
            if self._same_values(U.data):
                ps.set_phase(33)                       # solve with the kept factors
            else:
                ps.set_phase(23)                       # numerical factorisation + solve
                self._values = U.data.copy()
                self.factorisations += 1
        else:
            self.release()
            ps.set_phase(13)                           # analysis + factorisation + solve
            self._pattern = (U.indptr.copy(), U.indices.copy())
            self._values = U.data.copy()
            self.analyses += 1
            self.factorisations += 1
        try:
            return np.asarray(ps._call_pardiso(U, b))
        except Exception:
            self.release()                             # never reuse a failed analysis
            raise

    def solve(self, K: sp.spmatrix, b: np.ndarray) -> np.ndarray:
        """Solve; raises :class:`NonFiniteSystemError` for non-finite input."""
        K = K.tocsr()
        b = np.asarray(b, dtype=float)
        if not (np.all(np.isfinite(K.data)) and np.all(np.isfinite(b))):
            raise NonFiniteSystemError("tangent or right-hand side contains NaN/inf")
        t = time.perf_counter()
        try:
            if self._pardiso is not None:
                x = self._pardiso_solve(self._upper(K), b)
                self.inertia = (int(self._pardiso.iparm[21]), int(self._pardiso.iparm[22]))
            else:
                Kc = K.tocsc()
                pat = self._pattern
                same = (pat is not None and self._lu is not None
                        and np.array_equal(pat[0], Kc.indptr)
                        and np.array_equal(pat[1], Kc.indices) and self._same_values(Kc.data))
                if not same:
                    self._lu = _splu_symmetric(Kc)
                    self._pattern = (Kc.indptr.copy(), Kc.indices.copy())
                    self._values = Kc.data.copy()
                    self._knorm = _inf_norm(Kc)
                    self.factorisations += 1
                    self.inertia = _lu_inertia(self._lu)
                x = self._lu.solve(b)
                if not _accurate(Kc, self._knorm, x, b):
                    # a small diagonal pivot spoilt the symmetric-mode factors: partial
                    # pivoting (SuperLU's default), slower but safe
                    self._lu = spla.splu(Kc)
                    self.pivoted_refactorisations += 1
                    self.inertia = None
                    x = self._lu.solve(b)
        finally:
            self.time += time.perf_counter() - t
            self.calls += 1
        x = np.asarray(x).reshape(b.shape)
        if not np.all(np.isfinite(x)):
            raise NonFiniteSystemError("linear solve returned NaN/inf (singular tangent?)")
        return x


def _splu_symmetric(K: sp.csc_matrix) -> Any:
    """SuperLU in symmetric mode: a minimum-degree ordering of K + Kᵀ and diagonal pivots.

    The tangent is symmetric, so the symmetric ordering keeps the fill of a Cholesky-like
    factorisation; SuperLU's default (COLAMD with partial pivoting) more than doubles it on
    a loaded tangent (fine cell mesh, 9.9k DOF: 6.3 M instead of 13.1 M entries in L + U,
    0.6 s instead of 2.9 s). Diagonal pivots can be small on an indefinite tangent, so every
    solve is checked (:func:`_accurate`) and redone with partial pivoting if needed.
    """
    return spla.splu(K, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                     options={"SymmetricMode": True})


def _lu_inertia(lu: Any) -> tuple[int, int] | None:
    """(positive, negative) eigenvalue counts of a symmetric matrix from its symmetric-mode
    SuperLU factors, or None where they do not tell.

    With diagonal pivots and one permutation for rows and columns, Pᵀ K P = L U with
    U = D Lᵀ, so K and D are congruent and (Sylvester's law of inertia) have the same
    eigenvalue signs: the signs of U's diagonal. A factorisation that permuted rows and
    columns differently (an off-diagonal pivot) is not such a congruence.
    """
    if not np.array_equal(lu.perm_r, lu.perm_c):
        return None
    d = lu.U.diagonal()
    neg = int(np.count_nonzero(d < 0))
    return len(d) - neg - int(np.count_nonzero(d == 0)), neg


def _inf_norm(K: sp.spmatrix) -> float:
    """‖K‖∞, the largest absolute row sum."""
    return float(abs(K).sum(axis=1).max())


def _accurate(K: sp.spmatrix, knorm: float, x: np.ndarray, b: np.ndarray,
              rtol: float = 1e-10) -> bool:
    """Whether ``x`` solves ``K x = b`` with a normwise backward error below ``rtol``.

    The backward error ‖K x − b‖∞ / (‖K‖∞ ‖x‖∞ + ‖b‖∞) (per right-hand side) is about
    machine precision for a stable factorisation even when K is ill-conditioned (near a
    limit point), and large when small pivots made the factors unstable.
    """
    r = K @ x - b
    nr = np.max(np.abs(r), axis=0)
    scale = knorm * np.max(np.abs(x), axis=0) + np.max(np.abs(b), axis=0)
    return bool(np.all(np.isfinite(nr)) and np.all(nr <= rtol * np.maximum(scale, 1e-300)))


def make_solver(kind: str = "auto") -> LinearSolver:
    """A fresh solver: ``"auto"`` (PARDISO if importable, else SuperLU), ``"pardiso"`` or
    ``"superlu"``.
    """
    kind = kind.lower()
    if kind == "auto":
        kind = "pardiso" if pardiso_available() else "superlu"
    if kind == "pardiso":
        if not pardiso_available():
            from multimorph.fe._deps import MissingExtraError

            raise MissingExtraError("pypardiso is not installed (pip install 'multimorph[fast]')")
        return LinearSolver("pardiso-sym-indef")
    if kind == "superlu":
        return LinearSolver("superlu")
    raise MultimorphError(f"unknown linear solver {kind!r}; expected auto, pardiso or superlu")
