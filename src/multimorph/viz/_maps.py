"""Design maps from sweep results (plots from results only; no model is run here).

Three paper-style figures (Jeong et al. 2023, Fig. 4E–F), drawn from an xarray results
dataset as written by :mod:`multimorph.sweep`:

- *families*: dimensionless curvature κd/(2π) vs P/μ, one curve per value of one swept
  parameter (the others held at their middle values), Pc marked;
- *Pc line*: Pc/μ (and Ph/μ) vs one parameter, one line per value of a second one; for the
  modulus ``mu`` itself Pc in kPa (Pc/μ is constant by Buckingham scaling);
- *Pc contours*: Pc/μ over two parameters (grid or scattered designs), failed and invalid
  designs marked.

Matplotlib is used through :class:`matplotlib.figure.Figure` (no pyplot, no global state).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from multimorph.errors import MultimorphError

__all__ = ["design_maps", "families_figure", "model_note", "pc_contour_figure",
           "pc_line_figure", "resolve_variable"]

_MODULI = {"mu", "mu_b", "param_mu"}


def _safe(name: str) -> str:
    return name.replace("/", "_").replace(".", "_")


def swept_parameters(ds: Any) -> list[str]:
    """Names of the swept parameters, in spec order."""
    return list(json.loads(ds.attrs.get("parameters", "[]")))


def resolve_variable(ds: Any, name: str) -> tuple[str, str]:
    """(variable, label) in ``ds`` for a parameter or ratio name such as ``"ht/d"``.

    Looks for the swept parameter first (``param_ht_d``), then a design-table variable
    (``ht_d``, ``top_wall``, ``mu``).

    Raises
    ------
    MultimorphError
        The name is neither; the message lists what is available.
    """
    for var in (f"param_{_safe(name)}", _safe(name), name):
        if var in ds.variables and ds[var].dims == ("design",):
            return var, name
    avail = swept_parameters(ds) + [v for v in ("ht_d", "ws_d", "df_d", "hb_d", "w_d", "h_d",
                                                "mu", "mu_b") if v in ds]
    raise MultimorphError(f"no parameter {name!r} in these results; available: "
                          f"{', '.join(avail)}")


def _is_modulus(var: str) -> bool:
    return var in _MODULI or var.startswith("param_cell_material_mu")


#: How far each cell model is from 3D FE, in a figure title's few words.
_MODEL_WORDS = {"calibrated-fast": "corrected against 3D FE",
                "calibrated": "corrected against 3D FE",
                "ritz": "Pc about 2 × the 3D FE's", "fe": "3D FE"}


def model_note(ds: Any) -> str:
    """Which cell model drew a map, for its title: the sweep's model, and how many of its
    designs another model answered (a calibrated model's cells outside its box: Ritz).
    Empty for results that do not say."""
    from multimorph.sweep import answered_by

    if not ds.attrs.get("backend") or "status" not in ds:
        return ""
    model, counts = answered_by(ds)
    words = _MODEL_WORDS.get(model)
    note = f"{model} model" + (f" ({words})" if words else "")
    for other, n in sorted(counts.items()):
        if other != model:
            note += f"; {n} design{'s' if n != 1 else ''} by the {other} model"
            if model.startswith("calibrated") and other == "ritz":
                note += " (outside its box)"
    return note


def _titled(ax: Any, ds: Any, title: str) -> None:
    note = model_note(ds).replace("; ", "\n")
    ax.set_title(title + (f"\n{note}" if note else ""), fontsize=9 if note else None)


def _ok(ds: Any) -> np.ndarray:
    return np.asarray(ds["status"].values == "ok")


def _pc_values(ds: Any, x_var: str, which: str = "critical_pressure") -> tuple[np.ndarray, str]:
    pc = np.asarray(ds[which].values, float)
    if _is_modulus(x_var):
        return pc / 1e3, f"{'Pc' if which == 'critical_pressure' else 'Ph'} (kPa)"
    mu = np.asarray(ds["mu"].values, float)
    return pc / mu, f"{'Pc' if which == 'critical_pressure' else 'Ph'}/μ"


def _unit_scale(ds: Any, var: str) -> tuple[float, str]:
    unit = ds[var].attrs.get("unit", "")
    if unit == "m":
        return 1e3, " (mm)"
    if unit == "Pa":
        return 1e-3, " (kPa)"
    return 1.0, ""


def families_figure(ds: Any, x: str, *, max_curves: int = 12) -> Any:
    """κd/(2π) vs P/μ for designs differing in ``x`` (other parameters at middle values)."""
    from matplotlib import colormaps
    from matplotlib.figure import Figure

    if "curve_pressure" not in ds:
        raise MultimorphError("these results have no curves (add \"curves\" to sweep.outputs)")
    x_var, label = resolve_variable(ds, x)
    sel = _ok(ds) & (np.asarray(ds["n_points"].values) > 0)
    for other in swept_parameters(ds):
        ov, _ = resolve_variable(ds, other)
        if ov == x_var:
            continue
        vals = np.unique(np.asarray(ds[ov].values)[sel])
        if 1 < vals.size <= 50:  # a grid: hold the other parameter at its middle value
            mid = vals[(vals.size - 1) // 2]
            sel &= np.isclose(np.asarray(ds[ov].values), mid)
    idx = np.flatnonzero(sel)
    if idx.size == 0:
        raise MultimorphError("no successful designs with curves to plot")
    xv = np.asarray(ds[x_var].values, float)
    idx = idx[np.argsort(xv[idx], kind="stable")]
    if idx.size > max_curves:
        idx = idx[np.unique(np.linspace(0, idx.size - 1, max_curves).round().astype(int))]
    fig = Figure(figsize=(5.5, 4.2), layout="constrained")
    ax = fig.add_subplot()
    cmap = colormaps["viridis"]
    lo, hi = float(xv[idx].min()), float(xv[idx].max())
    scale, unit = _unit_scale(ds, x_var)
    d = np.asarray(ds["length"].values, float)
    mu = np.asarray(ds["mu"].values, float)
    for k, i in enumerate(idx):
        n = int(ds["n_points"].values[i])
        p = np.asarray(ds["curve_pressure"].values[i, :n]) / mu[i]
        kd = np.asarray(ds["curve_curvature"].values[i, :n]) * d[i] / (2 * np.pi)
        c = cmap(0.5 if hi == lo else (xv[i] - lo) / (hi - lo))
        ax.plot(p, kd, color=c, lw=1.5, label=f"{label} = {xv[i] * scale:.3g}{unit}")
        if "critical_pressure" in ds and np.isfinite(ds["critical_pressure"].values[i]):
            ax.plot(ds["critical_pressure"].values[i] / mu[i],
                    ds["curvature_at_critical"].values[i] * d[i] / (2 * np.pi), "o", color=c,
                    ms=4)
        del k
    ax.set_xlabel("P/μ")
    ax.set_ylabel("κd/(2π)")
    _titled(ax, ds, f"curvature families over {label} (dots: Pc)")
    ax.legend(fontsize=7, loc="upper left")
    ax.grid(alpha=0.3)
    return fig


def pc_line_figure(ds: Any, x: str, group: str | None = None) -> Any:
    """Pc (and Ph) vs ``x``; one line per value of ``group`` (another swept parameter)."""
    from matplotlib import colormaps
    from matplotlib.figure import Figure

    if "critical_pressure" not in ds:
        raise MultimorphError("these results have no characteristic pressures "
                              "(add \"characteristic\" to sweep.outputs)")
    x_var, label = resolve_variable(ds, x)
    ok = _ok(ds)
    xv = np.asarray(ds[x_var].values, float)
    pc, ylab = _pc_values(ds, x_var)
    ph, _ = _pc_values(ds, x_var, "hardening_pressure")
    groups: list[tuple[str, np.ndarray]] = [("", ok)]
    if group is not None:
        g_var, g_label = resolve_variable(ds, group)
        gv = np.asarray(ds[g_var].values, float)
        vals = np.unique(gv[ok])
        if vals.size > 8:
            vals = vals[np.unique(np.linspace(0, vals.size - 1, 8).round().astype(int))]
        gs, gu = _unit_scale(ds, g_var)
        groups = [(f"{g_label} = {v * gs:.3g}{gu}", ok & np.isclose(gv, v)) for v in vals]
    fig = Figure(figsize=(5.5, 4.2), layout="constrained")
    ax = fig.add_subplot()
    cmap = colormaps["viridis"]
    scale, unit = _unit_scale(ds, x_var)
    for k, (name, members) in enumerate(groups):
        i = np.flatnonzero(members)
        i = i[np.argsort(xv[i], kind="stable")]
        c = cmap(k / max(len(groups) - 1, 1)) if len(groups) > 1 else "C0"
        ax.plot(xv[i] * scale, pc[i], "o-", color=c, ms=3, label=f"Pc {name}".strip())
        if np.isfinite(ph[i]).any():
            ax.plot(xv[i] * scale, ph[i], "s--", color=c, ms=3, alpha=0.6,
                    label=f"Ph {name}".strip())
    bad = ~ok & np.isfinite(xv)
    if bad.any():
        ax.plot(xv[bad] * scale, np.zeros(bad.sum()), "x", color="red",
                label="failed / invalid")
    ax.set_xlabel(f"{label}{unit}")
    ax.set_ylabel(ylab)
    _titled(ax, ds, f"{ylab.split(' ')[0]} vs {label}")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    return fig


def pc_contour_figure(ds: Any, x: str, y: str) -> Any:
    """Filled contours of Pc/μ (Pc in kPa when a modulus is an axis) over ``x`` and ``y``."""
    from matplotlib.figure import Figure
    from matplotlib.tri import Triangulation

    x_var, xl = resolve_variable(ds, x)
    y_var, yl = resolve_variable(ds, y)
    if "critical_pressure" not in ds:
        raise MultimorphError("these results have no characteristic pressures")
    xv = np.asarray(ds[x_var].values, float)
    yv = np.asarray(ds[y_var].values, float)
    pc, zlab = _pc_values(ds, x_var if _is_modulus(x_var) else y_var)
    ok = _ok(ds) & np.isfinite(pc)
    xs, xu = _unit_scale(ds, x_var)
    ys, yu = _unit_scale(ds, y_var)
    fig = Figure(figsize=(5.5, 4.4), layout="constrained")
    ax = fig.add_subplot()
    if ok.sum() >= 3 and np.unique(xv[ok]).size > 1 and np.unique(yv[ok]).size > 1:
        # triangulate in normalised coordinates so unequal axis ranges do not skew it
        def nrm(v: np.ndarray) -> np.ndarray:
            span = float(np.ptp(v[ok])) or 1.0
            return (v - float(v[ok].min())) / span
        tri = Triangulation(nrm(xv)[ok], nrm(yv)[ok])
        tri.x, tri.y = xv[ok] * xs, yv[ok] * ys
        cs = ax.tricontourf(tri, pc[ok], levels=14, cmap="viridis")
        ax.tricontour(tri, pc[ok], levels=7, colors="k", linewidths=0.5)
        fig.colorbar(cs, ax=ax, label=zlab)
    else:
        sc = ax.scatter(xv[ok] * xs, yv[ok] * ys, c=pc[ok], cmap="viridis")
        fig.colorbar(sc, ax=ax, label=zlab)
    ax.plot(xv[ok] * xs, yv[ok] * ys, ".", color="k", ms=2)
    bad = ~ok & np.isfinite(xv) & np.isfinite(yv)
    if bad.any():
        ax.plot(xv[bad] * xs, yv[bad] * ys, "x", color="red", label="failed / invalid / no Pc")
        ax.legend(fontsize=7)
    ax.set_xlabel(f"{xl}{xu}")
    ax.set_ylabel(f"{yl}{yu}")
    _titled(ax, ds, f"{zlab.split(' ')[0]} over {xl} and {yl}")
    return fig


def design_maps(ds: Any, out: str | os.PathLike[str], *, x: str | None = None,
                y: str | None = None, fmt: str = "png") -> list[Path]:
    """Write the design maps of a results dataset into ``out``; returns the files.

    Parameters
    ----------
    ds : xarray.Dataset
        Sweep results (:func:`multimorph.sweep.open_results`).
    out : path
        Folder for the figures.
    x, y : str, optional
        Parameters for the axes (``"ht/d"``, ``"cell.top_wall"``, ``"mu"`` …); default: the
        first and second swept parameters. With ``y`` a contour map is drawn too.
    fmt : {"png", "svg", "pdf"}
    """
    params = swept_parameters(ds)
    if x is None:
        if not params:
            raise MultimorphError("results name no swept parameter; pass --x")
        x = params[0]
    if y is None and len(params) > 1:
        y = next(p for p in params if resolve_variable(ds, p)[0] != resolve_variable(ds, x)[0])
    outdir = Path(out)
    outdir.mkdir(parents=True, exist_ok=True)
    files: list[Path] = []

    def save(fig: Any, stem: str) -> None:
        f = outdir / f"{stem}.{fmt}"
        fig.savefig(f, dpi=150)
        files.append(f)

    sx = _safe(x)
    if "curve_pressure" in ds:
        save(families_figure(ds, x), f"families_{sx}")
    if "critical_pressure" in ds:
        save(pc_line_figure(ds, x, y), f"pc_vs_{sx}")
        if y is not None:
            save(pc_contour_figure(ds, x, y), f"pc_map_{sx}__{_safe(y)}")
    return files
