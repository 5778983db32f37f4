r"""Fitting a strain-energy law to homogeneous test data (uniaxial, equibiaxial, pure shear).

Least squares (:func:`scipy.optimize.least_squares`, trust-region reflective, with bounds)
on the nominal stress. The residual of point *i* of load case *c* is

* ``relative`` (default): :math:`r_i = \sqrt{w_c}\,(P(\lambda_i) - P_i)/P_i`
  (each point counts by its relative error; points with :math:`P_i \le 0` are left out);
* ``absolute``: :math:`r_i = \sqrt{w_c}\,(P(\lambda_i) - P_i)` in Pa.

The model stress :math:`P(\lambda)` and the Jacobian come from JAX (automatic
differentiation through :func:`~multimorph.materials.stress_function`). Bounds keep the
parameters physical (the law's bounds; Gent's :math:`J_m` stays above the largest
:math:`I_1 - 3` in the data, so no point is at lock-up). Cheap laws are started from a few
points and the best optimum is kept. Standard errors are :math:`\sqrt{\mathrm{diag}(s^2
(J^T J)^{-1})}` with :math:`s^2 = \sum r_i^2 / (n - p)`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cache
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from multimorph.errors import FitError, LockupError, SpecError
from multimorph.materials._loadcases import (
    StabilityReport,
    canonical_case,
    drucker_stability,
    stress_function,
    stretches,
)
from multimorph.materials._material import Material, Provenance
from multimorph.materials._readers import LoadCurve, TestData, as_curves
from multimorph.materials._registry import Law, get_law
from multimorph.outcome import Outcome

__all__ = ["CaseStats", "FitResult", "fit_material"]

RESIDUALS = ("relative", "absolute")

_DEFINITIONS = {
    "relative": "relative: r_i = sqrt(w_case) * (P_model(lambda_i) - P_i) / P_i on nominal "
                "stress, minimising sum r_i^2 (points with P_i <= 0 or lambda_i = 1 left out, "
                "and toe points with P_i < toe_filter * mu0 * P_neoHooke(lambda_i)/mu)",
    "absolute": "absolute: r_i = sqrt(w_case) * (P_model(lambda_i) - P_i) in Pa on nominal "
                "stress, minimising sum r_i^2 (points with lambda_i = 1 left out)",
}


@dataclass(frozen=True)
class CaseStats:
    """Goodness of fit for one load case (stresses in Pa).

    Attributes
    ----------
    n : int
        Points fitted.
    r2 : float
        Coefficient of determination of the nominal stress.
    relative_rms : float
        :math:`\\sqrt{\\mathrm{mean}(((P - P_i)/P_i)^2)}` (-).
    median_relative_error, max_relative_error : float
        Median and maximum of :math:`|P - P_i| / |P_i|` (-).
    rms : float
        Root-mean-square stress error (Pa).
    """

    case: str
    n: int
    r2: float
    relative_rms: float
    median_relative_error: float
    max_relative_error: float
    rms: float

    def to_dict(self) -> dict[str, Any]:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class FitResult:
    """Outcome of :func:`fit_material`.

    Attributes
    ----------
    material : Material
        The fitted material (with :class:`Provenance`: data file, fit range and error).
    params, stderr : mapping
        Fitted parameters and their standard errors (SI: Pa or -).
    status : Outcome
        ``CONVERGED``, ``AT_BOUND`` (converged with a parameter on a bound, named in
        :attr:`message`), ``MAX_EVALUATIONS`` or ``FAILED``
        (:class:`~multimorph.outcome.Outcome`; strings ``"converged"`` … in JSON).
    per_case : dict of CaseStats
        R², relative RMS, median relative error per load case.
    relative_rms, median_relative_error : float
        Over all fitted points (-).
    stability : StabilityReport
        Drucker stability of the fitted material per load case.
    """

    material: Material
    params: Mapping[str, float]
    stderr: Mapping[str, float]
    status: Outcome
    message: str
    residual: str
    residual_definition: str
    stretch_range: tuple[float, float]
    n_points: int
    n_excluded: int
    per_case: dict[str, CaseStats]
    relative_rms: float
    median_relative_error: float
    stability: StabilityReport
    n_starts: int = 1
    nfev: int = 0
    weights: Mapping[str, float] = field(default_factory=dict)

    @property
    def success(self) -> bool:
        """Whether the fit converged (also with a parameter on a bound)."""
        return self.status.ok

    @property
    def model(self) -> str:
        return self.material.model

    def predict(self, case: str, stretch: Any) -> np.ndarray:
        """Nominal stress (Pa) of the fitted material."""
        return self.material.nominal_stress(case, stretch)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (SI units)."""
        return {
            "model": self.material.model,
            "name": self.material.name,
            "status": self.status,
            "message": self.message,
            "params": dict(self.params),
            "stderr": dict(self.stderr),
            "units": dict(zip(self.material.law.param_names, self.material.law.param_units,
                              strict=True)),
            "convention": self.material.convention,
            "shear_modulus": self.material.shear_modulus,
            "break_stretch": self.material.break_stretch,
            "residual": self.residual,
            "residual_definition": self.residual_definition,
            "stretch_range": list(self.stretch_range),
            "n_points": self.n_points,
            "n_excluded": self.n_excluded,
            "weights": dict(self.weights),
            "relative_rms": self.relative_rms,
            "median_relative_error": self.median_relative_error,
            "per_case": {k: v.to_dict() for k, v in self.per_case.items()},
            "drucker_stable": self.stability.stable,
            "stability": self.stability.to_dict(),
            "n_starts": self.n_starts,
            "nfev": self.nfev,
            "material": self.material.to_dict(),
        }


