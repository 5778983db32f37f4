"""Plots and animations of a simulated device (from a ``DeviceResult`` only).

- :func:`module_curves_figure`: each module's motion vs pressure (bend/twist angle in
  degrees, stretch in %), Pc and Ph marked, dominance bands shaded (the sequence chart);
- :func:`shapes_figure`: 3D centre lines of every module at chosen pressures;
- :func:`write_animation`: a GIF of the morphing as pressure rises.

Matplotlib through :class:`~matplotlib.figure.Figure` (no pyplot state).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

__all__ = ["module_curves_figure", "shapes_figure", "write_animation"]

_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")


def _figure(**kw: Any) -> Any:
    from matplotlib.figure import Figure

    return Figure(**kw)


def _display(mode: str, measure: np.ndarray) -> tuple[np.ndarray, str]:
    if mode == "stretch":
        return 100.0 * measure, "stretch λ−1 (%)"
    return np.degrees(measure), f"{mode} angle (deg)"


def module_curves_figure(result: Any) -> Any:
    """Per-module curves vs pressure over the sequence chart (bands of dominance)."""
    fig = _figure(figsize=(8.0, 5.0), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    names = list(result.strains)
    colour = {n: _COLOURS[i % len(_COLOURS)] for i, n in enumerate(names)}
    for band in result.sequence.bands:
        ax.axvspan(band["from_pressure"] / 1e3, band["to_pressure"] / 1e3,
                   color=colour[band["module"]], alpha=0.08, lw=0)
    modes = {result.strains[n].module.mode for n in names}
    for n in names:
        strain = result.strains[n]
        y, _ = _display(strain.module.mode, strain.measure)
        kind = strain.module.mode
        ls = "-" if kind == "bend" else ("--" if kind == "twist" else ":")
        ax.plot(strain.pressure / 1e3, y, ls, color=colour[n], lw=2, label=f"{n} ({kind})")
        ch = strain.response.characteristic
        for p, marker in ((ch.critical, "o"), (ch.hardening, "s")):
            if p is not None:
                ax.plot([p / 1e3], [np.interp(p, strain.pressure, y)], marker, color=colour[n],
                        ms=7, mfc="white")
    ax.set_xlabel("pressure P (kPa)")
    ax.set_ylabel(" / ".join(sorted({_display(mode, np.zeros(1))[1] for mode in modes})))
    ax.set_title(f"{result.device.name}: motion per module (o Pc, □ Ph; shading: dominant "
                 f"module)", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def _draw_shape(ax: Any, lines: dict[str, np.ndarray], colour: dict[str, str]) -> None:
    for key, pts in lines.items():
        name = key.split("#")[0]
        ax.plot(pts[:, 0] * 1e3, pts[:, 1] * 1e3, pts[:, 2] * 1e3, color=colour[name], lw=2.5)


def _limits(result: Any, pressures: Sequence[float]) -> tuple[np.ndarray, float]:
    pts = np.concatenate([np.concatenate(list(result.shape(p).values()))
                          for p in pressures]) * 1e3
    centre = 0.5 * (pts.max(axis=0) + pts.min(axis=0))
    half = 0.55 * float(np.max(pts.max(axis=0) - pts.min(axis=0))) + 1e-9
    return centre, half


def shapes_figure(result: Any, pressures: Sequence[float]) -> Any:
    """3D snapshots (mm) of the device's centre lines at ``pressures`` (Pa)."""
    n = len(pressures)
    fig = _figure(figsize=(3.6 * n, 3.8), layout="constrained")
    colour = {name: _COLOURS[i % len(_COLOURS)] for i, name in enumerate(result.strains)}
    centre, half = _limits(result, pressures)
    for i, p in enumerate(pressures):
        ax = fig.add_subplot(1, n, i + 1, projection="3d")
        _draw_shape(ax, result.shape(p), colour)
        for k, axis in enumerate("xyz"):
            getattr(ax, f"set_{axis}lim")(centre[k] - half, centre[k] + half)
        ax.set_title(f"P = {p / 1e3:.3g} kPa", fontsize=9)
        ax.set_xlabel("x (mm)", fontsize=7)
        ax.set_ylabel("y (mm)", fontsize=7)
        ax.set_zlabel("z (mm)", fontsize=7)
        ax.tick_params(labelsize=6)
    return fig


def write_animation(result: Any, path: str | os.PathLike[str], *, frames: int = 30,
                    fps: int = 8, progress: Callable[[int, int], None] | None = None) -> None:
    """Write a GIF of the device morphing from 0 to its maximum pressure;
    ``progress(done, total)`` after each frame drawn."""
    from matplotlib.animation import FuncAnimation, PillowWriter

    pressures = np.linspace(0.0, result.pmax, frames)
    colour = {name: _COLOURS[i % len(_COLOURS)] for i, name in enumerate(result.strains)}
    centre, half = _limits(result, [0.0, result.pmax * 0.5, result.pmax])
    fig = _figure(figsize=(4.5, 4.5))
    ax = fig.add_subplot(1, 1, 1, projection="3d")

    def draw(i: int) -> list[Any]:
        ax.cla()
        _draw_shape(ax, result.shape(float(pressures[i])), colour)
        for k, axis in enumerate("xyz"):
            getattr(ax, f"set_{axis}lim")(centre[k] - half, centre[k] + half)
        ax.set_title(f"{result.device.name}\nP = {pressures[i] / 1e3:.3g} kPa", fontsize=9)
        ax.tick_params(labelsize=6)
        return []

    anim = FuncAnimation(fig, draw, frames=frames, blit=False)
    anim.save(str(path), writer=PillowWriter(fps=fps),
              progress_callback=(None if progress is None
                                 else lambda i, n: progress(i + 1, n)))
