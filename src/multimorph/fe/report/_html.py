"""``report.html`` of ``multimorph fem``: one self-contained page (plotly, inlined).

- the run: what was inflated, its size, solver work, time and why it stopped (the console
  summary) and the solver statistics;
- the FE curves: each measured signal against pressure (kPa), Pc and Ph marked, one
  figure per unit (angles in deg, curvature in 1/m, stretch);
- with ``--compare``: the cell model's curves against FE's and the table of Pc and Ph of
  both with (model − FE)/FE;
- the deformed FE surface in 3D under a pressure slider: the mesh's boundary faces at up
  to :data:`FRAMES` path points, when that fits in :data:`MAX_SURFACE_BYTES` (else the page
  says why it is left out).

Reads finished results only (:class:`~multimorph.fe.analyses.FEOutcome`); Pa and m
inside, kPa and mm on the page.
"""

from __future__ import annotations

import html
import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from multimorph.fe.mesh import hex_boundary
from multimorph.fe.report._comparison import QUANTITY_LABELS, comparison_curves
from multimorph.viz._html import Curve, Figure, curves_vs_pressure, kpa, table, write_page
from multimorph.viz._surface import surface_bytes, surface_figure

__all__ = ["FRAMES", "MAX_SURFACE_BYTES", "fe_curves", "surface_frames", "write_report_html"]

#: Most path points of the 3D view.
FRAMES = 10
#: Most bytes of the 3D view (plotly.js takes another ~4.6 MB: the page stays under 10 MB).
MAX_SURFACE_BYTES = 5_000_000


def fe_curves(outcome: Any) -> dict[str, list[Curve]]:
    """The FE curves of a run by axis title (one unit each): a cell's signal (κ or λ), a
    device's bend and twist angles and stretches per module, a twisting module's twist
    angle; each with its Pc and Ph."""
    result, kind = outcome.result, outcome.job.kind
    if kind == "cell":
        path, ch = result.response.path, result.response.characteristic
        if ch.signal == "axial_stretch":
            return {"axial stretch λ (-)": [Curve("FE", path.pressure, path.axial_stretch,
                                                  ch.critical, ch.hardening)]}
        return {"curvature κ (1/m)": [Curve("FE", path.pressure, path.curvature,
                                            ch.critical, ch.hardening)]}
    if kind == "twisting":
        pc, ph = result.activation()
        return {"twist angle (deg)": [Curve(result.module.name, result.pressure,
                                            np.degrees(result.twist_angle), pc, ph)]}
    out: dict[str, list[Curve]] = {}
    for module in result.mesh.modules:
        path = result.responses[module.name].path
        pc, ph = result.activation(module.name)
        label = f"{module.name} ({module.kind})"
        if module.kind == "stretching":
            axis, values = "centroid stretch λ (-)", path.axial_stretch
        elif module.kind == "twisting":
            axis, values = "twist angle (deg)", np.degrees(path.extra["twist_angle"])
        else:
            axis, values = "bend angle (deg)", np.degrees(path.extra["bend_angle"])
        out.setdefault(axis, []).append(Curve(label, path.pressure, values, pc, ph))
    return out


def _comparison_blocks(outcome: Any) -> list[str | Figure]:
    if outcome.comparison is None:
        return []
    curves = comparison_curves(outcome.comparison)
    blocks: list[str | Figure] = ["<h2>Cell model vs 3D FE</h2>"]
    rows = []
    for n, cmp in enumerate(curves):
        axis = QUANTITY_LABELS.get(cmp.quantity, cmp.quantity)
        blocks.append(Figure(f"compare-{n}", curves_vs_pressure(
            [Curve("3D FE", cmp.pressure_fe, cmp.value_fe, cmp.pc_fe, cmp.ph_fe,
                   colour="#000000"),
             Curve(f"{cmp.model} model", cmp.pressure_model, cmp.value_model, cmp.pc_model,
                   cmp.ph_model, dash="dash", colour="#1f77b4")],
            y_title=axis, title=f"{cmp.name}: {cmp.model} model vs 3D FE (○ Pc, □ Ph)")))
        rows.append([cmp.name, cmp.model, kpa(cmp.pc_model), kpa(cmp.pc_fe),
                     _relative(cmp.pc_model, cmp.pc_fe), kpa(cmp.ph_model), kpa(cmp.ph_fe),
                     _relative(cmp.ph_model, cmp.ph_fe)])
    blocks.append(table(("of", "model", "model Pc", "FE Pc", "(model − FE)/FE",
                         "model Ph", "FE Ph", "(model − FE)/FE"), rows))
    return blocks