# --------------------------------------------------------------------------- kernels
@cache
def _kernels(model: str, cases: tuple[str, ...], kind: str) -> Callable[..., Any]:
    """One jitted kernel per law, tuple of cases and residual kind, returning the model
    stresses, the residual and its Jacobian together (one compilation instead of three)."""
    law = get_law(model)
    names = law.param_names
    fs = [stress_function(law.name, c) for c in cases]

    def stresses(x: Any, scale: Any, lams: Any) -> Any:
        p = {n: x[i] * scale[i] for i, n in enumerate(names)}
        return jnp.concatenate([f(p, lam) for f, lam in zip(fs, lams, strict=True)])

    def residual(x: Any, scale: Any, lams: Any, pd: Any, ws: Any, sref: Any) -> Any:
        # pd, ws: concatenated data and per-point sqrt(weight) (0 on the padding)
        den = pd if kind == "relative" else sref
        return ws * (stresses(x, scale, lams) - pd) / den

    def both(x: Any, scale: Any, lams: Any, pd: Any, ws: Any, sref: Any) -> Any:
        return (stresses(x, scale, lams), residual(x, scale, lams, pd, ws, sref),
                jax.jacfwd(residual, argnums=0)(x, scale, lams, pd, ws, sref))

    return jax.jit(both)


def _bucket(n: int) -> int:
    """Padded length: the next power of two (at least 16)."""
    return max(16, 1 << (int(n) - 1).bit_length())


def _pad(a: np.ndarray, size: int, fill: float) -> np.ndarray:
    out = np.full(size, fill, dtype=float)
    out[: len(a)] = a
    return out


def _nh_shape(case: str, lam: np.ndarray) -> np.ndarray:
    """Neo-Hookean nominal stress per unit shear modulus in ``case`` (-)."""
    if case == "uniaxial":
        return lam - lam**-2.0
    if case == "equibiaxial":
        return lam - lam**-5.0
    return lam - lam**-3.0


def _mu_estimate(curves: Sequence[LoadCurve]) -> float:
    """Neo-Hookean shear modulus (Pa) from the small-stretch points (robust median)."""
    est = []
    for c in curves:
        lam, p = c.stretch, c.stress
        shape = _nh_shape(c.case, lam)
        ok = (np.abs(shape) > 1e-9) & (p > 0)
        if not np.any(ok):
            continue
        lam_ok, ratio = lam[ok], p[ok] / shape[ok]
        small = lam_ok <= max(1.5, float(np.quantile(lam_ok, 0.25)))
        est.append(float(np.median(ratio[small] if small.sum() >= 3 else ratio)))
    if not est:
        raise FitError("cannot estimate a modulus: no point with positive stress")
    return float(np.median(est))


