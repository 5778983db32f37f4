"""Material adapter: the package's one energy law, evaluated by tensortrax inside FElupe.

:meth:`multimorph.materials.Material.energy_isochoric_C` evaluates a law from the right
Cauchy–Green tensor through a small math namespace ``xp``. :class:`TensortraxMath` supplies
that namespace over ``tensortrax.math``, so FElupe gets the gradient and Hessian of *the same*
function that the reduced model and the fits differentiate with JAX. No law is repeated here.

Two routes, one energy:

* **Invariant laws** (neo-Hooke, Mooney–Rivlin, Yeoh, Gent, Arruda–Boyce: W(Ī1, Ī2)) go
  through :class:`InvariantHyperelastic`: tensortrax differentiates the law's scalar energy in
  the two isochoric invariants only (a 2-vector per point), and the kinematics of Ī1(F),
  Ī2(F) are written out once (first and second derivatives in F). This is the same stress
  and tangent as the tensor route to round-off (tested), about 6× cheaper per quadrature
  point than carrying a 3×3 tensor's hyper-duals through the whole energy.
* **Principal-stretch laws** (Ogden) need the eigenvalues of C̄ and keep the tensor route
  (FElupe's ``Hyperelastic`` over tensortrax).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from multimorph.fe._deps import require
from multimorph.materials import Material

__all__ = ["TENSORTRAX_MATH", "InvariantHyperelastic", "TensortraxMath", "felupe_umat"]


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


def _outer(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dyadic product (a ⊗ b)_iJkL = a_iJ b_kL of (3, 3, n) arrays → (3, 3, 3, 3, n)."""
    return a[:, :, None, None] * b[None, None]


