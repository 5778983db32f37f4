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

__all__ = ["curves_figure", "device_figure", "device_report_html", "sequence_figure"]

_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b")
#: Rod frames per cell in the page's 3D view (fewer than the PNG: every frame is stored).
POINTS_PER_CELL = 4


def _plotly() -> Any:
    import plotly.graph_objects as go

    return go


def _colours(result: Any) -> dict[str, str]:
    return {name: _COLOURS[i % len(_COLOURS)] for i, name in enumerate(result.strains)}


def _display(mode: str, measure: np.ndarray) -> tuple[np.ndarray, str]:
    if mode == "stretch":
        return 100.0 * np.asarray(measure), "stretch λ−1 (%)"
    return np.degrees(measure), f"{mode} angle (deg)"


def sequence_figure(result: Any) -> Any:
    """Each module's motion against pressure (kPa), Pc (○) and Ph (□) marked, the band of
    pressure where each module dominates shaded."""
    go = _plotly()
    colour = _colours(result)
    fig = go.Figure()
    for band in result.sequence.bands:
        fig.add_vrect(x0=band["from_pressure"] / 1e3, x1=band["to_pressure"] / 1e3,
                      fillcolor=colour[band["module"]], opacity=0.1, line_width=0)
    for name, strain in result.strains.items():
        y, label = _display(strain.module.mode, strain.measure)
        P = strain.pressure / 1e3
        fig.add_trace(go.Scatter(x=P, y=y, name=f"{name} ({strain.module.kind}), {label}",
                                 line={"color": colour[name], "width": 3}))
        ch = strain.response.characteristic
        for p, symbol, what in ((ch.critical, "circle-open", "Pc"),
                                (ch.hardening, "square-open", "Ph")):
            if p is not None:
                fig.add_trace(go.Scatter(
                    x=[p / 1e3], y=[float(np.interp(p / 1e3, P, y))], mode="markers",
                    marker={"symbol": symbol, "size": 11, "color": colour[name],
                            "line": {"width": 2}},
                    name=f"{what} {name}: {p / 1e3:.3g} kPa", showlegend=False))
    fig.update_layout(title="sequence: motion per module (○ Pc, □ Ph; shading: dominant "
                            "module)", xaxis_title="pressure P (kPa)",
                      yaxis_title="motion (deg, or % stretch)", height=430,
                      margin={"t": 50, "b": 40})
    return fig


def curves_figure(result: Any) -> Any:
    """Every module's bend κ (1/m), twist τ (rad/m) and stretch λ against pressure (kPa)."""
    go = _plotly()
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
    go = _plotly()
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
    axis = {k: {"range": [centre[n] - half, centre[n] + half], "title": f"{k[0]} (mm)",
                "autorange": False} for n, k in enumerate(("xaxis", "yaxis", "zaxis"))}
    fig.update_layout(
        title=title.format(names[0]), height=620, margin={"t": 50, "b": 10},
        scene={**axis, "aspectmode": "cube"}, uirevision="device",
        sliders=[{"active": 0, "currentvalue": {"prefix": "P = ", "suffix": " kPa"},
                  "pad": {"t": 10}, "steps": [
                      {"label": name, "method": "animate",
                       "args": [[name], {"mode": "immediate", "frame": {"duration": 0,
                                                                         "redraw": True},
                                         "transition": {"duration": 0}}]}
                      for name in names]}])
    return fig


def _kpa(p: float | None) -> str:
    return "—" if p is None else f"{p / 1e3:.4g} kPa"


def _stage_table(result: Any, summary: Mapping[str, Any]) -> str:
    """The stages as an HTML table: per module in the order of the sequence."""
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
        cells = [name, strain.module.kind, str(strain.module.n_cells), _kpa(ch.critical),
                 _kpa(ch.hardening), _kpa(ch.failure), dominant, str(entry["model"]), inside]
        rows.append("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in cells) + "</tr>")
    head = ("module", "kind", "cells", "Pc", "Ph", "failure", "dominant", "model",
            "calibration")
    margins = "".join(
        f"<li>{html.escape(m['earlier'])} → {html.escape(m['later'])}: "
        + ("undetermined" if m["margin"] is None else
           f"{html.escape(m['verdict'])} (Pc later − Ph earlier = {m['margin'] / 1e3:+.3g} "
           "kPa)") + "</li>" for m in seq.margins)
    return ("<table><thead><tr>" + "".join(f"<th>{h}</th>" for h in head)
            + "</tr></thead><tbody>" + "".join(rows) + "</tbody></table>"
            + (f"<ul>{margins}</ul>" if margins else ""))


_STYLE = """body{font-family:system-ui,sans-serif;max-width:1100px;margin:1em auto;
padding:0 1em;color:#222}table{border-collapse:collapse;margin:.5em 0}
td,th{border:1px solid #ccc;padding:.25em .6em;text-align:left}th{background:#f2f2f2}
.note{color:#b00}"""


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
    pressures = np.linspace(0.0, result.pmax, max(2, int(frames)))
    parts = [("device", device_figure(result, pressures)),
             ("sequence", sequence_figure(result)), ("curves", curves_figure(result))]
    divs = {name: fig.to_html(full_html=False, include_plotlyjs=(i == 0), div_id=name,
                              config={"displaylogo": False}, auto_play=False)
            for i, (name, fig) in enumerate(parts)}
    notes = "".join(f'<li class="note">{html.escape(n)}</li>' for n in summary["notes"])
    name = html.escape(result.device.name)
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{name} — multimorph simulate</title>
<style>{_STYLE}</style></head><body>
<h1>{name}</h1>
<p>{len(result.strains)} modules on one pressure line, P up to {result.pmax / 1e3:.4g} kPa.
Cell model: {html.escape(model_text)}.</p>
{f'<ul>{notes}</ul>' if notes else ''}
<h2>The device as pressure rises</h2>
<p>Move the slider: every module is its cells' cross-section swept along the rod (darker
bands: partitions between cells; dark stripe: the top face, turned by twist).</p>
{divs["device"]}
<h2>Sequence</h2>
{divs["sequence"]}
<h2>Stages</h2>
{_stage_table(result, summary)}
<h2>Strain curves</h2>
{divs["curves"]}
</body></html>
"""
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(page)
