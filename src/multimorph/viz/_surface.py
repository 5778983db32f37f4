"""A deformed surface in 3D under a pressure slider (plotly ``Mesh3d`` frames): the
boundary of an FE mesh at a few path points, coloured by the displacement's magnitude.

Only the nodes on the surface are kept and stored as float32 (plotly writes numpy arrays
base64-encoded), so a page holds the surface at every frame in a few MB;
:func:`surface_bytes` says how much before anything is built.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from multimorph.viz._html import plotly, pressure_slider_scene

__all__ = ["surface_bytes", "surface_figure"]

#: Bytes per stored float32 number in the page (base64: 4 bytes → 5.33 characters).
_BYTES_PER_NUMBER = 4 * 4 / 3


def _surface(points: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The surface's node numbers (into ``points``) and its triangles (into those)."""
    nodes, local = np.unique(np.asarray(quads), return_inverse=True)
    local = local.reshape(-1, 4)
    triangles = np.concatenate([local[:, [0, 1, 2]], local[:, [0, 2, 3]]])
    return nodes, triangles


def surface_bytes(quads: np.ndarray, frames: int) -> int:
    """About how many bytes the page's 3D view takes: per frame the surface nodes'
    coordinates and colour, once the triangles."""
    nodes = len(np.unique(np.asarray(quads)))
    return int(_BYTES_PER_NUMBER * (4 * nodes * (frames + 1) + 6 * len(quads)))


def surface_figure(points: np.ndarray, quads: np.ndarray,
                   displacements: Sequence[np.ndarray], pressures: Sequence[float], *,
                   title: str) -> Any:
    """The surface ``quads`` (node numbers, 4 per face) of a mesh with nodes ``points``
    (m), displaced by each of ``displacements`` (m, one per frame) at ``pressures`` (Pa):
    one frame per pressure under a slider, mm on equal axes, coloured by |u| (mm)."""
    go = plotly()
    nodes, triangles = _surface(points, quads)
    base = np.asarray(points, float)[nodes]
    shapes = [((base + np.asarray(u, float)[nodes]) * 1e3).astype(np.float32)
              for u in displacements]
    colour = [(np.linalg.norm(np.asarray(u, float)[nodes], axis=1) * 1e3).astype(np.float32)
              for u in displacements]
    every = np.concatenate(shapes)
    centre = 0.5 * (every.max(axis=0) + every.min(axis=0))
    half = 0.5 * float(np.max(every.max(axis=0) - every.min(axis=0))) * 1.05 + 1e-6
    top = max(float(max(c.max() for c in colour)), 1e-9)
    names = [f"{p / 1e3:.4g}" for p in pressures]

    def trace(xyz: np.ndarray, value: np.ndarray, *, full: bool) -> Any:
        extra = ({"i": triangles[:, 0].astype(np.int32), "j": triangles[:, 1].astype(np.int32),
                  "k": triangles[:, 2].astype(np.int32), "colorscale": "Viridis",
                  "cmin": 0.0, "cmax": top, "colorbar": {"title": {"text": "|u| (mm)"}},
                  "flatshading": True, "name": "FE surface",
                  "lighting": {"ambient": 0.6, "diffuse": 0.7, "specular": 0.05}}
                 if full else {})
        return go.Mesh3d(x=xyz[:, 0], y=xyz[:, 1], z=xyz[:, 2], intensity=value, **extra)

    fig = go.Figure(data=[trace(shapes[0], colour[0], full=True)], frames=[
        go.Frame(data=[trace(xyz, value, full=False)], name=name,
                 layout={"title": {"text": f"{title}: P = {name} kPa"}})
        for xyz, value, name in zip(shapes, colour, names, strict=True)])
    return pressure_slider_scene(fig, centre, half, f"{title}: P = {names[0]} kPa", names,
                                 "surface")
