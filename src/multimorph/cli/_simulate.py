"""``multimorph simulate``: a device on one pressure line — curves, sequence, shapes, GIF."""

from __future__ import annotations

import csv
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich.markup import escape

from multimorph.cli._common import (
    console,
    default_out,
    emit_json,
    handle_errors,
    in_file,
    pressure_option,
)
from multimorph.cli._help import PlainHelpCommand
from multimorph.cli._progress import progress

__all__ = ["CSV_COLUMNS", "MODEL_WORDS", "model_words", "register", "simulate"]

#: Files written into the output folder (and ``morph.gif`` with ``--frames`` > 0).
FILES = ("summary.json", "curves.csv", "sequence.png", "shapes.png", "report.html")
#: Columns of curves.csv: ``<quantity>_<unit>`` as FE's CSV files name them (the first
#: six are the older names, kept in their places: bend = curvature, twist = twist rate,
#: stretch = axial stretch, measure = the module's own motion in SI).
CSV_COLUMNS = ("module", "pressure_pa", "bend_1_per_m", "twist_rad_per_m", "stretch",
               "measure", "pressure_kpa", "curvature_1_per_m", "twist_rate_rad_per_m",
               "axial_stretch", "bend_angle_deg", "twist_angle_deg")
#: Pressures of report.html's slider: ``--frames`` of them, at most this many (every one is
#: stored in the page), 12 without an animation.
MAX_REPORT_FRAMES = 48
#: Most GIF frames (each is a full figure held in memory while the GIF is written).
MAX_FRAMES = 1000


def _snapshot_pressures(given: str | None, p_max: float) -> list[float]:
    """The pressures (Pa) of the shape snapshots: ``given`` (comma-separated, each within
    [0, p_max]) or 0, p_max/3, 2 p_max/3 and p_max."""
    import math

    from multimorph.errors import SpecError
    from multimorph.units import to_si

    if not given:
        return [0.0, *[float(x) for x in np.linspace(p_max / 3, p_max, 3)]]
    out = []
    for item in given.split(","):
        if not item.strip():
            continue
        p = to_si(item.strip(), "Pa", field="--snapshots")
        if not (math.isfinite(p) and 0 <= p <= p_max):
            raise SpecError(f"--snapshots: {item.strip()!r} is outside the traced range 0 to "
                            f"{p_max / 1e3:.4g} kPa (pmax)")
        out.append(p)
    if not out:
        raise SpecError(f"--snapshots: no pressure in {given!r}")
    return out


