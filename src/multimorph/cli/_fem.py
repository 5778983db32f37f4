"""``multimorph fem``: 3D finite-element analysis of a unit cell, module or device (FElupe)."""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated, Any

import typer

from multimorph.cli._common import console, default_out, emit_json, err_console, handle_errors
from multimorph.cli._help import PlainHelpCommand
from multimorph.cli._progress import progress

__all__ = ["FILES", "SOMETIMES", "fem", "register"]

#: Files every FE run writes into its output folder (with its JSON's ``files``).
FILES = ("summary.json", "curves.png", "snapshots.png", "report.html")
#: Files of one kind of run: a cell or a twisting module ``path.csv``, a device
#: ``curves.csv`` and ``tip.csv``; the solid of a cell or device (a device with a twisting
#: module: STL only); with ``--compare`` the comparison; with ``--vtu`` (default) the series
#: ``<cell|device|module>.pvd`` and one ``_NNNN.vtu`` per path point.
SOMETIMES = ("path.csv", "curves.csv", "tip.csv", "cell.step", "cell.stl", "device.step",
             "device.stl", "comparison.json", "comparison.png", "cell.pvd", "device.pvd",
             "module.pvd")


@contextlib.contextmanager
def _progress(label: str, p_end: float, quiet: bool) -> Iterator[Callable[[float, int], None]]:
    """Progress on stderr (pressure reached, points; a bar on a terminal, else lines);
    yields the callback ``progress(pressure_pa, n_points)`` that the FE drivers call."""
    with progress("fem", quiet=quiet) as update:
        yield lambda p, n: update(min(max(p, 0.0), p_end), p_end, phase=f"inflating {label}",
                                  detail=f"{p / 1e3:.1f}/{p_end / 1e3:.4g} kPa, {n} points")


@contextlib.contextmanager
def _resumable(checkpoint: Any, quiet: bool) -> Iterator[None]:
    """Ctrl-C keeps the converged points: say where and how to go on, exit 130."""
    try:
        yield
    except KeyboardInterrupt:
        err_console.print(f"interrupted: {checkpoint.saved} converged points are kept in "
                          f"{checkpoint.folder}/; run the same command again to resume from "
                          f"them (--restart starts afresh)", highlight=False, soft_wrap=True)
        raise typer.Exit(130) from None
    if checkpoint.discarded and not quiet:
        err_console.print(f"note: the points in {checkpoint.folder}/ were not reused "
                          f"({checkpoint.discarded}); started afresh", highlight=False)


