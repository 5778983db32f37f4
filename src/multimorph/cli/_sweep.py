"""``multimorph sweep``: run (or resume) a parameter sweep on Dask."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from multimorph.cli._common import console, default_out, emit_json, err_console, handle_errors
from multimorph.cli._help import PlainHelpCommand
from multimorph.cli._progress import progress

__all__ = ["FILES", "register", "sweep", "sweep_model_line", "with_model"]

#: What a sweep folder holds (multimorph.sweep's store): the manifest, the spec as given,
#: the design table, one part per finished batch and, once complete, every result merged.
FILES = ("sweep.json", "spec.toml", "designs.zarr", "parts/", "results.zarr")


def sweep(
    spec: Annotated[Path, typer.Argument(help="Sweep spec (TOML): [cell] and [sweep].")],
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Sweep folder (default multimorph-out/sweep-<spec name>). "
        "Rerunning into the same folder resumes.")] = None,
    scheduler: Annotated[str | None, typer.Option(
        help="'local' (LocalCluster of worker processes, default), 'threads', 'sync', or a "
        "scheduler address such as tcp://host:8786.")] = None,
    workers: Annotated[int | None, typer.Option(
        min=1, help="Worker processes (local) or threads (threads); default: CPU count.")] = None,
    batch_size: Annotated[int | None, typer.Option(
        min=1, help="Designs per task (default: 256 for rom, 1 for fe).")] = None,
    retries: Annotated[int, typer.Option(min=0, help="Retries of a failed task.")] = 2,
    retry_failed: Annotated[bool, typer.Option(
        "--retry-failed", help="On resume, evaluate designs that failed before again.")
                            ] = False,
    allow_plugin: Annotated[list[str] | None, typer.Option(
        "--allow-plugin", metavar="MODULE:CALLABLE",
        help="Let the spec's backend be this import path (a factory of a sweep backend); "
        "repeatable. Without it a spec can only name registered backends (calibrated-fast, "
        "calibrated, ritz, rom, fe, installed entry points): a spec file never imports "
        "code.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print a JSON summary.")] = False,
    model: Annotated[str | None, typer.Option(
        "--model", help="Cell model, overriding the spec's sweep.backend (which is "
                        "calibrated-fast when the spec names none): calibrated (Ritz "
                        "corrected against 3D FE), calibrated-fast (the same on emulated Ritz "
                        "features: about 40 × faster, less accurate) or ritz (alias rom: the "
                        "reduced model, about twice as stiff as FE).")] = None,
) -> None:
    """Run a parameter sweep and store the results (Zarr) in a resumable folder.

    Example: multimorph sweep examples/sweep_ht.toml --out out/ht --workers 2

    Exit status: 0 when at least one design succeeded, 1 when every evaluated design failed
    (the results, with each error, are still written), 2 on a malformed spec or option (also
    when every design is invalid), checked before anything is created.
    """
    from multimorph.io import claim_output
    from multimorph.sweep import run_sweep

    with handle_errors(as_json):
        folder = out if out is not None else default_out("sweep", spec)
        target: Any = spec
        if model is not None:
            target = with_model(spec, model)
        with claim_output(folder, in_place=True), progress(
                "sweep", unit="designs", keep=not as_json) as update:
            summary = run_sweep(target, folder, scheduler=scheduler, workers=workers,
                                batch_size=batch_size, retries=retries,
                                progress=lambda done, total: update(done, total,
                                                                    phase="evaluating"),
                                retry_failed=retry_failed,
                                allow_plugins=tuple(allow_plugin or ()))
        failed_all = summary.n_ok == 0 and summary.n_failed > 0
        if as_json:
            emit_json(summary.to_dict())
            if failed_all:
                raise typer.Exit(1)
            return
        console.print(f"[bold]{summary.n_designs}[/] designs: {summary.n_ok} ok, "
                      f"{summary.n_failed} failed, {summary.n_invalid} invalid "
                      f"({summary.n_resumed} already done, {summary.n_run} run now) in "
                      f"{summary.elapsed:.1f} s")
        console.print(f"  model: {sweep_model_line(summary.model, summary.models)}",
                      highlight=False)
        for p in summary.invalid[:10]:
            console.print(f"  invalid design {p['index']} {p['values']}: {p['reason']}",
                          highlight=False)
        if len(summary.invalid) > 10:
            console.print(f"  … {len(summary.invalid) - 10} more invalid (see sweep.json)")
        for p in summary.failed[:10]:
            console.print(f"  failed design {p['index']}: {p['error']}", highlight=False)
        if len(summary.failed) > 10:
            console.print(f"  … {len(summary.failed) - 10} more failed (see results.zarr)")
        console.print(f"results: {summary.results}")
        if failed_all:
            err_console.print(f"[bold red]error:[/] every evaluated design failed "
                              f"({summary.n_failed}); the errors are in {summary.results}",
                              highlight=False, soft_wrap=True)
            raise typer.Exit(1)


def sweep_model_line(model: str, models: dict[str, int]) -> str:
    """Which cell model a sweep ran, how far it is from FE, and how many of its designs
    another model answered (a calibrated model answers a cell outside its box with the
    Ritz model: "…; 2 designs outside its calibrated box answered by the ritz model …")."""
    from multimorph.cli._simulate import MODEL_WORDS

    line = MODEL_WORDS.get(model, model)
    for other, n in sorted(models.items()):
        if other != model:
            where = (" outside its calibrated box"
                     if model.startswith("calibrated") and other == "ritz" else "")
            line += f"; {n} design{'s' if n != 1 else ''}{where} answered by the {other} model"
    return line


def with_model(spec: Path, model: str) -> Any:
    """The sweep spec at ``spec`` with its backend set to the cell model ``model`` (also in
    its raw table, so a resumed sweep must use the same model)."""
    import dataclasses

    from multimorph.models import model_name
    from multimorph.sweep import load_sweep_spec

    name = model_name(model, allowed=("calibrated", "calibrated-fast", "ritz"), field="--model")
    loaded = load_sweep_spec(spec)
    raw = dict(loaded.raw)
    raw["sweep"] = {**raw.get("sweep", {}), "backend": name}
    return dataclasses.replace(loaded, backend=name, raw=raw)


def register(app: typer.Typer) -> None:
    app.command("sweep", cls=PlainHelpCommand)(sweep)
