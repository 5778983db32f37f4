"""The pieces every ``report.html`` is made of: one self-contained page (plotly's JavaScript
inlined once, so it opens offline), its style, HTML tables, pressure curves with Pc and Ph
marked, and the words for pressures.

A page is a list of blocks: an HTML string, or a :class:`Figure` (a plotly figure and the
id of its ``div``). :func:`write_page` renders them in order; the first figure carries
plotly.js. Pressures are Pa inside, kPa on the page.
"""

from __future__ import annotations

import html
import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["COLOURS", "Curve", "Figure", "curves_vs_pressure", "kpa", "plotly",
           "pressure_slider_scene",
           "table", "write_page"]

COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b")

STYLE = """body{font-family:system-ui,sans-serif;max-width:1100px;margin:1em auto;
padding:0 1em;color:#222}table{border-collapse:collapse;margin:.5em 0}
td,th{border:1px solid #ccc;padding:.25em .6em;text-align:left}th{background:#f2f2f2}
.note{color:#b00}pre{white-space:pre-wrap}"""


def plotly() -> Any:
    """``plotly.graph_objects`` (imported where used: plotting is an optional weight)."""
    import plotly.graph_objects as go

    return go


@dataclass(frozen=True)
class Figure:
    """A plotly figure on the page, in a ``div`` with id ``div_id``."""

    div_id: str
    figure: Any


@dataclass(frozen=True)
class Curve:
    """One curve against pressure: ``pressure`` (Pa) and ``values`` (the axis' unit), with
    its critical and hardening pressures (Pa; None where not reached)."""

    name: str
    pressure: np.ndarray
    values: np.ndarray
    pc: float | None = None
    ph: float | None = None
    dash: str = "solid"
    colour: str | None = None


def kpa(p: float | None, digits: int = 4) -> str:
    """A pressure (Pa) in kPa, "—" where there is none."""
    return "—" if p is None else f"{p / 1e3:.{digits}g} kPa"


def table(head: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    """An HTML table; every cell is text (escaped)."""
    cells = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row)
                    + "</tr>" for row in rows)
    return ("<table><thead><tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in head)
            + f"</tr></thead><tbody>{cells}</tbody></table>")


def curves_vs_pressure(curves: Sequence[Curve], *, y_title: str, title: str,
                       height: int = 400) -> Any:
    """Curves against pressure (kPa) on one axis of one unit (``y_title``), Pc (○) and
    Ph (□) marked on each curve and named in its hover text."""
    go = plotly()
    fig = go.Figure()
    for n, curve in enumerate(curves):
        colour = curve.colour or COLOURS[n % len(COLOURS)]
        P = np.asarray(curve.pressure, float) / 1e3
        y = np.asarray(curve.values, float)
        fig.add_trace(go.Scatter(x=P, y=y, name=curve.name, legendgroup=curve.name,
                                 line={"color": colour, "width": 2.5, "dash": curve.dash}))
        for p, symbol, what in ((curve.pc, "circle-open", "Pc"),
                                (curve.ph, "square-open", "Ph")):
            if p is not None and len(P) and P.min() <= p / 1e3 <= P.max():
                fig.add_trace(go.Scatter(
                    x=[p / 1e3], y=[float(np.interp(p / 1e3, P, y))], mode="markers",
                    marker={"symbol": symbol, "size": 11, "color": colour,
                            "line": {"width": 2}}, legendgroup=curve.name,
                    name=f"{what} {curve.name}: {p / 1e3:.3g} kPa", showlegend=False))
    fig.update_layout(title=title, xaxis_title="pressure P (kPa)", yaxis_title=y_title,
                      height=height, margin={"t": 50, "b": 40})
    return fig


def write_page(path: str | os.PathLike[str], title: str,
               blocks: Sequence[str | Figure]) -> None:
    """Write one self-contained HTML page: ``blocks`` in order, plotly.js inlined with the
    first figure (a page without figures carries none)."""
    parts, inlined = [], False
    for block in blocks:
        if isinstance(block, Figure):
            parts.append(block.figure.to_html(
                full_html=False, include_plotlyjs=not inlined, div_id=block.div_id,
                config={"displaylogo": False}, auto_play=False))
            inlined = True
        else:
            parts.append(block)
    body = "\n".join(parts)
    page = (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f"<title>{html.escape(title)}</title>\n<style>{STYLE}</style></head><body>\n"
            f"{body}\n</body></html>\n")
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(page)


def pressure_slider_scene(fig: Any, centre: Any, half: float, title: str,
                          names: Sequence[str], revision: str) -> Any:
    """Lay out a 3D figure whose frames are named by their pressure (kPa): a cube scene of
    half-width ``half`` (mm) about ``centre``, axes in mm, and a slider over ``names``
    that shows each frame at once. Returns ``fig``."""
    axis = {k: {"range": [centre[n] - half, centre[n] + half], "title": f"{k[0]} (mm)",
                "autorange": False} for n, k in enumerate(("xaxis", "yaxis", "zaxis"))}
    fig.update_layout(
        title=title, height=620, margin={"t": 50, "b": 10},
        scene={**axis, "aspectmode": "cube"}, uirevision=revision,
        sliders=[{"active": 0, "currentvalue": {"prefix": "P = ", "suffix": " kPa"},
                  "pad": {"t": 10}, "steps": [
                      {"label": name, "method": "animate",
                       "args": [[name], {"mode": "immediate", "frame": {"duration": 0,
                                                                         "redraw": True},
                                         "transition": {"duration": 0}}]}
                      for name in names]}])
    return fig