def fem(
    spec: Annotated[Path, typer.Argument(
        help="Cell spec (TOML) with a [cell] table, or a device spec with [device] and "
             "[[module]] tables.")],
    mesh: Annotated[str, typer.Option(help="Mesh density: coarse, medium or fine.")
                    ] = "coarse",
    element_size: Annotated[str | None, typer.Option(
        help="Explicit element edge length, e.g. '1 mm' (overrides the preset's size).")
                            ] = None,
    wall_elements: Annotated[int | None, typer.Option(
        "--wall-elements", help="Elements through the thickness of every wall (overrides "
                                "the preset's 2, 3 or 4; 1 for a quick, stiffer look at a "
                                "large device or twisting module).")] = None,
    pmax: Annotated[str | None, typer.Option(
        help="Highest pressure, e.g. '60 kPa' (default: the wall shear modulus).")] = None,
    method: Annotated[str, typer.Option(
        help="auto (pressure steps, arc-length past stalls), pressure or arc-length.")
                      ] = "auto",
    solver: Annotated[str, typer.Option(help="Linear solver: auto, pardiso or superlu.")
                      ] = "auto",
    full: Annotated[bool, typer.Option("--full", help="Mesh the whole cell (or series "
                                                        "device), not half.")
                    ] = False,
    cells: Annotated[int, typer.Option(
        "--cells", help="Cells in series along the axis (a bending or stretching module "
                        "mounted at one end); 1: a single cell.")] = 1,
    tilt: Annotated[str | None, typer.Option(
        help="Tilt the chambers in the strip plane by this angle, e.g. '30 deg' (a twisting "
             "strip; full model): the strip's shear is measured, and with --compare set "
             "against the reduced model's twisting kinematics.")] = None,
    vtu: Annotated[bool, typer.Option(help="Write the VTU time series for ParaView.")
                   ] = True,
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Output folder (default multimorph-out/fem-<spec name>).")] = None,
    compare: Annotated[bool, typer.Option(
        "--compare", help="Also run a fast cell model (--model) and report Pc, Ph and the "
                          "curves side by side.")] = False,
    model: Annotated[str, typer.Option(
        "--model", help="The cell model --compare runs: calibrated (default), "
                        "calibrated-fast or ritz.")] = "calibrated",
    as_json: Annotated[bool, typer.Option("--json", help="Print the JSON summary.")] = False,
    module: Annotated[str | None, typer.Option(
        "--module", help="Device spec: run FE of this one module, clamped at its start (a "
                         "twisting module: its strips around the shaft; a bending or "
                         "stretching module: one copy as a one-module device).")] = None,
    restart: Annotated[bool, typer.Option(
        "--restart", help="Ignore the points an interrupted run of this command kept in "
                          "<out>.resume and start afresh.")] = False,
) -> None:
    """Inflate a cell (or a module of --cells cells in series) with 3D FE: path, Pc/Ph,
    curves, VTU series, STEP/STL. A device spec ([device], [[module]]: bending, stretching
    and twisting modules in series at any orientation, parallel branches such as fingers on
    a rigid hub) is
    meshed and inflated as one problem, each module (and each copy) measured on its own
    (Pc, Ph, bend and twist angle, stretch).

    Example: multimorph fem examples/fe_cell.toml --mesh medium --pmax "60 kPa" --out out/fe

    With --compare a fast cell model (--model: calibrated by default, or ritz) runs on the
    same spec; comparison.json and comparison.png hold Pc, Ph and κ(P) of both (per module
    for a device) with relative differences (model − fe)/fe.

    With --module NAME (device spec) only that module runs: a twisting module as its strips
    around the shaft, measured by the twist angle of its free end; --compare sets the twist
    angle, axial stretch, Pc and Ph against the reduced model's module strains.

    Writes summary.json, the CSV paths, curves.png, snapshots.png, the VTU series (.pvd),
    the solid (STEP/STL), with --compare comparison.json and comparison.png, and
    report.html (one page that opens offline: the FE curves, the model vs FE, the
    deformed surface under a pressure slider, the run's statistics).

    Interrupting (Ctrl-C) keeps every converged point in <out>.resume; the same command
    again resumes from them (--restart starts afresh). The folder goes once the results
    are written.
    """

    from multimorph.fe import PathCheckpoint
    from multimorph.fe.analyses import run_job
    from multimorph.fe.report import describe, write_outcome
    from multimorph.io import atomic_output_dir, load_toml

    with handle_errors(as_json):
        table = load_toml(spec)
        options = {"mesh": mesh, "element_size": element_size,
                   "wall_elements": wall_elements, "pmax": pmax,
                   "method": method, "solver": solver, "full": full, "cells": cells,
                   "tilt": tilt, "module": module}
        from multimorph.models import cell_model, model_name

        fast = model_name(model, allowed=("calibrated", "calibrated-fast", "ritz"),
                          field="--model")
        job = _job(spec, table, compare=compare, **options)
        suffix = f"-{module}" if job.kind == "twisting" else ""
        folder = out if out is not None else default_out("fem", spec, suffix)
        checkpoint = PathCheckpoint.beside(folder, spec.read_bytes(), options)
        if restart:
            checkpoint.clear()
        label = {"cell": "the cell", "device": "the device", "twisting": "the module"}[job.kind]
        with _resumable(checkpoint, as_json), _progress(label, job.p_end, as_json) as update:
            outcome = run_job(job, progress=update, checkpoint=checkpoint,
                              cell_model=cell_model(fast))
        with atomic_output_dir(folder) as tmp:
            info = write_outcome(outcome, tmp, vtu=vtu)
        checkpoint.clear()
        info["out"] = str(folder)
        if as_json:
            emit_json(info)
            return
        title, lines = describe(outcome, info)
        console.print(f"[bold]{title}[/]{lines[0]}", highlight=False)
        for line in lines[1:]:  # table rows (indented) are not wrapped
            console.print(line, highlight=False, soft_wrap=line.startswith("  "))
        console.print(f"files in {folder}/: {_file_list(info['files'])}", highlight=False)


