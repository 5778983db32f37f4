"""``report.html`` of a simulated device: one self-contained page (plotly, its JavaScript
inlined, so it opens offline).

- the sequence: each module's motion against pressure over the bands where it dominates,
  Pc and Ph marked;
- the device in 3D with a pressure slider (plotly frames): the same solid bodies as
  ``shapes.png`` (:mod:`multimorph.viz._bodies`) as ``Mesh3d`` surfaces;
- the strain curves (bend, twist, stretch) of every module;
- the stage table (Pc, Ph, failure, dominance, margins, calibration) and the cell model
  with how far it is from 3D FE; the notes where the rod model stops being physical.

Inputs are a ``DeviceResult`` and its summary (``DeviceResult.to_dict()``); pressures in
Pa inside, kPa and mm on the page.
"""

from __future__ import annotations

import html
import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from multimorph.viz._bodies import body_polygons
from multimorph.viz._html import (
    COLOURS,
    Figure,
    kpa,
    plotly,
    pressure_slider_scene,
    table,
    write_page,
)

__all__ = ["curves_figure", "device_blocks", "device_figure", "device_report_html",
           "sequence_figure", "stage_table"]

#: Rod frames per cell in the page's 3D view (fewer than the PNG: every frame is stored).
POINTS_PER_CELL = 4


def _colours(result: Any) -> dict[str, str]:
    return {name: COLOURS[i % len(COLOURS)] for i, name in enumerate(result.strains)}


def _display(mode: str, measure: np.ndarray) -> tuple[np.ndarray, str]:
    if mode == "stretch":
        return 100.0 * np.asarray(measure), "stretch λ−1 (%)"
    return np.degrees(measure), f"{mode} angle (deg)"


def sequence_figure(result: Any, targets: Sequence[tuple[str, float]] = ()) -> Any:
    """Each module's motion against pressure (kPa), Pc (○) and Ph (□) marked, the band of
    pressure where each module dominates shaded; angles (deg) on the left axis, stretches
    (%) on a right axis of their own (one unit per axis). ``targets``: (label, pressure in
    Pa) drawn as dashed vertical lines (a design's wanted pressures)."""
    go = plotly()
    colour = _colours(result)
    fig = go.Figure()
    for band in result.sequence.bands:
        fig.add_vrect(x0=band["from_pressure"] / 1e3, x1=band["to_pressure"] / 1e3,
                      fillcolor=colour[band["module"]], opacity=0.1, line_width=0)
    for label, p in targets:
        fig.add_vline(x=p / 1e3, line={"color": "#444", "dash": "dash", "width": 1},
                      annotation_text=label, annotation_position="top")
    modes = {strain.module.mode for strain in result.strains.values()}
    angles = bool(modes - {"stretch"})
    for name, strain in result.strains.items():
        y, label = _display(strain.module.mode, strain.measure)
        axis = "y2" if strain.module.mode == "stretch" and angles else "y"
        P = strain.pressure / 1e3
        fig.add_trace(go.Scatter(x=P, y=y, name=f"{name} ({strain.module.kind}), {label}",
                                 line={"color": colour[name], "width": 3}, yaxis=axis))
        ch = strain.response.characteristic
        for p, symbol, what in ((ch.critical, "circle-open", "Pc"),
                                (ch.hardening, "square-open", "Ph")):
            if p is not None:
                fig.add_trace(go.Scatter(
                    x=[p / 1e3], y=[float(np.interp(p / 1e3, P, y))], mode="markers",
                    marker={"symbol": symbol, "size": 11, "color": colour[name],
                            "line": {"width": 2}}, yaxis=axis,
                    name=f"{what} {name}: {p / 1e3:.3g} kPa", showlegend=False))
    layout: dict[str, Any] = {
        "title": "sequence: motion per module (○ Pc, □ Ph; shading: dominant module)",
        "xaxis_title": "pressure P (kPa)",
        "yaxis_title": "angle (deg)" if angles else "stretch λ−1 (%)",
        "height": 430, "margin": {"t": 50, "b": 40}}
    if angles and "stretch" in modes:
        layout["yaxis2"] = {"title": {"text": "stretch λ−1 (%)"}, "overlaying": "y",
                            "side": "right", "showgrid": False}
        layout["legend"] = {"x": 1.08}
    fig.update_layout(**layout)
    return fig