def _relative(model: float | None, fe: float | None) -> str:
    if model is None or fe is None or fe == 0:
        return "—"
    return f"{100 * (model - fe) / fe:+.1f} %"


def surface_frames(pressure: np.ndarray, frames: int = FRAMES) -> list[int]:
    """Path points of the 3D view: the first to reach each of ``frames`` evenly spaced
    pressures from 0 to the highest, and the last (past a limit point it need not be the
    highest; a path crowds its points where it balloons, so evenly spaced indices would
    show mostly the end)."""
    pressure = np.asarray(pressure, float)
    if len(pressure) == 0:
        return []
    top = float(np.max(pressure))
    picks = {len(pressure) - 1}
    for target in np.linspace(0.0, top, max(frames, 2)):
        picks.add(int(np.argmax(pressure >= target - 1e-12 * max(abs(top), 1.0))))
    return sorted(picks)


def _surface_blocks(outcome: Any, frames: int, max_bytes: int) -> list[str | Figure]:
    result = outcome.result
    mesh = result.mesh
    pressure = (result.response.path.pressure if outcome.job.kind == "cell"
                else result.pressure)
    quads = hex_boundary(mesh.cells)
    picks = surface_frames(pressure, frames)
    count = frames
    while count > 2 and surface_bytes(quads, len(picks)) > max_bytes:
        count -= 1
        picks = surface_frames(pressure, count)
    head = "<h2>The deformed FE surface</h2>"
    size = surface_bytes(quads, len(picks))
    if size > max_bytes:
        return [head, f"<p>Left out: the mesh's surface ({len(quads)} faces) would take "
                      f"about {size / 1e6:.0f} MB at even two pressures (this page keeps "
                      f"the 3D view under {max_bytes / 1e6:.0f} MB); the VTU series holds "
                      "every point for ParaView.</p>"]
    half = " (half model: the symmetry plane is open)" if getattr(mesh, "half", False) else ""
    return [head, f"<p>The mesh's boundary faces{half} at {len(picks)} of the path's "
                  f"{len(pressure)} points; colour: displacement magnitude. Move the "
                  "slider.</p>",
            Figure("surface", surface_figure(
                mesh.points, quads, [result.displacements[i] for i in picks],
                [float(pressure[i]) for i in picks], title="FE"))]


def _stats_table(stats: dict[str, Any]) -> str:
    keys = [k for k in ("nfree", "points", "newton_iterations", "solver", "wall_time",
                        "status", "stop_reason", "resumed_points", "restarts") if k in stats]
    labels = {"nfree": "free DOF", "wall_time": "wall time (s)",
              "newton_iterations": "Newton iterations"}

    def shown(value: Any) -> str:
        return f"{value:.1f}" if isinstance(value, float) else str(value)

    return table(("statistic", "value"),
                 [[labels.get(k, k.replace("_", " ")), shown(stats[k])] for k in keys])


def write_report_html(outcome: Any, path: str | os.PathLike[str], *, title: str,
                      lines: Sequence[str], frames: int = FRAMES,
                      max_bytes: int = MAX_SURFACE_BYTES) -> None:
    """Write ``report.html`` of an FE run (one file, plotly.js inlined).

    Parameters
    ----------
    outcome : FEOutcome
    path : path-like
    title, lines : str, sequence of str
        The run's console summary (:func:`~multimorph.fe.report.describe`).
    frames : int
        Most path points of the 3D view.
    max_bytes : int
        Most bytes of the 3D view; fewer frames are shown, down to two, to stay below,
        and the view is left out (the page says so) when even two do not fit.
    """
    result = outcome.result
    blocks: list[str | Figure] = [
        f"<h1>{html.escape(title)}</h1>",
        f"<pre>{html.escape(chr(10).join(line.rstrip() for line in lines).strip())}</pre>",
        "<h2>FE curves</h2>"]
    for n, (axis, curves) in enumerate(fe_curves(outcome).items()):
        blocks.append(Figure(f"fe-{n}", curves_vs_pressure(
            curves, y_title=axis, title=f"3D FE: {axis.split(' (')[0]} (○ Pc, □ Ph)")))
    blocks += _comparison_blocks(outcome)
    blocks += _surface_blocks(outcome, frames, max_bytes)
    blocks += ["<h2>Run statistics</h2>", _stats_table(dict(result.stats))]
    write_page(path, f"{title} — multimorph fem", blocks)