def _file_list(files: list[str]) -> str:
    """The files of a run, the VTU series as one count (it has a file per path point)."""
    series = [f for f in files if f.endswith(".vtu")]
    shown = [f for f in files if not f.endswith(".vtu")]
    return ", ".join(shown) + (f" and {len(series)} VTU files" if series else "")


def _job(spec: Path, table: dict[str, Any], *, mesh: str, element_size: str | None,
         wall_elements: int | None, pmax: str | None, method: str, solver: str, full: bool,
         cells: int, tilt: str | None, module: str | None, compare: bool) -> Any:
    """The FE job the spec and the options ask for (:class:`multimorph.fe.analyses.FEJob`),
    the options checked against the kind of spec."""
    from multimorph.device import device_from_spec
    from multimorph.errors import SpecError
    from multimorph.fe import FESettings
    from multimorph.fe.analyses import FEJob
    from multimorph.fe.mesh import MAX_TILT
    from multimorph.geometry import CellGeometry
    from multimorph.units import to_angle, to_si

    def units() -> tuple[float | None, float | None]:
        return (to_si(pmax, "Pa", field="--pmax") if pmax else None,
                to_si(element_size, "m", field="--element-size") if element_size else None)

    def settings(p_max: float | None, size: float | None) -> FESettings:
        return FESettings(mesh=_density(mesh, size, wall_elements), half=not full,
                          p_max=p_max, method=method, solver=solver)

    if module is not None:
        if "device" not in table:
            raise SpecError(f"--module: applies to a device spec ([device] and [[module]] "
                            f"tables); {spec} has none")
        if cells != 1 or tilt is not None:
            raise SpecError(f"--{'cells' if cells != 1 else 'tilt'}: applies to a cell "
                            f"spec; with --module the module table gives them")
        device = device_from_spec(table)
        names = [entry.name for entry in device.modules]
        if module not in names:
            raise SpecError(f"--module: no module named {module!r} in {spec} (modules: "
                            f"{', '.join(names)})")
        return FEJob.for_module(device, module, settings(*units()), compare=compare)
    if "device" in table:
        if cells != 1:
            raise SpecError("--cells: applies to a cell spec; a device spec gives the "
                            "cells of each module in its module table")
        if tilt is not None:
            raise SpecError("--tilt: applies to a cell spec; FE devices take bending "
                            "and stretching modules only")
        return FEJob.for_device(device_from_spec(table), settings(*units()), compare=compare)
    if "cell" not in table:
        raise SpecError(f"{spec}: missing [cell] table (or a device table with modules)")
    geometry = CellGeometry.from_spec(table["cell"])
    if cells < 1:
        raise SpecError(f"--cells: expected a positive number of cells, got {cells}")
    p_max, size = units()
    beta = to_angle(tilt, field="--tilt") if tilt is not None else 0.0
    if tilt is not None and not (math.isfinite(beta) and 0.0 < abs(beta) < MAX_TILT):
        raise SpecError(f"--tilt: expected an angle with 0 < |tilt| < "
                        f"{math.degrees(MAX_TILT):.0f} deg, got {tilt!r}")
    return FEJob.for_cell(geometry, settings(p_max, size), n_cells=cells, tilt=beta,
                          compare=compare)


def _density(mesh: str, size: float | None, wall_elements: int | None) -> Any:
    """The mesh density of the options: the preset, an explicit in-plane size, and
    ``--wall-elements`` (elements through every wall) over both."""
    from dataclasses import replace

    from multimorph.errors import SpecError
    from multimorph.fe import resolve_density

    density = resolve_density(mesh, size)
    if wall_elements is None:
        return density
    if wall_elements < 1:
        raise SpecError(f"--wall-elements: expected at least 1 element through each wall, "
                        f"got {wall_elements}")
    return replace(density, wall_elements=int(wall_elements))


def register(app: typer.Typer) -> None:
    app.command("fem", cls=PlainHelpCommand)(fem)