def _write(result: object, folder: Path, files: list[str], pressures: list[float],
           frames: int, update: Callable[..., None]) -> None:
    from multimorph.io import atomic_output_dir, write_json
    from multimorph.viz._device_plots import (
        module_curves_figure,
        shapes_figure,
        write_animation,
    )
    from multimorph.viz._report import device_report_html

    summary = {**result.to_dict(), "files": files}  # type: ignore[attr-defined]
    with atomic_output_dir(folder) as tmp:
        write_json(tmp / "summary.json", summary)
        with open(tmp / "curves.csv", "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(CSV_COLUMNS)
            for name, s in result.strains.items():  # type: ignore[attr-defined]
                length = s.module.length
                for row in zip(s.pressure, s.bend, s.twist, s.stretch, s.measure,
                               s.pressure / 1e3, s.bend, s.twist, s.stretch,
                               np.degrees(s.bend * length), np.degrees(s.twist * length),
                               strict=True):
                    w.writerow([name, *(f"{x:.8g}" for x in row)])
        update(0, 2, phase="figures", detail="sequence.png, shapes.png")
        module_curves_figure(result).savefig(tmp / "sequence.png", dpi=130)
        shapes_figure(result, pressures).savefig(tmp / "shapes.png", dpi=110)
        update(1, 2, phase="report", detail="report.html")
        device_report_html(result, tmp / "report.html", summary=summary,
                           model_text=model_words(summary),
                           frames=min(frames, MAX_REPORT_FRAMES) if frames else 12)
        if frames:
            write_animation(result, tmp / "morph.gif", frames=frames,
                            progress=lambda done, total: update(
                                done, total, phase="animation", detail=f"{done}/{total} frames"))


#: Each cell model in words: what it is and how far it is from 3D FE.
MODEL_WORDS = {"calibrated": "calibrated (Ritz corrected against 3D FE; errors in "
                             "docs/validation.md)",
               "calibrated-fast": "calibrated-fast (Ritz corrected against 3D FE on emulated "
                                  "Ritz features; errors in docs/validation.md)",
               "ritz": "ritz (reduced model; Pc about 2 × the 3D FE's)", "fe": "fe (3D FE)"}


def model_words(summary: dict[str, Any]) -> str:
    """The cell model(s) of a device result, and how far each is from 3D FE."""
    words = MODEL_WORDS
    fell_back = [n for n, m in summary["modules"].items()
                 if (m.get("calibration") or {}).get("inside") is False]
    models = summary["model"] if isinstance(summary["model"], list) else [summary["model"]]
    text = "; ".join(words.get(m, m) for m in models)
    if fell_back:
        text += f" — Ritz fallback outside the calibrated box for {', '.join(fell_back)}"
    from multimorph.calibrated._anchor import readings_disagree

    unsure = [n for n, m in summary["modules"].items()
              if readings_disagree((m.get("calibration") or {}).get("anchors"))]
    if unsure:
        text += (f" — Pc uncertain for {', '.join(unsure)} (the cell's path and its anchor "
                 "read Pc more than 2× apart; see calibration.anchors)")
    return text


def simulate(
    spec: Annotated[Path, typer.Argument(help="Device spec (TOML): [device], [[module]].")],
    pmax: Annotated[str | None, typer.Option(
        help="Maximum pressure, e.g. '60 kPa' (default: the spec's device.pmax).")] = None,
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Output folder (default multimorph-out/simulate-<spec name>).")
                   ] = None,
    snapshots: Annotated[str | None, typer.Option(
        help="Comma-separated pressures of the shape snapshots, e.g. '20 kPa,40 kPa'.")
                         ] = None,
    frames: Annotated[int, typer.Option(min=0, max=MAX_FRAMES,
                                        help="GIF frames (0: no animation).")] = 24,
    as_json: Annotated[bool, typer.Option("--json", help="Print the JSON summary.")] = False,
    model: Annotated[str | None, typer.Option(
        "--model", help="Cell model: calibrated-fast (the default: Ritz corrected "
                        "against 3D FE, on emulated Ritz features; ~1 ms a cell), calibrated "
                        "(the same with a Ritz trace per cell: a first call of ~45 s), ritz "
                        "(alias rom: the reduced model, about twice as stiff "
                        "as FE) or fe (3D FE of each distinct cell, minutes each). Default: "
                        "multimorph.models.DEFAULT_MODEL.")] = None,
) -> None:
    """Simulate a device: per-module curves, the sequence of modes, shapes, an animation
    and report.html (one page that opens offline: the device in 3D with a pressure slider,
    the sequence, the stages, the model).

    Example: multimorph simulate examples/gripper.toml --pmax "60 kPa" --out out/gripper
    """
    from multimorph.device import device_from_spec, simulate_device
    from multimorph.errors import SpecError
    from multimorph.io import claim_output, load_toml
    from multimorph.models import cell_model, model_name

    with handle_errors(as_json):
        # everything is checked before the model runs
        name = model_name(model, field="--model")
        table = load_toml(spec)
        with in_file(spec):
            device = device_from_spec(table)
        mu = min(m.cell.mu for m in device.modules)
        if pmax:
            p_max = pressure_option(pmax, "--pmax", mu=mu)
        elif isinstance(table.get("device"), dict) and "pmax" in table["device"]:
            p_max = device.pmax
        else:
            raise SpecError(f"{spec}: device.pmax: missing; give the supply pressure in "
                            "[device] (pmax = \"60 kPa\") or on the command line (--pmax)")
        pressures = _snapshot_pressures(snapshots, p_max)
        folder = out if out is not None else default_out("simulate", spec)
        files = list(FILES) + (["morph.gif"] if frames else [])
        with claim_output(folder, files=files), progress("simulate", quiet=as_json) as update:
            result = simulate_device(
                device, p_max, cell_model=None if model is None else cell_model(name),
                progress=lambda done, total: update(done, total, phase="tracing modules",
                                                    detail=f"{done}/{total} modules"))
            _write(result, folder, files, pressures, frames, update)
        summary = {**result.to_dict(), "files": files}
        if as_json:
            emit_json({**summary, "out": str(folder)})
            return
        seq = result.sequence
        console.print(f"[bold]{device.name}[/]: {len(device.modules)} modules, "
                      f"P up to {result.pmax / 1e3:.4g} kPa; cell model: "
                      f"{model_words(summary)}", highlight=False)
        for name in seq.order:
            pc, ph = seq.windows[name]
            s = result.strains[name]
            f = s.response.characteristic.failure
            console.print(
                f"  {name:<14} {s.module.kind:<10} Pc = "
                f"{'—' if pc is None else f'{pc / 1e3:.4g} kPa':<11} Ph = "
                f"{'—' if ph is None else f'{ph / 1e3:.4g} kPa':<11} failure "
                f"{'not reached' if f is None else f'{f / 1e3:.4g} kPa'}", highlight=False)
        console.print("  dominance: " + ", ".join(
            f"{b['module']} {b['from_pressure'] / 1e3:.3g}–{b['to_pressure'] / 1e3:.3g} kPa"
            for b in seq.bands), highlight=False)
        for m in seq.margins:
            if m["margin"] is None:
                console.print(f"  {m['earlier']} → {m['later']}: undetermined")
            else:
                console.print(f"  {m['earlier']} → {m['later']}: {m['verdict']} "
                              f"(Pc_later − Ph_earlier = {m['margin'] / 1e3:+.3g} kPa)",
                              highlight=False)
        console.print(f"  first to fail: {seq.first_to_fail or 'none within the path'}; "
                      f"unloading order: {', '.join(seq.unloading_order) or '—'}")
        for note in summary["notes"]:
            console.print(f"  [yellow]note:[/] {escape(note)}", highlight=False)
        console.print(f"files in {folder}: {', '.join(summary['files'])}")


def register(app: typer.Typer) -> None:
    app.command("simulate", cls=PlainHelpCommand)(simulate)
