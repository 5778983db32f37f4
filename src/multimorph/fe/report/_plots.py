"""FE result plots: pressure against path quantities, and snapshots of the deformed mesh."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from multimorph.fe.analyses import FEDeviceResult, FEResult, FETwistResult

__all__ = ["plot_curves", "plot_device", "plot_hex_snapshots", "plot_path_panels",
           "plot_snapshots", "plot_twist"]


def _pyplot() -> Any:
    """matplotlib's pyplot on the file-only Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_curves(result: FEResult, path: Path) -> None:
    """Pressure against curvature·d, chamber volume ratio and peak stretch (PNG)."""
    plt = _pyplot()
    response = result.response
    curve = response.path
    mu = response.shear_modulus
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.8), constrained_layout=True)
    xs = [(curve.curvature * response.length, "κ d (-)"),
          (curve.extra["volume_ratio"], "V / V0 (-)"),
          (curve.peak_stretch, "peak principal stretch (-)")]
    for ax, (x, label) in zip(axes, xs, strict=True):
        load = curve.pressure / mu
        ax.plot(x, load, "-", color="0.6", lw=1, label="path")
        stable = curve.stable
        ax.plot(np.where(stable, x, np.nan), np.where(stable, load, np.nan), "o-", ms=2.5,
                label="stable")
        if (~stable).any():
            ax.plot(x[~stable], load[~stable], "x", color="C3", ms=4, label="unstable")
        ax.set_xlabel(label)
        ax.set_ylabel("P / μ (-)")
        ax.grid(alpha=0.3)
    marks = response.characteristic
    for val, name, ls in ((marks.critical, "Pc", "--"), (marks.hardening, "Ph", ":")):
        if val is not None:
            for ax in axes:
                ax.axhline(val / mu, color="k", ls=ls, lw=0.8)
            axes[0].text(0.02, val / mu, f" {name}", va="bottom", fontsize=8,
                         transform=axes[0].get_yaxis_transform())
    axes[0].legend(fontsize=8)
    fig.suptitle(f"FE cell path ({result.stats['nfree']} DOF, {result.stats['solver']})")
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_snapshots(result: FEResult, path: Path, count: int = 4) -> None:
    """Side views (y–z) of the deformed cell at a few path points, coloured by stretch."""
    mesh = result.mesh
    plot_hex_snapshots(mesh.points, mesh.cells, result.displacements, result.stretch,
                       result.response.path.pressure, path, count=count)


def plot_hex_snapshots(points: np.ndarray, cells: np.ndarray, displacements: np.ndarray,
                       stretch: np.ndarray, pressure: np.ndarray, path: Path, *,
                       count: int = 4, view: tuple[int, int] = (1, 2), slab: int = 0,
                       slab_side: str = "low", title: str | None = None) -> None:
    """Views of a deformed hex mesh at ``count`` path points, coloured by stretch (PNG).

    The element centroids of one slab (the third of the mesh nearest its ``slab_side``
    along axis ``slab``: the outer face of a half model by default) are projected on the
    plane of the ``view`` axes (0 x, 1 y, 2 z), so walls in front hide nothing behind them.
    """
    plt = _pyplot()
    picks = _snapshot_picks(np.asarray(pressure, dtype=float), count)
    cen0 = points[cells].mean(axis=1)[:, slab]
    lo, hi = float(cen0.min()), float(cen0.max())
    third = (hi - lo) / 3 + 1e-12 * max(abs(hi), 1.0)
    front = cen0 <= lo + third if slab_side == "low" else cen0 >= hi - third
    vmax = float(np.nanmax(stretch[picks][:, front])) if front.any() else 1.0
    fig, axes = plt.subplots(1, len(picks), figsize=(3.2 * len(picks), 3.2),
                             constrained_layout=True, squeeze=False)
    names = "xyz"
    sc = None
    cens = {i: (points + displacements[i])[cells].mean(axis=1)[front] * 1e3 for i in picks}
    both = np.concatenate([c[:, list(view)] for c in cens.values()])
    pad = 0.03 * float(np.ptp(both, axis=0).max())
    lims = [(float(both[:, k].min()) - pad, float(both[:, k].max()) + pad) for k in (0, 1)]
    for ax, i in zip(axes[0], picks, strict=True):
        cen = cens[i]
        sc = ax.scatter(cen[:, view[0]], cen[:, view[1]], c=stretch[i][front], s=6,
                        cmap="viridis", vmin=1.0, vmax=max(vmax, 1.0 + 1e-6))
        ax.set_xlim(*lims[0])
        ax.set_ylim(*lims[1])
        ax.set_aspect("equal")
        ax.set_title(f"P = {float(pressure[i]) / 1e3:.3g} kPa", fontsize=9)
        ax.set_xlabel(f"{names[view[0]]} (mm)")
        ax.set_ylabel(f"{names[view[1]]} (mm)")
    if sc is not None:
        fig.colorbar(sc, ax=axes[0].tolist(), label="max principal stretch", shrink=0.8)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _snapshot_picks(pressure: np.ndarray, count: int) -> list[int]:
    """Path points to show: the first to reach each of ``count`` evenly spaced pressures
    from 0 to the highest, and the last point (a path crowds its points where it balloons,
    so evenly spaced indices would show mostly the end)."""
    n = len(pressure)
    if n == 0:
        return []
    top = float(np.max(pressure))
    picks = {n - 1}
    for t in np.linspace(0.0, top, max(count, 1)):
        picks.add(int(np.argmax(pressure >= t - 1e-12 * max(abs(top), 1.0))))
    return sorted(picks)


