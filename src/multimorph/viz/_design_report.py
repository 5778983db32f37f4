"""``report.html`` of ``multimorph design``: one self-contained page.

- the verdict and which cell model gave the numbers (the search model too);
- the target stages against what the best design achieves (Pc, Ph, motion, cells, safety
  factor), graded stages as a whole;
- the designed device as :func:`multimorph.viz._report.device_blocks` shows a simulated
  one (3D view with a pressure slider, sequence with the wanted pressures marked, stage
  table, strain curves);
- the 3D FE verification (model vs FE per stage and FE round) when the run had
  ``--verify-fe``, else a line saying the design is not FE-verified;
- the robustness summary.

Inputs are the design report (``report.json``'s content, SI units) and the best device's
simulation; kPa, deg and % on the page.
"""

from __future__ import annotations

import html
import math
import os
from collections.abc import Mapping, Sequence
from typing import Any

from multimorph.names import kind_name
from multimorph.viz._html import Figure, kpa, table, write_page
from multimorph.viz._report import device_blocks

__all__ = ["design_report_html", "fe_verification_blocks", "target_table"]


def _motion(kind: str, value: float | None) -> str:
    """A stage's motion: stretch in %, angles in deg."""
    if value is None:
        return "—"
    return f"{100 * value:.3g} %" if kind == "stretch" else f"{math.degrees(value):.3g} deg"


def _relative(model: float | None, reference: float | None) -> str:
    if model is None or reference is None or reference == 0:
        return "—"
    return f"{100 * (model - reference) / reference:+.1f} %"


def target_table(report: Mapping[str, Any]) -> str:
    """Each target stage against the best design: wanted and achieved Pc (start), Ph
    (end) and motion at Ph, the cells and the safety factor."""
    designs = report.get("designs") or []
    if not designs:
        return "<p>No design was found: nothing to compare with the target.</p>"
    best = {stage["name"]: stage for stage in designs[0]["stages"]}
    rows = []
    for stage in report["stages"]:
        got = best.get(stage["name"], {})
        sf = got.get("safety_factor")
        rows.append([stage["name"], kind_name(stage["kind"]), got.get("cells", "—"),
                     kpa(stage["start_pressure"]), kpa(got.get("start_pressure")),
                     kpa(stage["end_pressure"]), kpa(got.get("end_pressure")),
                     _motion(stage["kind"], abs(stage["magnitude"])),
                     _motion(stage["kind"], got.get("magnitude")),
                     "—" if sf is None else f"{sf:.2f}"])
    tol = report.get("tolerance") or {}
    out = table(("stage", "kind", "cells", "wanted Pc", "Pc", "wanted Ph", "Ph",
                 "wanted motion", "motion at Ph", "safety factor"), rows)
    if tol:
        out += (f"<p>Tolerances: pressure ±{100 * tol['pressure']:.0f} %, motion "
                f"±{100 * tol['magnitude']:.0f} %. Pc: where a stage starts, Ph: where it "
                "completes.</p>")
    graded = report.get("graded") or {}
    if graded:
        kinds = {stage["name"]: stage["kind"] for stage in report["stages"]}
        grows = []
        for name, entry in graded.items():
            kind = kinds.get(entry["parts"][0], "")
            wanted, got = entry["wanted"], entry.get("predicted") or {}
            grows.append([name, " + ".join(entry["parts"]), kpa(wanted["start_pressure"]),
                          kpa(got.get("start_pressure")), kpa(wanted["end_pressure"]),
                          kpa(got.get("end_pressure")),
                          _motion(kind, abs(wanted["magnitude"])),
                          _motion(kind, got.get("magnitude")),
                          "yes" if got.get("met") else "no"])
        out += ("<p>Graded stages (modules of one kind in series, each with its own cell):"
                "</p>" + table(("stage", "parts", "wanted start", "start", "wanted end",
                                "end", "wanted motion", "motion", "met"), grows))
    return out