def _crossed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Crossed product a_iL b_kJ of (3, 3, n) arrays → (3, 3, 3, 3, n) in iJkL order."""
    return a[:, None, None, :] * b.transpose(1, 0, 2)[None, :, :, None]


class InvariantHyperelastic:
    """Isochoric hyperelasticity of an invariant law W(Ī1, Ī2) with analytic kinematics.

    With J = det F, a = J^(−2/3), b = J^(−4/3), G = F^(−T), Ī1 = a I1, Ī2 = b I2 and
    D = ∂I2/∂F = 2 (I1 F − F C):

    * ∂Ī1/∂F = a (2F − ⅔ I1 G),  ∂Ī2/∂F = b (D − ⁴⁄₃ I2 G);
    * P = W₁ ∂Ī1/∂F + W₂ ∂Ī2/∂F;
    * A = Σ W_αβ ∂Ī_α/∂F ⊗ ∂Ī_β/∂F + W₁ ∂²Ī1/∂F∂F + W₂ ∂²Ī2/∂F∂F, with (indices iJkL)
      ∂²Ī1 = a [2 δik δJL − ⁴⁄₃ (F⊗G + G⊗F) + ⁴⁄₉ I1 G⊗G + ⅔ I1 G_iL G_kJ],
      ∂²Ī2 = b [2 (2 F⊗F + I1 δik δJL − δik C_JL − F_iL F_kJ − B_ik δJL)
      − ⁴⁄₃ (D⊗G + G⊗D) + ¹⁶⁄₉ I2 G⊗G + ⁴⁄₃ I2 G_iL G_kJ].

    W₁, W₂, W₁₁, W₁₂, W₂₂ come from tensortrax applied to the law's own scalar energy
    (:meth:`Material.energy_invariants` through :data:`TENSORTRAX_MATH`): no law is
    re-derived. FElupe calls ``gradient([F, statevars])`` → ``[P, statevars]`` and
    ``hessian([F, statevars])`` → ``[A]`` with F of shape (3, 3, q, cells).
    """

    def __init__(self, material: Material) -> None:
        tr = require("tensortrax")
        self.material = material
        self.x = [np.eye(3), np.zeros(0)]

        def w(v: Any) -> Any:
            return material.energy_invariants(v[0], v[1], TENSORTRAX_MATH)

        self._d2w = tr.hessian(w, ntrax=1, full_output=True)
        self._last: tuple[np.ndarray, dict[str, Any]] | None = None

    def _kinematics(self, F: np.ndarray) -> dict[str, Any]:
        """The invariants, their first derivatives and the law's derivatives at ``F``.

        FElupe asks for the tangent at the deformation of the preceding stress evaluation;
        the last result is kept (with a copy of its F) and handed out again for an equal F,
        which saves a fifth of a tangent's material work.
        """
        F = np.ascontiguousarray(F).reshape(3, 3, -1)
        last = self._last
        if last is not None and last[0].shape == F.shape and np.array_equal(last[0], F):
            return last[1]
        F = F.copy()  # FElupe overwrites its kinematics in place
        k = self._evaluate(F)
        self._last = (F, k)
        return k

    def _evaluate(self, F: np.ndarray) -> dict[str, Any]:
        C = np.einsum("kI...,kJ...->IJ...", F, F)
        B = np.einsum("iK...,jK...->ij...", F, F)
        I1 = C[0, 0] + C[1, 1] + C[2, 2]
        I2 = 0.5 * (I1**2 - np.einsum("IJ...,IJ...->...", C, C))
        # cofactor of F (= J F^-T), written out
        cof = np.empty_like(F)
        cof[0, 0] = F[1, 1] * F[2, 2] - F[1, 2] * F[2, 1]
        cof[0, 1] = F[1, 2] * F[2, 0] - F[1, 0] * F[2, 2]
        cof[0, 2] = F[1, 0] * F[2, 1] - F[1, 1] * F[2, 0]
        cof[1, 0] = F[0, 2] * F[2, 1] - F[0, 1] * F[2, 2]
        cof[1, 1] = F[0, 0] * F[2, 2] - F[0, 2] * F[2, 0]
        cof[1, 2] = F[0, 1] * F[2, 0] - F[0, 0] * F[2, 1]
        cof[2, 0] = F[0, 1] * F[1, 2] - F[0, 2] * F[1, 1]
        cof[2, 1] = F[0, 2] * F[1, 0] - F[0, 0] * F[1, 2]
        cof[2, 2] = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
        J = np.einsum("i...,i...->...", F[0], cof[0])
        G = cof / J
        a = J ** (-2.0 / 3.0)
        b = a * a
        D = 2.0 * (I1 * F - np.einsum("iK...,KJ...->iJ...", F, C))
        d1 = a * (2.0 * F - (2.0 / 3.0) * I1 * G)
        d2 = b * (D - (4.0 / 3.0) * I2 * G)
        with np.errstate(invalid="ignore", divide="ignore"):
            H, g, _ = self._d2w(np.stack([a * I1, b * I2]))
        # tensortrax returns broadcastable zeros for terms a law does not have
        n = F.shape[-1]
        H = np.broadcast_to(H, (2, 2, n))
        g = np.broadcast_to(g, (2, n))
        return {"F": F, "C": C, "B": B, "I1": I1, "I2": I2, "G": G, "a": a, "b": b,
                "D": D, "d1": d1, "d2": d2, "g": g, "H": H}

    def gradient(self, x: list[Any]) -> list[Any]:
        """Isochoric first Piola–Kirchhoff stress P (3, 3, q, cells) and the state."""
        F = np.asarray(x[0])
        k = self._kinematics(F)
        P = k["g"][0] * k["d1"] + k["g"][1] * k["d2"]
        return [P.reshape(F.shape), x[-1]]

    def hessian(self, x: list[Any]) -> list[Any]:
        """Isochoric tangent A = ∂²W/∂F∂F, shape (3, 3, 3, 3, q, cells).

        Every dyadic term lies in span{F, G, D} ⊗ span{F, G, D}, so the Hessian part and
        the dyadic parts of ∂²Ī1, ∂²Ī2 are gathered into one symmetric 3 × 3 coefficient
        matrix M per point (three outer products instead of nine); the crossed and δ terms
        are added in place.
        """
        F0 = np.asarray(x[0])
        k = self._kinematics(F0)
        F, C, B, G, D = (k[n] for n in ("F", "C", "B", "G", "D"))
        I1, I2, g, H, a, b = k["I1"], k["I2"], k["g"], k["H"], k["a"], k["b"]
        s = g[0] * a      # W₁ a
        t = g[1] * b      # W₂ b
        zero = np.zeros_like(a)
        # ∂Ī1/∂F and ∂Ī2/∂F in the basis (F, G, D)
        c = np.array([[2.0 * a, (-2.0 / 3.0) * a * I1, zero],
                      [zero, (-4.0 / 3.0) * b * I2, b]])
        M = np.einsum("ap...,ab...,bq...->pq...", c, H, c)
        M[0, 0] += 4.0 * t
        M[0, 1] -= (4.0 / 3.0) * s
        M[1, 0] -= (4.0 / 3.0) * s
        M[1, 1] += (4.0 / 9.0) * s * I1 + (16.0 / 9.0) * t * I2
        M[1, 2] -= (4.0 / 3.0) * t
        M[2, 1] -= (4.0 / 3.0) * t
        def row(i: int) -> np.ndarray:
            return M[i, 0] * F + M[i, 1] * G + M[i, 2] * D

        A = _outer(F, row(0))
        A += _outer(G, row(1))
        A += _outer(D, row(2))
        A += _crossed(((2.0 / 3.0) * s * I1 + (4.0 / 3.0) * t * I2) * G, G)
        A -= _crossed(2.0 * t * F, F)
        # δik [(2s + 2t I1) δJL − 2t C_JL] − 2t B_ik δJL
        X = -2.0 * t * C
        X[0, 0] += 2.0 * s + 2.0 * t * I1
        X[1, 1] += 2.0 * s + 2.0 * t * I1
        X[2, 2] += 2.0 * s + 2.0 * t * I1
        Y = 2.0 * t * B
        for i in range(3):
            A[i, :, i, :] += X
            A[:, i, :, i] -= Y
        return [A.reshape(3, 3, 3, 3, *F0.shape[2:])]


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
    InvariantHyperelastic or felupe.Hyperelastic
        :class:`InvariantHyperelastic` for invariant laws (analytic kinematics, the law's
        derivatives in Ī1, Ī2 by tensortrax); FElupe's tensortrax ``Hyperelastic`` of
        W(C) for principal-stretch laws, or when ``parallel`` is asked for. Both accept
        ``gradient([F, statevars])`` and ``hessian([F, statevars])``.
    """
    if material.law.variables == "invariants" and not parallel:
        return InvariantHyperelastic(material)
    fem = require("felupe")

    def energy(C: Any) -> Any:
        return material.energy_isochoric_C(C, TENSORTRAX_MATH)

    return fem.Hyperelastic(energy, parallel=parallel)
