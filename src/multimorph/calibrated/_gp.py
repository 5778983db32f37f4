"""Gaussian-process regression for the calibrated model: fitted with scikit-learn, evaluated
in NumPy (the shipped model needs neither scikit-learn nor JAX at run time).

One GP serves many outputs (the grid values of a cell kind): one Matérn-5/2 kernel with a
length scale per input (ARD), fitted once on the outputs together; each output has its own
linear mean (ridge regression on the inputs), its own scale, and its own set of training
designs (a design that ended before a grid volume does not inform that grid point). The
mean prediction of all outputs is one kernel matrix times one weight matrix.

A design whose outputs stop because its value passed a known bound (an FE run stopped at
its pressure limit: every later grid volume lies above that pressure) is *censored*, not
missing: with ``lower``, :func:`fit_gp` imputes those outputs from the output's own GP
prediction at the design and the design's leave-one-out error at its last observed
output carried over (:func:`censored_residuals`), truncated below at the bound (a
Tobit-type treatment), and lets them into their outputs' solves with the conditional
variance added to the noise, so that every output of a grid volume sees the same designs
as its neighbours (``_fit.fit_pressure``; docs/validation.md §2 item 3).

Reference: C. E. Rasmussen, C. K. I. Williams, Gaussian Processes for Machine Learning,
MIT Press (2006), ch. 2 and 4.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["MultiOutputGP", "censored_residuals", "fit_gp", "fit_gp_cv", "lower_solve",
           "matern52", "robust_noise"]


def matern52(a: np.ndarray, b: np.ndarray, length: np.ndarray) -> np.ndarray:
    """Matérn ν = 5/2 correlation between rows of ``a`` and ``b`` (unit amplitude):
    (1 + s + s²/3) exp(−s) with s = √5 r, r the distance scaled by ``length``.

    Evaluated in place on two (q, n) arrays: a batch of 1,000 designs against the bending
    kind's 969 training designs is 1M entries per GP, and temporaries of that size were a
    fifth of a batch's time (``benchmarks/bench_calibrated.py``, stop 57)."""
    a = np.asarray(a, float) / length
    b = np.asarray(b, float) / length
    s = a @ b.T
    s *= -2.0
    s += np.einsum("ij,ij->i", a, a)[:, None]
    s += np.einsum("ij,ij->i", b, b)[None, :]
    np.maximum(s, 0.0, out=s)
    np.sqrt(s, out=s)
    s *= math.sqrt(5.0)
    out = np.negative(s)
    np.exp(out, out=out)
    poly = s * s
    poly *= 1.0 / 3.0
    poly += s
    poly += 1.0
    out *= poly
    return out


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
        v = lower_solve(self.chol, ks.T)
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
        if not np.all(np.isfinite(g["chol"])):
            raise ValueError(f"{prefix}chol: the stored variance factor is not finite "
                             "(a damaged model file)")
        return cls(**g)