def fe_verification_blocks(report: Mapping[str, Any], model: str) -> list[str]:
    """The 3D FE verification of the device: per FE round and stage, Pc, Ph and motion
    wanted, by the cell model and by FE, with (model − FE)/FE; or why there is none."""
    rounds = report.get("fe_rounds") or []
    if not rounds:
        return ["<p><b>Not FE-verified</b>: every number on this page is the "
                f"{html.escape(model)} model's. <code>multimorph design … --verify-fe</code> "
                "inflates the designed device in 3D FE and adds the comparison here.</p>"]
    verdict = ("<b>FE-verified</b>: 3D FE meets every target"
               if report.get("fe_verified") else
               "<b>Not FE-verified</b>: 3D FE misses a target")
    strip = (report.get("fe_twist") == "strip"
             and any(st["kind"] == "twist" for rd in rounds for st in rd["stages"]))
    verdict += (" (each stage's module inflated on its own, on the common pressure: route "
                "<code>modules</code>" + ("; twisting modules as one tilted cell of their "
                                          "strips, twisted by the shaft kinematics"
                                          if strip else "") + ")"
                if report.get("fe_route") == "modules" else
                " (the whole device as one FE problem: route <code>device</code>)"
                if report.get("fe_route") == "device" else "")
    rows = []
    for rd in rounds:
        for stage in rd["stages"]:
            kind, want = stage["kind"], stage["wanted"]
            mod, fe = stage["search_model"], stage["check_model"]
            rows.append([rd["round"], stage["name"], kind_name(kind),
                         kpa(want["start_pressure"]), kpa(mod["start_pressure"]),
                         kpa(fe["start_pressure"]),
                         _relative(mod["start_pressure"], fe["start_pressure"]),
                         kpa(want["end_pressure"]), kpa(mod["end_pressure"]),
                         kpa(fe["end_pressure"]),
                         _relative(mod["end_pressure"], fe["end_pressure"]),
                         _motion(kind, want["magnitude"]), _motion(kind, mod["magnitude"]),
                         _motion(kind, fe["magnitude"]),
                         _relative(mod["magnitude"], fe["magnitude"])])
    return [f"<p>{verdict} ({len(rounds)} FE round{'s' if len(rounds) > 1 else ''}; "
            f"model: {html.escape(model)}; — where FE did not reach the pressure).</p>",
            table(("FE round", "stage", "kind", "wanted Pc", "model Pc", "FE Pc",
                   "model vs FE", "wanted Ph", "model Ph", "FE Ph", "model vs FE",
                   "wanted motion", "model motion", "FE motion", "model vs FE"), rows)]


def _robustness(report: Mapping[str, Any]) -> list[str]:
    rob = report.get("robustness")
    if not rob:
        return []
    return ["<h2>Robustness</h2>",
            f"<p>{rob['n_samples']} Monte Carlo samples (walls and material parameters "
            f"varied): the stage order holds in {100 * rob['p_order']:.0f} %, every target "
            f"and constraint is met in {100 * rob['p_meets']:.0f} %.</p>"]


def design_report_html(report: Mapping[str, Any], path: str | os.PathLike[str], *,
                       device_result: Any = None, model_text: str, frames: int = 12
                       ) -> None:
    """Write ``report.html`` of a design run (one file, plotly.js inlined).

    Parameters
    ----------
    report : mapping
        The design report (``report.json``'s content: stages, designs, graded, fe_rounds,
        robustness, model).
    path : path-like
    device_result : DeviceResult, optional
        The best device simulated by the design's cell model (None: no 3D view, and the
        page says why).
    model_text : str
        Which cell model gave the numbers and how far it is from 3D FE, in words.
    frames : int
        Pressures of the 3D view's slider (at least 2).
    """
    name = str(report["target"])
    model = str(report.get("model", "the cell"))
    verdict = ("feasible: the best design meets every target" if report["feasible"]
               else "INFEASIBLE: the closest design only")
    search = (f" The search ran on {html.escape(report['search_model'])}; its best designs "
              f"were scored by {html.escape(model)}." if report.get("search_model") else "")
    why = "".join(f"<li>{html.escape(e)}</li>" for e in report.get("explanation") or [])
    blocks: list[str | Figure] = [
        f"<h1>{html.escape(name)}</h1>",
        f"<p><b>{verdict}</b> (seed {report['seed']}, {report['evaluations']} cell-model "
        f"evaluations, {report['wall_time']:.1f} s). Cell model: "
        f"{html.escape(model_text)}.{search}</p>",
        f"<ul>{why}</ul>" if why else "",
        "<h2>Target vs achieved</h2>", target_table(report)]
    if device_result is not None:
        targets: Sequence[tuple[str, float]] = [
            (f"{stage['name']} Ph wanted", stage["end_pressure"])
            for stage in report["stages"] if stage["end_pressure"] is not None]
        blocks += ["<h2>The designed device</h2>",
                   f"<p>Simulated by the {html.escape(model)} model up to "
                   f"{device_result.pmax / 1e3:.4g} kPa; dashed lines on the sequence: the "
                   "wanted completion pressures.</p>",
                   *device_blocks(device_result, device_result.to_dict(), frames=frames,
                                  targets=targets)]
    else:
        blocks += ["<h2>The designed device</h2>",
                   "<p>No device simulation: "
                   + html.escape(report.get("simulation_error") or "no design was found")
                   + ".</p>"]
    blocks += ["<h2>3D FE verification</h2>", *fe_verification_blocks(report, model),
               *_robustness(report)]
    write_page(path, f"{name} — multimorph design", blocks)