def plot_path_panels(pressure: np.ndarray, stable: np.ndarray,
                     panels: Sequence[tuple[str, Mapping[str, np.ndarray]]], path: Path, *,
                     title: str, marks: Sequence[tuple[float, str]] = ()) -> None:
    """Pressure (kPa) against one or more path quantities per panel (PNG).

    ``panels``: (x-axis label, {curve label: values per path point}); unstable points are
    crossed; ``marks`` are horizontal lines (pressure in Pa, label), e.g. Pc and Ph.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(panels), figsize=(4 * len(panels), 3.8),
                             constrained_layout=True, squeeze=False)
    pk = np.asarray(pressure) / 1e3
    stable = np.asarray(stable, dtype=bool)
    for ax, (label, curves) in zip(axes[0], panels, strict=True):
        for k, (name, x) in enumerate(curves.items()):
            x = np.asarray(x, dtype=float)
            ax.plot(x, pk, "-", color=f"C{k}", lw=1, label=name)
            if (~stable).any():
                ax.plot(x[~stable], pk[~stable], "x", color=f"C{k}", ms=4)
        for val, name in marks:
            ax.axhline(val / 1e3, color="k", ls="--", lw=0.7)
            ax.text(0.02, val / 1e3, f" {name}", va="bottom", fontsize=7,
                    transform=ax.get_yaxis_transform())
        ax.set_xlabel(label)
        ax.set_ylabel("P (kPa)")
        ax.grid(alpha=0.3)
        if len(curves) > 1:
            ax.legend(fontsize=7)
    fig.suptitle(title + ("  (x: unstable points)" if (~stable).any() else ""), fontsize=10)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_device(result: FEDeviceResult, folder: Path | str) -> list[str]:
    """``curves.png`` (pressure against every module's bend angle, centroid stretch and
    V/V0, twisting modules' twist angle, and the tip angle; each module's Pc marked) and
    ``snapshots.png`` (side views of the deformed device, coloured by stretch) in
    ``folder``; returns the file names."""
    folder = Path(folder)
    paths = {name: response.path for name, response in result.responses.items()}
    marks = [(pc, f"Pc {name}") for name in paths
             if (pc := result.activation(name)[0]) is not None]
    panels = [("bend angle, module frame (deg)",
               {n: np.degrees(path.extra["bend_angle"]) for n, path in paths.items()}),
              ("centroid stretch (-)", {n: path.axial_stretch for n, path in paths.items()}),
              ("V / V0 (-)", {n: path.extra["volume_ratio"] for n, path in paths.items()}),
              ("tip angle (deg)", {"tip": np.degrees(result.tip_angle)})]
    twisting = [module.name for module in result.mesh.modules if module.kind == "twisting"]
    if twisting:
        panels.insert(1, ("twist angle about the axis (deg)",
                          {n: np.degrees(paths[n].extra["twist_angle"]) for n in twisting}))
    plot_path_panels(
        result.pressure, result.stable, panels,
        folder / "curves.png", marks=marks,
        title=f"FE device {result.device.name} ({result.stats.get('nfree', '?')} DOF)")
    mesh = result.mesh
    plot_hex_snapshots(mesh.points, mesh.cells, result.displacements, result.stretch,
                       result.pressure, folder / "snapshots.png",
                       title="side view (outer third of the half model)" if mesh.half
                       else "side view (the third of the model at the smallest x)")
    return ["curves.png", "snapshots.png"]


def plot_twist(result: FETwistResult, folder: Path | str) -> list[str]:
    """``curves.png`` (pressure against twist angle, axial stretch, V/V0 and peak stretch,
    Pc and Ph marked) and ``snapshots.png`` (the free end third seen along the axis,
    coloured by stretch) in ``folder``; returns the file names."""
    folder = Path(folder)
    curve = result.response.path
    pc, ph = result.activation()
    marks = [(v, k) for v, k in ((pc, "Pc"), (ph, "Ph")) if v is not None]
    plot_path_panels(
        result.pressure, curve.stable,
        [("twist angle, right-handed about +y (deg)", {"twist": np.degrees(result.twist_angle)}),
         ("axial stretch (-)", {"stretch": curve.axial_stretch}),
         ("V / V0 (-)", {"V/V0": curve.extra["volume_ratio"]}),
         ("peak principal stretch (-)", {"peak": curve.peak_stretch})],
        folder / "curves.png", marks=marks,
        title=f"FE twisting module {result.module.name} ({result.stats.get('nfree', '?')} DOF)")
    mesh = result.mesh
    plot_hex_snapshots(mesh.points, mesh.cells, result.displacements, result.stretch,
                       result.pressure, folder / "snapshots.png", view=(0, 2), slab=1,
                       slab_side="high", title="free-end third seen along the axis (x–z)")
    return ["curves.png", "snapshots.png"]
