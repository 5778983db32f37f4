"""Plots of material fits: test data against the fitted law, with the Drucker-stable band."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from multimorph.materials import FitResult, LoadCurve, Material

__all__ = ["plot_fit", "plot_fit_grid"]

#: Stresses on every fit panel: kPa (one unit across panels and commands).
STRESS_UNIT = ("kPa", 1e3)

_CASE_TITLES = {"uniaxial": "uniaxial tension", "equibiaxial": "equibiaxial tension",
                "pure_shear": "pure shear"}


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _model_curve(material: Material, case: str, lam_max: float) -> tuple[np.ndarray, np.ndarray]:
    from multimorph.materials import stretches

    lam = np.linspace(1.0, lam_max, 300)
    lam = lam[material.lockup_fraction(*stretches(case, lam)) < 0.98]
    return lam, np.asarray(material.nominal_stress(case, lam))


def _stable_band(result: FitResult, case: str) -> tuple[float, float]:
    lo, hi = result.stability.stretch_range
    c_bad, t_bad = result.stability.first_unstable.get(case, (None, None))
    return (c_bad if c_bad is not None else lo), (t_bad if t_bad is not None else hi)


def _draw(ax: Any, result: FitResult, curve: LoadCurve, *, others: Sequence[FitResult] = (),
          stress_unit: tuple[str, float] = STRESS_UNIT, legend: bool = True) -> None:
    unit, div = stress_unit
    lo, hi = result.stretch_range
    lam, p = curve.stretch, curve.stress
    inside = (lam >= lo) & (lam <= hi)
    lam_max = float(lam[inside].max()) if inside.any() else float(lam.max())
    x_max = lam_max * 1.1
    band = _stable_band(result, curve.case)
    ax.axvspan(max(1.0, band[0]), min(x_max, band[1]), color="tab:green", alpha=0.08,
               lw=0, label="Drucker-stable")
    shown = lam <= x_max
    ax.plot(lam[shown & inside], p[shown & inside] / div, ".", ms=3, color="0.2",
            label="data (fitted)")
    if np.any(shown & ~inside):
        ax.plot(lam[shown & ~inside], p[shown & ~inside] / div, ".", ms=3, color="0.7",
                label="data (not fitted)")
    for i, r in enumerate((result, *others)):
        x, y = _model_curve(r.material, curve.case, x_max)
        ax.plot(x, y / div, "-", lw=1.6, color=f"C{i}",
                label=f"{r.material.model} (rel. RMS {r.per_case[curve.case].relative_rms:.1%})"
                if curve.case in r.per_case else r.material.model)
    ax.set_xlim(1.0, x_max)
    ax.set_xlabel("stretch λ (-)")
    ax.set_ylabel(f"nominal stress ({unit})")
    if legend:
        ax.legend(fontsize=7, loc="upper left")




def plot_fit(result: FitResult, curves: Sequence[LoadCurve], path: str | os.PathLike[str], *,
             others: Sequence[FitResult] = (), title: str | None = None) -> None:
    """Save a PNG: one panel per load case with data, the fit(s) and the stable band.

    Parameters
    ----------
    result : FitResult
        The fit to draw (its stretch range decides which points count as fitted).
    curves : sequence of LoadCurve
        The full test data (points outside the fit range are drawn in grey).
    path : path-like
        Output PNG.
    others : sequence of FitResult
        Further fits to overlay.
    """
    plt = _pyplot()
    n = len(curves)
    fig, axes = plt.subplots(1, n, figsize=(4.2 * n, 3.6), squeeze=False)
    for ax, c in zip(axes[0], curves, strict=True):
        _draw(ax, result, c, others=others)
        ax.set_title(_CASE_TITLES.get(c.case, c.case), fontsize=10)
    fig.suptitle(title or f"{result.material.name or 'material'}: {result.material.model} fit",
                 fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_fit_grid(items: Sequence[tuple[str, Sequence[FitResult], LoadCurve]],
                  path: str | os.PathLike[str], *, ncols: int = 4) -> None:
    """Save a grid of uniaxial panels, one per material: ``(title, fits, curve)`` items."""
    plt = _pyplot()
    nrows = max(1, -(-len(items) // ncols))
    fig, axes = plt.subplots(nrows, ncols, figsize=(3.6 * ncols, 2.9 * nrows), squeeze=False)
    for ax in axes.ravel()[len(items):]:
        ax.axis("off")
    for ax, (title, fits, curve) in zip(axes.ravel(), items, strict=False):
        _draw(ax, fits[0], curve, others=fits[1:])
        ax.set_title(title, fontsize=9)
        ax.legend(fontsize=6, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