def curves_figure(result: Any) -> Any:
    """Every module's bend κ (1/m), twist τ (rad/m) and stretch λ against pressure (kPa)."""
    go = plotly()
    from plotly.subplots import make_subplots

    colour = _colours(result)
    fig = make_subplots(rows=1, cols=3, subplot_titles=("bend κ (1/m)", "twist τ (rad/m)",
                                                        "stretch λ (-)"))
    for name, strain in result.strains.items():
        for col, values in enumerate((strain.bend, strain.twist, strain.stretch), start=1):
            fig.add_trace(go.Scatter(x=strain.pressure / 1e3, y=values, name=name,
                                     legendgroup=name, showlegend=col == 1,
                                     line={"color": colour[name]}), row=1, col=col)
            fig.update_xaxes(title_text="P (kPa)", row=1, col=col)
    fig.update_layout(height=360, margin={"t": 40, "b": 40})
    return fig


def _mesh(polygons: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (n, 3) and fan triangles (m, 3) of convex polygons."""
    vertices = np.concatenate(polygons)
    triangles, start = [], 0
    for poly in polygons:
        k = len(poly)
        triangles += [(start, start + j, start + j + 1) for j in range(1, k - 1)]
        start += k
    return vertices, np.array(triangles)


def _rgb(colour: Sequence[float]) -> str:
    r, g, b = (round(255 * c) for c in colour[:3])
    return f"rgb({r},{g},{b})"


def _frame_meshes(result: Any, pressure: float, colour: Mapping[str, str]
                  ) -> dict[str, dict[str, Any]]:
    """Per module (and ``"hub"``): the Mesh3d vertices (mm), triangles and face colours of
    the bodies at ``pressure``."""
    shape = result.bodies(pressure, POINTS_PER_CELL)
    polygons, faces, owners = body_polygons(shape, colour, points_per_cell=POINTS_PER_CELL)
    out: dict[str, dict[str, Any]] = {}
    for owner in dict.fromkeys(owners):
        picked = [i for i, o in enumerate(owners) if o == owner]
        vertices, triangles = _mesh([polygons[i] for i in picked])
        colours = np.repeat([_rgb(faces[i]) for i in picked],
                            [len(polygons[i]) - 2 for i in picked])
        out[owner] = {"xyz": np.round(vertices, 3), "ijk": triangles,
                      "facecolor": colours.tolist()}
    return out


def device_figure(result: Any, pressures: Sequence[float]) -> Any:
    """The device in 3D (mm, equal axes) with a slider over ``pressures`` (Pa): one plotly
    frame per pressure, one ``Mesh3d`` per module (and hub) in each."""
    go = plotly()
    colour = _colours(result)
    meshes = [_frame_meshes(result, float(p), colour) for p in pressures]
    every = np.concatenate([m["xyz"] for frame in meshes for m in frame.values()])
    centre = 0.5 * (every.max(axis=0) + every.min(axis=0))
    half = 0.5 * float(np.max(every.max(axis=0) - every.min(axis=0))) * 1.05 + 1e-6
    kinds = {name: strain.module.kind for name, strain in result.strains.items()}

    def traces(frame: Mapping[str, Mapping[str, Any]], *, full: bool) -> list[Any]:
        out = []
        for owner, mesh in frame.items():
            xyz = mesh["xyz"]
            extra = ({"i": mesh["ijk"][:, 0], "j": mesh["ijk"][:, 1], "k": mesh["ijk"][:, 2],
                      "facecolor": mesh["facecolor"], "flatshading": True,
                      "name": owner if owner == "hub" else f"{owner} ({kinds[owner]})",
                      "showlegend": True,
                      "lighting": {"ambient": 0.55, "diffuse": 0.7, "specular": 0.1}}
                     if full else {})
            out.append(go.Mesh3d(x=xyz[:, 0], y=xyz[:, 1], z=xyz[:, 2], **extra))
        return out

    names = [f"{p / 1e3:.4g}" for p in pressures]
    title = result.device.name + ": P = {} kPa"
    fig = go.Figure(data=traces(meshes[0], full=True), frames=[
        go.Frame(data=traces(frame, full=False), name=name,
                 layout={"title": {"text": title.format(name)}})
        for frame, name in zip(meshes, names, strict=True)])
    return pressure_slider_scene(fig, centre, half, title.format(names[0]), names, "device")


def stage_table(result: Any, summary: Mapping[str, Any]) -> str:
    """The stages as an HTML table, per module in the order of the sequence, and the
    hand-over margins."""
    seq = result.sequence
    rows = []
    for name in seq.order:
        strain = result.strains[name]
        ch = strain.response.characteristic
        band = next((b for b in seq.bands if b["module"] == name), None)
        dominant = ("—" if band is None else f"{band['from_pressure'] / 1e3:.3g}–"
                    f"{band['to_pressure'] / 1e3:.3g} kPa")
        entry = summary["modules"][name]
        cal = entry.get("calibration") or {}
        inside = ("" if not cal else "inside the calibrated box" if cal.get("inside")
                  else f"outside: {cal.get('reason', 'Ritz fallback')}")
        rows.append([name, strain.module.kind, strain.module.n_cells, kpa(ch.critical),
                     kpa(ch.hardening), kpa(ch.failure), dominant, entry["model"], inside])
    margins = "".join(
        f"<li>{html.escape(m['earlier'])} → {html.escape(m['later'])}: "
        + ("undetermined" if m["margin"] is None else
           f"{html.escape(m['verdict'])} (Pc later − Ph earlier = {m['margin'] / 1e3:+.3g} "
           "kPa)") + "</li>" for m in seq.margins)
    return (table(("module", "kind", "cells", "Pc", "Ph", "failure", "dominant", "model",
                   "calibration"), rows)
            + (f"<ul>{margins}</ul>" if margins else ""))


def device_blocks(result: Any, summary: Mapping[str, Any], *, frames: int = 16,
                  targets: Sequence[tuple[str, float]] = ()) -> list[str | Figure]:
    """The device's part of a page: the notes, the 3D view with its pressure slider
    (``frames`` pressures from 0 to pmax, at least 2), the sequence (with ``targets``
    marked), the stage table and the strain curves."""
    pressures = np.linspace(0.0, result.pmax, max(2, int(frames)))
    notes = "".join(f'<li class="note">{html.escape(n)}</li>' for n in summary["notes"])
    return [
        f"<ul>{notes}</ul>" if notes else "",
        "<h2>The device as pressure rises</h2>",
        "<p>Move the slider: every module is its cells' cross-section swept along the rod "
        "(darker bands: partitions between cells; dark stripe: the top face, turned by "
        "twist).</p>",
        Figure("device", device_figure(result, pressures)),
        "<h2>Sequence</h2>", Figure("sequence", sequence_figure(result, targets)),
        "<h2>Stages</h2>", stage_table(result, summary),
        "<h2>Strain curves</h2>", Figure("curves", curves_figure(result))]


def device_report_html(result: Any, path: str | os.PathLike[str], *,
                       summary: Mapping[str, Any], model_text: str, frames: int = 16
                       ) -> None:
    """Write ``report.html`` of a simulated device (one file, plotly.js inlined).

    Parameters
    ----------
    result : DeviceResult
    path : path-like
    summary : mapping
        ``result.to_dict()`` (the modules' models and calibration, the notes).
    model_text : str
        Which cell model made it and how far it is from 3D FE, in words.
    frames : int
        Pressures of the 3D view's slider, from 0 to pmax (at least 2).
    """
    name = html.escape(result.device.name)
    write_page(path, f"{result.device.name} — multimorph simulate", [
        f"<h1>{name}</h1>",
        f"<p>{len(result.strains)} modules on one pressure line, P up to "
        f"{result.pmax / 1e3:.4g} kPa. Cell model: {html.escape(model_text)}.</p>",
        *device_blocks(result, summary, frames=frames)])
