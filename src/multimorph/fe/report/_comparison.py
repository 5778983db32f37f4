"""``comparison.png``: the reduced model's curve against FE's, Pc and Ph of both marked.

:func:`comparison_curves` reads any comparison :func:`~multimorph.fe.analyses.run_job`
makes (a cell's ``Comparison`` or ``ShearComparison``, a device's or a twisting module's
dict) into plain :class:`ComparisonCurve` values; :func:`plot_comparison` draws one panel
per curve (per module for a device). Pressures in Pa inside, kPa on the axes.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["ComparisonCurve", "comparison_curves", "plot_comparison"]

#: Axis label of each compared quantity.
QUANTITY_LABELS = {
    "curvature": "curvature κ (1/m)",
    "axial_stretch": "axial stretch λ (-)",
    "shear": "strip shear γ (-)",
    "bend_angle_deg": "bend angle (deg)",
    "twist_angle_abs_deg": "|twist angle| (deg)",
    "twist_angle_deg": "twist angle in the sense of the tilt (deg)",
}


@dataclass(frozen=True)
class ComparisonCurve:
    """One quantity against pressure from the reduced model and from FE.

    Parameters
    ----------
    name : str
        What it is of: ``"cell"``, a module's name.
    quantity : str
        A key of :data:`QUANTITY_LABELS`.
    model : str
        The reduced model (``"calibrated"``, ``"ritz"``).
    pressure_model, value_model, pressure_fe, value_fe : ndarray
        The two curves (Pa; the quantity's unit).
    pc_model, ph_model, pc_fe, ph_fe : float or None
        Critical and hardening pressures (Pa), None where not reached or not defined.
    """

    name: str
    quantity: str
    model: str
    pressure_model: np.ndarray
    value_model: np.ndarray
    pressure_fe: np.ndarray
    value_fe: np.ndarray
    pc_model: float | None = None
    ph_model: float | None = None
    pc_fe: float | None = None
    ph_fe: float | None = None


def _array(values: Any) -> np.ndarray:
    return np.asarray(values, float)


def comparison_curves(comparison: Any, *, model: str | None = None
                      ) -> list[ComparisonCurve]:
    """The curves of a comparison with FE: a cell's κ (or stretch, for a stretching cell)
    or a tilted strip's shear, every module of a device, a twisting module's twist angle.

    ``model`` names the reduced model where the comparison does not (default ``"ritz"``,
    what a cell comparison runs).
    """
    if isinstance(comparison, Mapping) and "twist_deg_fe" in comparison:
        P = _array(comparison["pressure_pa"])
        return [ComparisonCurve(
            str(comparison["module"]), "twist_angle_deg",
            model or str(comparison.get("model", "ritz")), P,
            _array(comparison["twist_deg_rom"]), P, _array(comparison["twist_deg_fe"]),
            comparison["pc_rom"], comparison["ph_rom"], comparison["pc_fe"],
            comparison["ph_fe"])]
    if isinstance(comparison, Mapping):  # a device: per module
        return [ComparisonCurve(
            f"{name} ({entry['kind']})" if "kind" in entry else name,
            entry["curves"]["quantity"], model or str(entry.get("model", "ritz")),
            _array(entry["curves"]["pressure_pa_rom"]), _array(entry["curves"]["rom"]),
            _array(entry["curves"]["pressure_pa_fe"]), _array(entry["curves"]["fe"]),
            entry["pc_rom"], entry["ph_rom"], entry["pc_fe"], entry["ph_fe"])
            for name, entry in comparison.items() if "curves" in entry]
    label = model or str(comparison.meta.get("model", "ritz"))
    P = _array(comparison.pressure)
    if hasattr(comparison, "shear_fe"):  # a tilted strip: no Pc, Ph of its shear
        return [ComparisonCurve("cell", "shear", label, P, _array(comparison.shear_rom), P,
                                _array(comparison.shear_fe))]
    stretching = comparison.signal == "axial_stretch"
    rom, fe = ((comparison.stretch_rom, comparison.stretch_fe) if stretching
               else (comparison.kappa_rom, comparison.kappa_fe))
    return [ComparisonCurve("cell", "axial_stretch" if stretching else "curvature", label,
                            P, _array(rom), P, _array(fe), comparison.pc_rom,
                            comparison.ph_rom, comparison.pc_fe, comparison.ph_fe)]


def _marks(ax: Any, P: np.ndarray, y: np.ndarray, pc: float | None, ph: float | None,
           colour: str) -> None:
    """Pc (circle) and Ph (square) on a curve, read off it at those pressures."""
    for p, marker in ((pc, "o"), (ph, "s")):
        if p is not None and len(P) and P.min() <= p <= P.max():
            ax.plot([p / 1e3], [np.interp(p, P, y)], marker, color=colour, ms=7,
                    mfc="white", mew=1.8, zorder=3)


def _words(p: float | None) -> str:
    return "not reached" if p is None else f"{p / 1e3:.3g} kPa"


def plot_comparison(curves: Sequence[ComparisonCurve], path: Path | str, *,
                    title: str = "reduced model vs 3D FE") -> Any:
    """Draw ``curves`` (one panel each) into ``path`` (PNG); return the figure.

    FE in black, the reduced model dashed in colour; Pc (○) and Ph (□) of both marked on
    their curves and named in the legend (kPa, or "not reached").
    """
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    n = max(1, len(curves))
    cols = min(n, 3)
    rows = -(-n // cols)
    fig = Figure(figsize=(4.4 * cols, 3.6 * rows + 0.4), layout="constrained")
    for i, curve in enumerate(curves):
        ax = fig.add_subplot(rows, cols, i + 1)
        ax.plot(curve.pressure_fe / 1e3, curve.value_fe, "-", color="k", lw=2)
        ax.plot(curve.pressure_model / 1e3, curve.value_model, "--", color="tab:blue", lw=2)
        _marks(ax, curve.pressure_fe, curve.value_fe, curve.pc_fe, curve.ph_fe, "k")
        _marks(ax, curve.pressure_model, curve.value_model, curve.pc_model, curve.ph_model,
               "tab:blue")
        ax.legend(handles=[
            Line2D([], [], color="k", lw=2, label=f"3D FE: Pc {_words(curve.pc_fe)}, "
                                                  f"Ph {_words(curve.ph_fe)}"),
            Line2D([], [], color="tab:blue", ls="--", lw=2,
                   label=f"{curve.model} model: Pc {_words(curve.pc_model)}, "
                         f"Ph {_words(curve.ph_model)}"),
            Line2D([], [], ls="", marker="o", color="0.3", mfc="white", label="Pc"),
            Line2D([], [], ls="", marker="s", color="0.3", mfc="white", label="Ph")],
            fontsize=7, loc="best")
        ax.set_xlabel("pressure P (kPa)")
        ax.set_ylabel(QUANTITY_LABELS.get(curve.quantity, curve.quantity))
        ax.set_title(curve.name, fontsize=10)
        ax.grid(alpha=0.3)
    fig.suptitle(title, fontsize=11)
    fig.savefig(path, dpi=120)
    return fig
