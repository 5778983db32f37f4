"""``multimorph plot``: figures from stored results (``plot map`` for sweep design maps)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from multimorph.cli._common import console, emit_json, fail, handle_errors
from multimorph.cli._help import PlainHelpCommand, PlainHelpGroup

__all__ = ["MAP_FILES", "plot_app", "register"]

#: Figures ``plot map`` writes into RESULTS/maps (``<x>``, ``<y>``: the parameters'
#: names; the map over two parameters only with a second one).
MAP_FILES = ("families_<x>.png", "pc_vs_<x>.png", "pc_map_<x>__<y>.png")

plot_app = typer.Typer(cls=PlainHelpGroup, help="Plots from stored results.",
                       no_args_is_help=True)


@plot_app.command("map", cls=PlainHelpCommand)
def plot_map(
    results: Annotated[Path, typer.Argument(help="Sweep folder (or its results.zarr).")],
    x: Annotated[str | None, typer.Option(
        "--x", help="Parameter on the x axis, e.g. ht/d (default: first swept).")] = None,
    y: Annotated[str | None, typer.Option(
        "--y", help="Second parameter: line groups and a Pc contour map (default: second "
        "swept, if any).")] = None,
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Folder for the figures (default RESULTS/maps).")] = None,
    fmt: Annotated[str, typer.Option("--format", help="png, svg or pdf.")] = "png",
    as_json: Annotated[bool, typer.Option("--json", help="Print the written files as JSON.")
                       ] = False,
) -> None:
    """Draw design maps: κd/2π vs P/μ families, Pc vs a parameter, Pc contours over two.

    Example: multimorph plot map out/ht --x ht/d --y ws/d
    """
    if fmt not in ("png", "svg", "pdf"):
        fail(f"--format: expected png, svg or pdf, got {fmt!r}", as_json=as_json)
    from multimorph.sweep import answered_by, open_results
    from multimorph.viz import design_maps, model_note

    with handle_errors(as_json):
        ds = open_results(results)
        folder = out if out is not None else (
            results.parent if results.name == "results.zarr" else results) / "maps"
        files = design_maps(ds, folder, x=x, y=y, fmt=fmt)
        model, models = answered_by(ds) if "status" in ds else ("", {})
        if as_json:
            emit_json({"files": [str(f) for f in files], "model": model, "models": models})
        else:
            note = model_note(ds)
            if note:
                console.print(f"model: {note}", highlight=False)
            for f in files:
                console.print(f"wrote {f}", highlight=False)


def register(app: typer.Typer) -> None:
    app.add_typer(plot_app, name="plot")
