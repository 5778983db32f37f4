"""Gaussian-process regression for the calibrated model: fitted with scikit-learn, evaluated
in NumPy (the shipped model needs neither scikit-learn nor JAX at run time).

One GP serves many outputs (the grid values of a cell kind): one Matérn-5/2 kernel with a
length scale per input (ARD), fitted once on the outputs together; each output has its own
linear mean (ridge regression on the inputs), its own scale, and its own set of training
designs (a design that ended before a grid volume does not inform that grid point). The
mean prediction of all outputs is one kernel matrix times one weight matrix.

Reference: C. E. Rasmussen, C. K. I. Williams, Gaussian Processes for Machine Learning,
MIT Press (2006), ch. 2 and 4.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["MultiOutputGP", "fit_gp", "matern52"]


def matern52(a: np.ndarray, b: np.ndarray, length: np.ndarray) -> np.ndarray:
    """Matérn ν = 5/2 correlation between rows of ``a`` and ``b`` (unit amplitude)."""
    a = np.asarray(a, float) / length
    b = np.asarray(b, float) / length
    d2 = (np.sum(a * a, axis=1)[:, None] + np.sum(b * b, axis=1)[None, :] - 2.0 * a @ b.T)
    r = np.sqrt(np.maximum(d2, 0.0))
    s5r = math.sqrt(5.0) * r
    return (1.0 + s5r + 5.0 / 3.0 * r * r) * np.exp(-s5r)


@dataclass(frozen=True, eq=False)
class MultiOutputGP:
    """A fitted multi-output GP (see the module docstring). Arrays only: it saves to and
    loads from a flat dict of arrays (:meth:`to_arrays`, :meth:`from_arrays`).

    Attributes
    ----------
    x : ndarray (n, k)
        Training inputs.
    length : ndarray (k,)
        ARD length scales.
    noise : float
        Noise variance relative to the unit-amplitude kernel.
    mask : ndarray (n, m) of bool
        Which designs train which output.
    weights : ndarray (n, m)
        K_sub⁻¹ (y − mean) / scale per output, zero outside its designs.
    coef : ndarray (k + 1, m)
        Linear mean per output (intercept first).
    scale : ndarray (m,)
        Output scale (the residual standard deviation of the training outputs).
    chol : ndarray (n, n)
        Cholesky factor of K + noise·I over all designs (for the predictive variance).
    """

    x: np.ndarray
    length: np.ndarray
    noise: float
    mask: np.ndarray
    weights: np.ndarray
    coef: np.ndarray
    scale: np.ndarray
    chol: np.ndarray

    def predict(self, x: np.ndarray, *, std: bool = False) -> Any:
        """Mean (q, m) at inputs ``x`` (q, k), and with ``std`` the predictive standard
        deviation (q, m) from the full-data factor (a lower bound where an output has
        fewer designs)."""
        x = np.atleast_2d(np.asarray(x, float))
        ks = matern52(x, self.x, self.length)
        lin = np.column_stack([np.ones(len(x)), x]) @ self.coef
        mean = lin + (ks @ self.weights) * self.scale
        if not std:
            return mean
        if self.chol.size == 0:
            raise ValueError("this GP was stored without its variance factor (mean only)")
        from scipy.linalg import solve_triangular

        v = solve_triangular(self.chol, ks.T, lower=True)
        var = np.maximum(1.0 + self.noise - np.sum(v * v, axis=0), self.noise)
        return mean, np.sqrt(var)[:, None] * self.scale[None, :]

    def to_arrays(self, prefix: str) -> dict[str, np.ndarray]:
        return {f"{prefix}{k}": np.asarray(getattr(self, k)) for k in
                ("x", "length", "noise", "mask", "weights", "coef", "scale", "chol")}

    @classmethod
    def from_arrays(cls, arrays: Any, prefix: str) -> MultiOutputGP:
        g = {k: np.asarray(arrays[f"{prefix}{k}"]) for k in
             ("x", "length", "noise", "mask", "weights", "coef", "scale", "chol")}
        g["noise"] = float(g["noise"])
        return cls(**g)


def _linear(x: np.ndarray, y: np.ndarray, ridge: float) -> np.ndarray:
    A = np.column_stack([np.ones(len(x)), x])
    reg = ridge * np.eye(A.shape[1])
    reg[0, 0] = 0.0
    return np.linalg.solve(A.T @ A + reg, A.T @ y)


def fit_gp(x: np.ndarray, y: np.ndarray, mask: np.ndarray, *, fit_outputs: np.ndarray | None
           = None, ridge: float = 1e-3, restarts: int = 3, seed: int = 0,
           noise_bounds: tuple[float, float] = (1e-6, 1.0)) -> MultiOutputGP:
    """Fit a :class:`MultiOutputGP` to inputs ``x`` (n, k) and outputs ``y`` (n, m) known
    where ``mask`` (n, m).

    The kernel (ARD length scales, noise) is fitted by scikit-learn's marginal-likelihood
    optimiser on the outputs ``fit_outputs`` (default: all) over the designs that have all
    of them, each output's linear-mean residual scaled to unit variance; then each output's
    weights are solved on its own designs.
    """
    from scipy.linalg import cho_factor, cho_solve
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel

    x = np.asarray(x, float)
    y = np.asarray(y, float)
    mask = np.asarray(mask, bool) & np.isfinite(y)
    n, k = x.shape
    m = y.shape[1]
    coef = np.zeros((k + 1, m))
    scale = np.ones(m)
    resid = np.zeros_like(y)
    for j in range(m):
        sel = mask[:, j]
        if sel.sum() < k + 2:
            continue
        coef[:, j] = _linear(x[sel], y[sel, j], ridge)
        r = y[sel, j] - np.column_stack([np.ones(sel.sum()), x[sel]]) @ coef[:, j]
        scale[j] = max(float(np.std(r)), 1e-6)
        resid[sel, j] = r / scale[j]
    cols = np.arange(m) if fit_outputs is None else np.asarray(fit_outputs)
    rows = np.all(mask[:, cols], axis=1)
    kernel = (ConstantKernel(1.0, (1e-3, 1e3))
              * Matern(length_scale=np.ones(k), length_scale_bounds=(1e-2, 1e3), nu=2.5)
              + WhiteKernel(min(max(1e-2, noise_bounds[0]), noise_bounds[1]), noise_bounds))
    gpr = GaussianProcessRegressor(kernel, normalize_y=False, n_restarts_optimizer=restarts,
                                   random_state=seed)
    gpr.fit(x[rows], resid[np.ix_(rows, cols)])
    kp = gpr.kernel_.get_params()
    amp = float(kp["k1__k1__constant_value"])
    length = np.asarray(kp["k1__k2__length_scale"], float) * np.ones(k)
    noise = float(kp["k2__noise_level"]) / amp
    scale = scale * math.sqrt(amp)
    resid = resid / math.sqrt(amp)
    K = matern52(x, x, length)
    weights = np.zeros((n, m))
    for j in range(m):
        sel = mask[:, j]
        if not sel.any():
            continue
        Ks = K[np.ix_(sel, sel)] + noise * np.eye(int(sel.sum()))
        weights[sel, j] = cho_solve(cho_factor(Ks, lower=True), resid[sel, j])
    chol = np.linalg.cholesky(K + noise * np.eye(n))
    return MultiOutputGP(x=x, length=length, noise=noise, mask=mask, weights=weights,
                         coef=coef, scale=scale, chol=chol)