def lower_solve(chol: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """L⁻¹ rhs for a lower Cholesky factor checked finite when it was loaded
    (:meth:`MultiOutputGP.from_arrays`). SciPy's own finiteness check reads the whole
    (n, n) factor on every call: with the bending kind's 872 training designs that was a
    quarter of one warm curve's time (``benchmarks/bench_calibrated.py``)."""
    from scipy.linalg import solve_triangular

    return solve_triangular(chol, rhs, lower=True, check_finite=False)


def _linear(x: np.ndarray, y: np.ndarray, ridge: float) -> np.ndarray:
    A = np.column_stack([np.ones(len(x)), x])
    reg = ridge * np.eye(A.shape[1])
    reg[0, 0] = 0.0
    return np.linalg.solve(A.T @ A + reg, A.T @ y)


def _leave_one_out(A: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A⁻¹ r, diag A⁻¹) for the covariance ``A`` of the residuals ``r``: the design i's
    leave-one-out residual is (A⁻¹ r)_i / (A⁻¹)_ii and its leave-one-out variance
    1 / (A⁻¹)_ii (Rasmussen & Williams, §5.4.2)."""
    from scipy.linalg import cho_factor, cho_solve

    c = cho_factor(A, lower=True)
    return cho_solve(c, r), np.diag(cho_solve(c, np.eye(len(A))))


#: Fewest designs with both outputs for the regression that continues a censored design.
MIN_PAIRS = 30


def censored_residuals(K: np.ndarray, noise: float, resid: np.ndarray, mask: np.ndarray,
                       bound: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Impute the censored outputs of standardised residuals ``resid`` (n, m; observed
    where ``mask``; ``K`` the unit-amplitude kernel matrix of the n designs): output j of
    design i is censored where ``bound[i, j]`` is finite and it is not observed — it lies
    above that bound.

    Its value combines what the other designs say and what the design's own observed
    outputs say: the GP of output j (its observed designs) predicts m_j(x_i), and the
    design's leave-one-out error at its last observed output e, δ_e (observed minus the
    prediction without it), is carried over by the regression of the leave-one-out errors
    at j on those at e over the designs that have both (β, residual variance s²; at least
    :data:`MIN_PAIRS` designs): r ~ N(m_j(x_i) + β δ_e, s²). That is then conditioned on
    r > bound: the truncated normal's mean μ + s λ(α) and variance s² (1 + α λ − λ²),
    α = (bound − μ)/s, λ = φ(α)/(1 − Φ(α)).
    Returns (residuals with the imputed values, their variance (0 where observed), the
    mask of imputed entries)."""
    from scipy.special import ndtr

    resid = np.array(resid, float)
    n, m = resid.shape
    extra = np.zeros((n, m))
    imputed = np.zeros((n, m), bool)
    cens = np.isfinite(bound) & ~mask
    todo = np.flatnonzero(cens.any(axis=1) & mask.any(axis=1))
    if todo.size == 0:
        return resid, extra, imputed
    cache: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def solved(j: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(designs of output j, their weights, their leave-one-out errors (n,))"""
        if j not in cache:
            sel = np.flatnonzero(mask[:, j])
            alpha, inv_diag = _leave_one_out(K[np.ix_(sel, sel)] + noise * np.eye(sel.size),
                                             resid[sel, j])
            loo = np.full(n, np.nan)
            loo[sel] = alpha / inv_diag
            cache[j] = (sel, alpha, loo)
        return cache[j]

    for i in todo:
        e = int(np.flatnonzero(mask[i])[-1])
        _, _, loo_e = solved(e)
        for j in np.flatnonzero(cens[i]):
            sel, alpha, loo_j = solved(int(j))
            both = np.isfinite(loo_e) & np.isfinite(loo_j)
            if both.sum() < MIN_PAIRS:
                continue
            a, b = loo_e[both], loo_j[both]
            beta = float(a @ b) / max(float(a @ a), 1e-300)
            s2 = max(float(np.mean((b - beta * a) ** 2)), 1e-12)
            mu = float(K[i, sel] @ alpha) + beta * float(loo_e[i])
            sd = math.sqrt(s2)
            al = (bound[i, j] - mu) / sd
            tail = float(ndtr(-al))
            if tail > 1e-12:
                lam = math.exp(-0.5 * al * al) / math.sqrt(2.0 * math.pi) / tail
                mu, var = mu + sd * lam, s2 * max(1.0 + al * lam - lam * lam, 1e-6)
            else:                            # the bound far above the continuation
                mu, var = float(bound[i, j]), s2 * 1e-6
            resid[i, j], extra[i, j], imputed[i, j] = mu, var, True
    return resid, extra, imputed


def robust_noise(K: np.ndarray, noise: float, resid: np.ndarray, own: np.ndarray,
                 limit: float) -> np.ndarray:
    """Each design's own noise for :func:`fit_gp`'s ``robust`` fit (the unit-amplitude
    kernel matrix ``K``, the common ``noise``, residuals ``resid`` (n,), the designs' own
    noises so far ``own``): where a design's leave-one-out residual is z > ``limit``
    leave-one-out standard deviations from the others' prediction, its noise grows by
    v ((z / limit)² − 1), v its leave-one-out variance, so that it lies at ``limit``."""
    alpha, d = _leave_one_out(K + np.diag(noise + own), resid)
    z = alpha / np.sqrt(d)
    return np.where(np.abs(z) > limit, own + ((z / limit) ** 2 - 1.0) / d, own)


def fit_gp(x: np.ndarray, y: np.ndarray, mask: np.ndarray, *, fit_outputs: np.ndarray | None
           = None, ridge: float = 1e-3, restarts: int = 3, seed: int = 0,
           noise_bounds: tuple[float, float] = (1e-6, 1.0),
           lower: np.ndarray | None = None, robust: float | None = None,
           robust_passes: int = 3) -> MultiOutputGP:
    """Fit a :class:`MultiOutputGP` to inputs ``x`` (n, k) and outputs ``y`` (n, m) known
    where ``mask`` (n, m).

    The kernel (ARD length scales, noise) is fitted by scikit-learn's marginal-likelihood
    optimiser on the outputs ``fit_outputs`` (default: all) over the designs that have all
    of them, each output's linear-mean residual scaled to unit variance; then each output's
    weights are solved on its own designs.

    ``lower`` (n, m): where finite and the output is not in ``mask``, the design is known to
    lie above it there (censored; :func:`censored_residuals`): the output is imputed and
    solved with the design too (the returned ``mask`` includes it). The kernel, the linear
    means and the scales are those of the observed outputs alone.

    ``robust`` (one output, every design observed): a Huber-type likelihood. A design whose
    leave-one-out residual lies more than ``robust`` standard deviations from the others'
    prediction gets its own noise raised until it lies at ``robust`` (:func:`robust_noise`),
    and the kernel is fitted again with those noises, ``robust_passes`` fits in all (the
    first is the plain one, with ``restarts``; each later one a single local optimisation
    from the kernel of the pass before, since stop 58: on the bending anchors (969 designs)
    it reaches the same kernel as restarting (length scales within 10⁻³, predictions within
    1.1·10⁻⁵ in log P) in 165 s on one core for both later passes of both anchors, where
    the first passes, four starts each, took 692 s (Pc 493 s, Ph 199 s); a whole bending
    refit's anchors 10–14 min a variant instead of 24). The predictive variance carries
    those noises.
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
    if robust is not None and (m != 1 or not rows.all() or lower is not None):
        raise ValueError("fit_gp: robust needs one output observed at every design")
    # robust: each design's own noise (in units of the scaled residual's variance)
    own = np.zeros(n)
    kernel = (ConstantKernel(1.0, (1e-3, 1e3))
              * Matern(length_scale=np.ones(k), length_scale_bounds=(1e-2, 1e3), nu=2.5)
              + WhiteKernel(min(max(1e-2, noise_bounds[0]), noise_bounds[1]), noise_bounds))
    for rpass in range(robust_passes if robust is not None else 1):
        # a robust pass after the first starts from the kernel of the one before, without
        # restarts: the designs' own noises move the optimum, not to another mode
        gpr = GaussianProcessRegressor(kernel, alpha=own[rows] + 1e-10, normalize_y=False,
                                       n_restarts_optimizer=restarts if rpass == 0 else 0,
                                       random_state=seed)
        gpr.fit(x[rows], resid[np.ix_(rows, cols)])
        kernel = gpr.kernel_
        kp = gpr.kernel_.get_params()
        amp = float(kp["k1__k1__constant_value"])
        length = np.asarray(kp["k1__k2__length_scale"], float) * np.ones(k)
        noise = float(kp["k2__noise_level"]) / amp
        K = matern52(x, x, length)
        if robust is not None and rpass < robust_passes - 1:
            own = amp * robust_noise(K, noise, resid[:, 0] / math.sqrt(amp), own / amp,
                                     robust)
    scale = scale * math.sqrt(amp)
    resid = resid / math.sqrt(amp)
    extra = np.zeros((n, m))
    extra[:, 0] += own / amp
    if lower is not None:
        bound = (np.asarray(lower, float)
                 - np.column_stack([np.ones(n), x]) @ coef) / scale[None, :]
        resid, extra, imputed = censored_residuals(K, noise, resid, mask, np.where(
            np.isfinite(lower), bound, np.nan))
        mask = mask | imputed
    weights = np.zeros((n, m))
    for j in range(m):
        sel = mask[:, j]
        if not sel.any():
            continue
        Ks = K[np.ix_(sel, sel)] + np.diag(noise + extra[sel, j])
        weights[sel, j] = cho_solve(cho_factor(Ks, lower=True), resid[sel, j])
    chol = np.linalg.cholesky(K + np.diag(noise + own / amp))
    return MultiOutputGP(x=x, length=length, noise=noise, mask=mask, weights=weights,
                         coef=coef, scale=scale, chol=chol)


#: :func:`fit_gp_cv`'s loss on a leave-one-out residual e (in units of the output's
#: linear-mean residual std): sqrt(e² + CV_LOSS_SOFTNESS²), an absolute error smoothed
#: below this size.
CV_LOSS_SOFTNESS = 0.1


def fit_gp_cv(x: np.ndarray, y: np.ndarray, *, ridge: float = 1e-3,
              noise_bounds: tuple[float, float] = (1e-6, 1.0),
              max_iter: int = 150) -> MultiOutputGP:
    """A one-output GP as :func:`fit_gp` (linear mean, Matérn-5/2 ARD kernel), its length
    scales and noise chosen by leave-one-out cross-validation instead of the marginal
    likelihood: they minimise the mean :data:`CV_LOSS_SOFTNESS`-smoothed absolute
    leave-one-out residual (closed form, Rasmussen & Williams §5.4.2), from unit length
    scales and a noise of 1e-2, by SciPy's L-BFGS-B. The amplitude is the likelihood's
    (rᵀK⁻¹r / n for the chosen K), for the predictive variance.

    Where the kernel is misspecified, as for labels read on curves (a Pc that jumps between
    two readings of a gradual knee), cross-validation gives a better predictor than the
    likelihood (F. Bachoc, Comput. Stat. Data Anal. 66 (2013) 55–69), and with such labels
    the likelihood may settle on a near-interpolating kernel; the two kernels differ, and
    their mean is what ``_fit.ANCHOR_CV`` uses (docs/validation.md §4, stop 55)."""
    from scipy.linalg import cho_factor, cho_solve
    from scipy.optimize import minimize

    x = np.asarray(x, float)
    y = np.asarray(y, float).reshape(len(x))
    n, k = x.shape
    coef = _linear(x, y, ridge)
    r = y - np.column_stack([np.ones(n), x]) @ coef
    sc = max(float(np.std(r)), 1e-6)
    r = r / sc
    eye = np.eye(n)

    def gram(theta: np.ndarray) -> np.ndarray:
        return matern52(x, x, np.exp(theta[:-1])) + math.exp(theta[-1]) * eye

    def loss(theta: np.ndarray) -> float:
        try:
            alpha, inv_diag = _leave_one_out(gram(theta), r)
        except np.linalg.LinAlgError:
            return 1e6
        e = alpha / inv_diag
        return float(np.mean(np.sqrt(e * e + CV_LOSS_SOFTNESS ** 2)))

    bounds = ([(math.log(1e-2), math.log(1e3))] * k
              + [(math.log(noise_bounds[0]), math.log(noise_bounds[1]))])
    start = np.r_[np.zeros(k), math.log(min(max(1e-2, noise_bounds[0]), noise_bounds[1]))]
    theta = minimize(loss, start, method="L-BFGS-B", bounds=bounds,
                     options={"maxiter": max_iter}).x
    K = gram(theta)
    c = cho_factor(K, lower=True)
    a = cho_solve(c, r)
    amp = max(float(r @ a) / n, 1e-12)
    length = np.exp(theta[:-1])
    noise = math.exp(float(theta[-1]))
    return MultiOutputGP(x=x, length=length, noise=noise, mask=np.ones((n, 1), bool),
                         weights=(a / math.sqrt(amp))[:, None], coef=coef[:, None],
                         scale=np.array([sc * math.sqrt(amp)]),
                         chol=np.linalg.cholesky(K))