def _starts(law: Law, mu0: float, jm_min: float) -> list[dict[str, float]]:
    base = law.guess(mu0)
    fam = law.family
    if fam == "gent":
        return [{"mu": mu0, "jm": jm} for jm in (max(1.5 * jm_min, 5.0), max(4 * jm_min, 30.0),
                                                 max(20 * jm_min, 200.0))]
    if fam == "arruda-boyce":
        return [{"mu": 0.9 * mu0, "lambda_m": lm} for lm in (2.5, 5.0, 12.0)]
    if fam in ("reduced-polynomial", "yeoh"):
        zero = {k: (0.0 if k != "c10" else mu0 / 2) for k in base}
        return [base, zero]
    if fam == "mooney-rivlin":
        return [base, {"c10": 0.5 * mu0, "c01": 0.0}]
    if fam == "ogden":
        alt = {k: (v * 0.5 if k.startswith("alpha") and abs(v) > 2 else v) for k, v in base.items()}
        return [base, alt]
    return [base]


def _clip_inside(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    span = np.where(np.isfinite(hi - lo), hi - lo, np.maximum(np.abs(x), 1.0))
    eps = 1e-6 * span
    return np.minimum(np.maximum(x, lo + eps), hi - eps)


# --------------------------------------------------------------------------- public
def fit_material(
    model: str,
    data: TestData | LoadCurve | Sequence[LoadCurve] | Mapping[str, Any],
    *,
    order: int | None = None,
    residual: str = "relative",
    stretch_range: float | tuple[float, float] | None = None,
    weights: Mapping[str, float] | None = None,
    initial: Mapping[str, float] | None = None,
    name: str | None = None,
    provenance: Provenance | None = None,
    toe_filter: float | None = 0.1,
    stability_range: tuple[float, float] = (0.1, 10.0),
    max_nfev: int = 3000,
) -> FitResult:
    r"""Fit a law's parameters to homogeneous test data by nonlinear least squares.

    Parameters
    ----------
    model : str
        Law name (``"gent"``, ``"yeoh"``, ``"reduced-polynomial"``, ``"ogden"`` …).
    data : TestData, LoadCurve, sequence of LoadCurve, or mapping
        Test curves; a mapping is ``{case: (stretch, nominal_stress_Pa)}``.
    order : int, optional
        Order N of ``reduced-polynomial`` (1..6, default 6) or ``ogden`` (terms, default 3).
    residual : {"relative", "absolute"}
        Residual definition (see the module docstring).
    stretch_range : float or (float, float), optional
        Fit only points with ``lo <= λ <= hi``; a single number is ``hi`` (the design range,
        e.g. 4). Default: all points.
    weights : mapping, optional
        Weight per load case multiplying its squared residuals (default 1 each).
    initial : mapping, optional
        Start parameters (SI); default: a few starts derived from the data's modulus.
    name : str, optional
        Name of the fitted material (default: the data's name).
    provenance : Provenance, optional
        Source/DOI/licence to record; fit range, error and residual are filled in.
    toe_filter : float or None
        Relative residuals only: leave out points whose secant modulus is below
        ``toe_filter`` times the data's small-strain modulus, i.e.
        :math:`P_i < f\,\mu_0\,g(\lambda_i)` with :math:`g` the neo-Hookean shape
        (specimen slack or load-cell offset at the first points, whose relative error would
        dominate the fit). ``None`` or 0 keeps every positive point.
    stability_range : (float, float)
        Stretch range of the Drucker check (-).
    max_nfev : int
        Function-evaluation limit per start.

    Returns
    -------
    FitResult

    Raises
    ------
    FitError
        Too few points, no positive stresses, or no start gave a finite optimum.

    Examples
    --------
    >>> import numpy as np
    >>> from multimorph.materials import Material, fit_material
    >>> lam = np.linspace(1.1, 3.0, 12)
    >>> true = Material("gent", {"mu": 2e5, "jm": 30.0})
    >>> res = fit_material("gent", {"uniaxial": (lam, true.nominal_stress("uniaxial", lam))})
    >>> str(res.status), round(res.params["mu"]), round(res.params["jm"], 3)
    ('converged', 200000, 30.0)
    """
    from scipy.optimize import least_squares

    if residual not in RESIDUALS:
        raise SpecError(f"residual must be one of {RESIDUALS}, got {residual!r}")
    law = get_law(model, order)
    curves_all = as_curves(data)
    if isinstance(stretch_range, int | float):
        lo, hi = 0.0, float(stretch_range)
    elif stretch_range is None:
        lo, hi = 0.0, math.inf
    else:
        lo, hi = (float(v) for v in stretch_range)
    if not lo < hi or hi <= 1.0:
        raise SpecError(f"stretch_range must be (lo, hi) with lo < hi and hi > 1, "
                        f"got {stretch_range!r}")
    w_in = {canonical_case(k): float(v) for k, v in (weights or {}).items()}
    if any(not (v > 0 and math.isfinite(v)) for v in w_in.values()):
        raise SpecError("weights must be positive numbers")

    curves: list[LoadCurve] = []
    n_excl = 0
    mu_all = _mu_estimate(curves_all) if residual == "relative" and toe_filter else 0.0
    for c in curves_all:
        keep = (c.stretch >= lo) & (c.stretch <= hi) & (c.stretch != 1.0)
        if residual == "relative":
            keep &= c.stress > 0
            if toe_filter:
                keep &= c.stress > toe_filter * mu_all * np.abs(_nh_shape(c.case, c.stretch))
        n_excl += int(np.sum((c.stretch >= lo) & (c.stretch <= hi))) - int(keep.sum())
        if keep.any():
            curves.append(LoadCurve(c.case, c.stretch[keep], c.stress[keep], c.source,
                                    c.break_stretch))
    n = sum(len(c) for c in curves)
    names = law.param_names
    if n <= len(names):
        raise FitError(f"{law.name} has {len(names)} parameters but only {n} usable points "
                       f"in the stretch range [{lo:g}, {hi:g}]")
    cases = tuple(c.case for c in curves)
    # pad every curve to a bucket size so that jitted kernels are reused across data sets
    sizes = [_bucket(len(c)) for c in curves]
    lams = tuple(jnp.asarray(_pad(c.stretch, m, c.stretch[-1]))
                 for c, m in zip(curves, sizes, strict=True))
    ps = tuple(jnp.asarray(_pad(c.stress, m, 1.0)) for c, m in zip(curves, sizes, strict=True))
    ws = tuple(jnp.asarray(_pad(np.full(len(c), math.sqrt(w_in.get(c.case, 1.0))), m, 0.0))
               for c, m in zip(curves, sizes, strict=True))
    all_p = np.concatenate([c.stress for c in curves])
    sref = float(np.median(np.abs(all_p[all_p != 0]))) if np.any(all_p != 0) else 1.0

    scale = np.array([sref if u == "Pa" else 1.0 for u in law.param_units])
    lower = np.array(law.lower, dtype=float)
    upper = np.array(law.upper, dtype=float)
    jm_min = 0.0
    if law.lockup_jm:
        i1m3 = max(float(np.max(np.sum(np.square(stretches(c.case, c.stretch)), axis=0) - 3.0))
                   for c in curves)
        jm_min = max(i1m3, 0.0)
        j = names.index(law.lockup_jm)
        lower[j] = max(lower[j], jm_min * (1.0 + 1e-4) + 1e-9)
    lower_s, upper_s = lower / scale, upper / scale

    kernel = _kernels(law.name, cases, residual)
    args = (jnp.asarray(scale), lams, jnp.concatenate(ps), jnp.concatenate(ws), sref)
    last: dict[str, Any] = {}

    def evaluate(x: np.ndarray) -> dict[str, Any]:
        key = np.asarray(x, float).tobytes()
        if last.get("key") != key:
            m, r, J = kernel(jnp.asarray(x), *args)
            last.update(key=key, m=np.asarray(m), r=np.asarray(r), J=np.asarray(J))
        return last

    def fun(x: np.ndarray) -> np.ndarray:
        return evaluate(x)["r"]

    def jac(x: np.ndarray) -> np.ndarray:
        return evaluate(x)["J"]

    mu0 = _mu_estimate(curves)
    starts = [dict(initial)] if initial is not None else _starts(law, mu0, jm_min)
    best = None
    nfev = 0
    messages = []
    for start in starts:
        try:
            x0 = np.array([float(start[k]) for k in names]) / scale
        except KeyError as exc:
            raise SpecError(f"initial parameters for {law.name} need {exc.args[0]!r}") from None
        x0 = _clip_inside(x0, lower_s, upper_s)
        if not np.all(np.isfinite(fun(x0))):
            messages.append("non-finite residual at start")
            continue
        try:
            sol = least_squares(fun, x0, jac=jac, bounds=(lower_s, upper_s), method="trf",
                                x_scale="jac", max_nfev=max_nfev, xtol=1e-12, ftol=1e-12,
                                gtol=1e-10)
        except (ValueError, FloatingPointError, LockupError) as exc:
            messages.append(str(exc))
            continue
        if not np.all(np.isfinite(sol.fun)):
            messages.append("non-finite residual at optimum")
            continue
        if best is None or sol.cost < best.cost - 1e-14 * max(1.0, best.cost):
            best = sol
        nfev += int(sol.nfev)
    if best is None:
        raise FitError(f"{law.name}: no start converged to a finite optimum ("
                       + "; ".join(sorted(set(messages))) + ")")

    x = best.x
    params = {k: float(v) for k, v in zip(names, x * scale, strict=True)}
    # standard errors in SI from the scaled Jacobian
    J = jac(x) / scale[None, :]
    dof = n - len(names)
    s2 = float(2.0 * best.cost / dof) if dof > 0 else math.nan
    with np.errstate(all="ignore"):
        cov = s2 * np.linalg.pinv(J.T @ J)
    stderr = {k: float(math.sqrt(v)) if v >= 0 else math.nan
              for k, v in zip(names, np.diag(cov), strict=True)}

    at_bound = [k for k, a in zip(names, best.active_mask, strict=True) if a != 0]
    if best.status > 0:
        status = Outcome.AT_BOUND if at_bound else Outcome.CONVERGED
        message = best.message + (f" Parameter(s) on a bound: {', '.join(at_bound)}."
                                  if at_bound else "")
    elif best.status == 0:
        status, message = Outcome.MAX_EVALUATIONS, best.message
    else:
        status, message = Outcome.FAILED, best.message

    data_name = name if name is not None else (data.name if isinstance(data, TestData) else "")
    break_stretch = None
    for c in curves_all:
        if c.case == "uniaxial" and c.break_stretch is not None:
            break_stretch = c.break_stretch
    fit_range = (float(min(c.stretch.min() for c in curves)),
                 float(max(c.stretch.max() for c in curves)))

    m_all = evaluate(x)["m"]
    offsets = np.cumsum([0, *sizes])
    per_case: dict[str, CaseStats] = {}
    all_rel: list[np.ndarray] = []
    for k, c in enumerate(curves):
        m = m_all[offsets[k]: offsets[k] + len(c)]
        d = c.stress
        err = m - d
        nz = d != 0
        rel = err[nz] / d[nz]
        all_rel.append(rel)
        sst = float(np.sum((d - d.mean()) ** 2))
        per_case[c.case] = CaseStats(
            case=c.case, n=len(c),
            r2=float(1.0 - np.sum(err**2) / sst) if sst > 0 else math.nan,
            relative_rms=float(np.sqrt(np.mean(rel**2))) if rel.size else math.nan,
            median_relative_error=float(np.median(np.abs(rel))) if rel.size else math.nan,
            max_relative_error=float(np.max(np.abs(rel))) if rel.size else math.nan,
            rms=float(np.sqrt(np.mean(err**2))),
        )
    rel_all = np.concatenate(all_rel) if all_rel else np.array([])
    rel_rms = float(np.sqrt(np.mean(rel_all**2))) if rel_all.size else math.nan
    med_rel = float(np.median(np.abs(rel_all))) if rel_all.size else math.nan

    prov_src = provenance or Provenance(source=f"fit to {curves_all[0].source or 'data'}",
                                        data_file=curves_all[0].source)
    prov = Provenance(
        source=prov_src.source, doi=prov_src.doi, licence=prov_src.licence,
        data_file=prov_src.data_file, fit_range=fit_range, fit_error=rel_rms,
        residual=_DEFINITIONS[residual]
        + (f"; toe_filter = {toe_filter:g}" if residual == "relative" and toe_filter else "")
        + f"; fit_error = relative RMS over {n} points ({', '.join(cases)})",
        note=prov_src.note,
    )
    material = Material(law.name, params, name=data_name,
                        convention="ogden1972" if law.family == "ogden" else None,
                        break_stretch=break_stretch, provenance=prov)
    stability = drucker_stability(material, stability_range)
    return FitResult(
        material=material, params=params, stderr=stderr, status=status, message=message,
        residual=residual, residual_definition=_DEFINITIONS[residual],
        stretch_range=(lo, hi), n_points=n, n_excluded=n_excl, per_case=per_case,
        relative_rms=rel_rms, median_relative_error=med_rel, stability=stability,
        n_starts=len(starts), nfev=nfev,
        weights={c: w_in.get(c, 1.0) for c in cases},
    )
