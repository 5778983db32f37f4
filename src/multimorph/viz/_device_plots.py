"""Plots and animations of a simulated device (from a ``DeviceResult`` only).

- :func:`module_curves_figure`: each module's motion vs pressure (bend/twist angle in
  degrees, stretch in %), Pc and Ph marked, dominance bands shaded (the sequence chart);
- :func:`shapes_figure`: the device in 3D at chosen pressures, its modules as solid bodies
  (:mod:`multimorph.viz._bodies`);
- :func:`write_animation`: a GIF of the morphing as pressure rises.

Matplotlib through :class:`~matplotlib.figure.Figure` (no pyplot state).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from multimorph.viz._bodies import BODY_POINTS_PER_CELL, draw_bodies

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
    """Per-module curves vs pressure over the sequence chart (bands of dominance): angles
    (deg) on the left axis, stretches (%) on a right axis of their own (one unit per
    axis)."""
    fig = _figure(figsize=(8.0, 5.0), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    names = list(result.strains)
    colour = {n: _COLOURS[i % len(_COLOURS)] for i, n in enumerate(names)}
    for band in result.sequence.bands:
        ax.axvspan(band["from_pressure"] / 1e3, band["to_pressure"] / 1e3,
                   color=colour[band["module"]], alpha=0.08, lw=0)
    modes = {result.strains[n].module.mode for n in names}
    angles = bool(modes - {"stretch"})
    right = ax.twinx() if angles and "stretch" in modes else None
    for n in names:
        strain = result.strains[n]
        mode = strain.module.mode
        y, _ = _display(mode, strain.measure)
        on = right if mode == "stretch" and right is not None else ax
        ls = "-" if mode == "bend" else ("--" if mode == "twist" else ":")
        on.plot(strain.pressure / 1e3, y, ls, color=colour[n], lw=2,
                label=f"{n} ({strain.module.kind})")
        ch = strain.response.characteristic
        for p, marker in ((ch.critical, "o"), (ch.hardening, "s")):
            if p is not None:
                on.plot([p / 1e3], [np.interp(p, strain.pressure, y)], marker, color=colour[n],
                        ms=7, mfc="white")
    ax.set_xlabel("pressure P (kPa)")
    ax.set_ylabel("angle (deg)" if angles else "stretch λ−1 (%)")
    if right is not None:
        right.set_ylabel("stretch λ−1 (%)")
    ax.set_title(f"{result.device.name}: motion per module (o Pc, □ Ph; shading: dominant "
                 f"module)", fontsize=10)
    ax.grid(alpha=0.3)
    handles = [h for a in (ax, right) if a is not None
               for h in a.get_legend_handles_labels()[0]]
    ax.legend(handles=handles, fontsize=8)
    return fig


def _colours(result: Any) -> dict[str, str]:
    return {name: _COLOURS[i % len(_COLOURS)] for i, name in enumerate(result.strains)}


def _limits(shapes: Sequence[Any]) -> tuple[np.ndarray, float]:
    """Centre and half-width (mm) of a cube holding every body of ``shapes``."""
    pts = np.concatenate([np.concatenate([body.points for body in shape.bodies])
                          for shape in shapes]) * 1e3
    reach = max(body.thickness for shape in shapes for body in shape.bodies) * 1e3
    centre = 0.5 * (pts.max(axis=0) + pts.min(axis=0))
    half = 0.5 * float(np.max(pts.max(axis=0) - pts.min(axis=0))) + 0.6 * reach + 1e-9
    return centre, half


def _legend_handles(result: Any, colour: dict[str, str]) -> list[Any]:
    """One entry per module: its name and kind (× copies)."""
    from matplotlib.patches import Patch

    handles = []
    for name, strain in result.strains.items():
        module = strain.module
        copies = f" ×{module.count}" if module.count > 1 else ""
        handles.append(Patch(facecolor=colour[name], label=f"{name} ({module.kind}){copies}"))
    return handles


def _draw_device(ax: Any, result: Any, shape: Any, colour: dict[str, str],
                 centre: np.ndarray, half: float, *, title: str) -> None:
    """The bodies of ``shape`` on ``ax``: equal axes in mm, the pressure in the title, a
    note in red where the rod model stops being physical."""
    draw_bodies(ax, shape, colour)
    for k, axis in enumerate("xyz"):
        getattr(ax, f"set_{axis}lim")(centre[k] - half, centre[k] + half)
        getattr(ax, f"set_{axis}label")(f"{axis} (mm)", fontsize=7, labelpad=1)
    ax.set_box_aspect((1.0, 1.0, 1.0), zoom=0.82)  # room for the z label
    ax.tick_params(labelsize=6, pad=0)
    ax.set_title(title, fontsize=9, y=0.95)  # inside the figure above the zoomed box
    notes = shape.notes()
    if notes:
        ax.text2D(0.0, 0.0, "\n".join(["note: self-contact is not modelled", *notes]),
                  transform=ax.transAxes, fontsize=6, color="tab:red", va="bottom",
                  bbox={"facecolor": "white", "alpha": 0.85, "edgecolor": "none"})


def shapes_figure(result: Any, pressures: Sequence[float]) -> Any:
    """3D snapshots (mm) of the device's bodies at ``pressures`` (Pa): every module its
    cell's cross-section swept along the rod (partitions darker, a stripe on the top face
    that shows twist), hubs grey, one legend entry per module."""
    n = len(pressures)
    fig = _figure(figsize=(3.8 * n, 4.8), layout="constrained")
    colour = _colours(result)
    shapes = [result.bodies(p, BODY_POINTS_PER_CELL) for p in pressures]
    centre, half = _limits(shapes)
    for i, (p, shape) in enumerate(zip(pressures, shapes, strict=True)):
        ax = fig.add_subplot(1, n, i + 1, projection="3d")
        _draw_device(ax, result, shape, colour, centre, half, title=f"P = {p / 1e3:.3g} kPa")
    fig.legend(handles=_legend_handles(result, colour), loc="outside lower center",
               ncols=min(len(colour), 4), fontsize=8, title=result.device.name,
               title_fontsize=9)
    return fig


def write_animation(result: Any, path: str | os.PathLike[str], *, frames: int = 30,
                    fps: int = 8, progress: Callable[[int, int], None] | None = None) -> None:
    """Write a GIF of the device morphing from 0 to its maximum pressure;
    ``progress(done, total)`` after each frame drawn."""
    from matplotlib.animation import FuncAnimation, PillowWriter

    pressures = np.linspace(0.0, result.pmax, frames)
    colour = _colours(result)
    centre, half = _limits([result.bodies(float(p)) for p in pressures])
    fig = _figure(figsize=(5.0, 5.4), layout="constrained")
    ax = fig.add_subplot(1, 1, 1, projection="3d")
    fig.legend(handles=_legend_handles(result, colour), loc="outside lower center",
               ncols=min(len(colour), 3), fontsize=7)

    def draw(i: int) -> list[Any]:
        ax.cla()
        p = float(pressures[i])
        _draw_device(ax, result, result.bodies(p, BODY_POINTS_PER_CELL), colour, centre, half,
                     title=f"{result.device.name}\nP = {p / 1e3:.3g} kPa")
        return []

    anim = FuncAnimation(fig, draw, frames=frames, blit=False)
    anim.save(str(path), writer=PillowWriter(fps=fps),
              progress_callback=(None if progress is None
                                 else lambda i, n: progress(i + 1, n)))
