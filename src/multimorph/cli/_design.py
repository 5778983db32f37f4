"""``multimorph design``: from a target sequence of motions to a device that does it.

Exit status: 0 when a design meets every target (files written), 3 when the target is
infeasible (the report explaining which constraint binds is still written, and ``--json``
prints ``"feasible": false`` with the explanation), 2 on a malformed spec or a missing model.
"""

from __future__ import annotations

import math
from contextlib import ExitStack
from pathlib import Path
from typing import Annotated, Any

import typer

from multimorph.cli._common import (
    console,
    default_out,
    emit_json,
    err_console,
    handle_errors,
    in_file,
)
from multimorph.cli._help import PlainHelpCommand
from multimorph.cli._progress import progress
from multimorph.cli._simulate import MODEL_WORDS, model_words

__all__ = ["EXIT_INFEASIBLE", "FILES", "SOMETIMES", "design_command", "register"]

EXIT_INFEASIBLE = 3
#: Files every design run writes into its output folder (with its report's ``files``).
FILES = ("report.json", "report.md", "report.html", "convergence.png")
#: Files a run writes when it has them: the best device (``closest_device.toml`` when the
#: target is infeasible and FE did not verify the design) and its sequence, the robustness
#: (``--robustness`` > 0) and the FE verification (``--verify-fe``) figures. A run removes
#: those an earlier run left in its folder and it did not write (a run that ends infeasible
#: leaves no old ``device.toml`` beside its ``closest_device.toml``).
SOMETIMES = ("device.toml", "closest_device.toml", "sequence.png", "robustness.png",
             "fe_verification.png")
#: Option limits: a batch of population × stages cells is traced at once, and every
#: evaluation or sample is a traced path (~0.1 s each on one core).
MAX_BUDGET = 10_000_000
MAX_POPULATION = 10_000
MAX_SAMPLES = 100_000
#: Search defaults per model family: a calibrated curve costs milliseconds (the fast
#: variant), a Ritz one a tenth of a second (benchmarks/bench_design.py).
DEFAULT_BUDGET = {"calibrated": 4000, "ritz": 1200}
DEFAULT_POPULATION = {"calibrated": 48, "ritz": 24}


def design_command(
    target: Annotated[Path, typer.Argument(
        help="Target spec (TOML): [[stage]], [constraints].")],
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Output folder (default multimorph-out/design-<target name>).")
                   ] = None,
    seed: Annotated[int, typer.Option(help="Random seed (search and Monte Carlo).")] = 0,
    budget: Annotated[int | None, typer.Option(
        min=1, max=MAX_BUDGET,
        help="Cell-model evaluations for the search (default: 4000 on the calibrated "
             "models, 1200 on ritz).")] = None,
    population: Annotated[int | None, typer.Option(
        min=4, max=MAX_POPULATION,
        help="Differential-evolution population (default: 48 on the calibrated models, "
             "24 on ritz).")] = None,
    robustness: Annotated[int, typer.Option(
        min=0, max=MAX_SAMPLES,
        help="Monte Carlo samples for the robustness of the best design (0: skip).")
                          ] = 64,
    wall_tolerance: Annotated[str, typer.Option(
        help="Fabrication tolerance on every wall, ±, e.g. '0.1 mm'.")] = "0.1 mm",
    default_cv: Annotated[float, typer.Option(
        help="Coefficient of variation of material parameters without fit errors.")] = 0.05,
    robust: Annotated[bool, typer.Option(
        "--robust", help="Rank the shortlist by a robust objective (Monte Carlo).")] = False,
    verify_fe: Annotated[bool, typer.Option(
        "--verify-fe", help="Inflate the best design in 3D FE (--fe-route: each stage's "
        "module on its own, or the whole device); report each stage's Pc, Ph and motion, "
        "model vs FE (minutes to tens of minutes; resumable: finished FE runs are kept in "
        "<out>.fe and re-used).")] = False,
    fe_rounds: Annotated[int | None, typer.Option(
        "--fe-rounds", min=0, max=10,
        help="FE in the loop (implies --verify-fe): where the device FE misses a target, "
             "correct the targets by the model/FE ratio of the design and search again near "
             "it, at most N times (default 0: verify only).")] = None,
    fe_mesh: Annotated[str, typer.Option(
        "--fe-mesh", help="Mesh of the device FE and of twisting modules: coarse, medium or "
                          "fine (bending and stretching modules on the modules route take "
                          "the FE data set's mesh).")] = "coarse",
    fe_route: Annotated[str, typer.Option(
        "--fe-route", help="How FE inflates the design: modules (each stage's module on its "
                           "own, on the common pressure; default) or device (the whole "
                           "device as one problem; it stops at the first module's limit "
                           "point).")] = "modules",
    fe_twist: Annotated[str, typer.Option(
        "--fe-twist", help="On the modules route, how FE inflates a twisting module: strip "
                           "(one tilted cell of its strips in FE, twisted by the module's "
                           "shaft kinematics; default, minutes) or shaft (its strips on the "
                           "shaft as one FE problem; hours on 2 cores).")] = "strip",
    fe_screen: Annotated[int, typer.Option(
        "--fe-screen", min=0, max=8,
        help="FE in the loop on the modules route: where FE misses, also check up to N "
             "other cells of the stage FE misses most (one module's FE each, minutes); the "
             "best one FE finds stays in the round's design (0: none).")] = 2,
    vectorised: Annotated[bool, typer.Option(
        "--vectorised", help="Trace each batch with the vmapped ROM (default: a loop of "
        "single-design traces, faster on small CPUs today).")] = False,
    gradient: Annotated[bool, typer.Option(
        "--gradient/--no-gradient", help="Refine the best global design with IFT gradients "
        "through the traced equilibrium paths before the compass search.")] = True,
    graded: Annotated[bool, typer.Option(
        "--graded/--no-graded", help="Realise a stage whose band is wider than one module "
        "can span (Ph/Pc > 1.4) by graded modules of the same kind in series.")] = True,
    as_json: Annotated[bool, typer.Option("--json", help="Print the JSON report.")] = False,
    model: Annotated[str | None, typer.Option(
        "--model", help="Cell model of the design: calibrated (Ritz corrected against 3D FE; "
                        "the search runs on its fast variant inside the calibrated box, its "
                        "best designs are scored by the calibrated model and the targets "
                        "corrected for the difference, see --rounds), calibrated-fast (search "
                        "and scores on emulated Ritz features: fastest, less accurate) or ritz "
                        "(alias rom: the reduced model, about twice as stiff as FE). "
                        "Default: calibrated (multimorph.models.DESIGN_MODEL).")] = None,
    rounds: Annotated[int, typer.Option(
        "--rounds", min=0, max=20,
        help="With --model calibrated: searches again on targets corrected by the "
             "calibrated/fast ratio of the best design, at most this many times (0: score "
             "the search's designs only); then, if still missing, a compass search on the "
             "calibrated model itself, one stage's cell at a time (at most 20 s).")] = 3,
) -> None:
    """Design a device whose predicted sequence of motions meets a target.

    Example: multimorph design examples/target_gripper.toml --seed 1 --out out/gripper
    """
    from multimorph.design import (
        DesignSettings,
        rom_batch_model,
        run_design,
        target_from_spec,
        write_design_report,
    )
    from multimorph.design._verify import fe_available
    from multimorph.errors import MultimorphError, SpecError
    from multimorph.io import atomic_output_dir, claim_output, load_toml
    from multimorph.models import DESIGN_MODEL, batch_model, model_name
    from multimorph.units import to_si

    with handle_errors(as_json), ExitStack() as hold:
        name = model_name(model or DESIGN_MODEL, allowed=("calibrated", "calibrated-fast",
                                                          "ritz"), field="--model")
        with in_file(target):
            spec = target_from_spec(load_toml(target))
        tol = to_si(wall_tolerance, "m", field="--wall-tolerance")
        if not (math.isfinite(tol) and tol >= 0):
            raise SpecError(f"--wall-tolerance: must be a non-negative length, got "
                            f"{wall_tolerance!r}")
        if not (math.isfinite(default_cv) and default_cv >= 0):
            raise SpecError(f"--default-cv: must be a non-negative number, got {default_cv}")
        if fe_rounds is not None:
            verify_fe = True
        if fe_mesh not in ("coarse", "medium", "fine"):
            raise SpecError(f"--fe-mesh: expected coarse, medium or fine, got {fe_mesh!r}")
        from multimorph.design import FE_ROUTES

        if fe_route not in FE_ROUTES:
            raise SpecError(f"--fe-route: expected one of {', '.join(FE_ROUTES)}, got "
                            f"{fe_route!r}")
        from multimorph.design import TWIST_ROUTES

        if fe_twist not in TWIST_ROUTES:
            raise SpecError(f"--fe-twist: expected one of {', '.join(TWIST_ROUTES)}, got "
                            f"{fe_twist!r}")
        if verify_fe:
            ok, why = fe_available()
            if not ok:
                raise MultimorphError(f"--verify-fe: {why}")
        folder = out if out is not None else default_out("design", target)
        hold.enter_context(claim_output(folder))
        calibrated = name.startswith("calibrated")
        if budget is None:
            budget = DEFAULT_BUDGET["calibrated" if calibrated else "ritz"]
        if population is None:
            population = DEFAULT_POPULATION["calibrated" if calibrated else "ritz"]
        from multimorph.design import GRADED_RATIO, GRADED_RATIO_CALIBRATED

        settings = DesignSettings(budget=budget, population=population, seed=seed,
                                  graded_ratio=(GRADED_RATIO_CALIBRATED if calibrated
                                                else GRADED_RATIO),
                                  robust_samples=(16 if robust else 0), wall_tolerance=tol,
                                  default_cv=default_cv, gradient=gradient, graded=graded)
        with progress("design", unit="candidates", quiet=as_json) as update:
            run = run_design(spec, settings,
                             model=(rom_batch_model(vectorised) if name == "ritz"
                                    else batch_model(name, fallback=False)),
                             search_model=(batch_model("calibrated-fast", fallback=False)
                                           if name == "calibrated" else None),
                             rounds=rounds,
                             robustness_samples=robustness,
                             fe_rounds=(fe_rounds or 0) if verify_fe else None,
                             fe_folder=Path(str(folder) + ".fe"), fe_mesh=fe_mesh,
                             fe_route=fe_route, fe_twist=fe_twist, fe_screen=fe_screen,
                             progress=lambda done, total, phase: update(
                                 min(done, total), total, phase=f"search: {phase}"),
                             stage=lambda text: update(None, phase=text))
        if run.simulation_error is not None:
            err_console.print(f"[yellow]warning:[/] {run.simulation_error}")
        result = run.result
        header = (f"designed by 'multimorph design {target.name} --seed {seed} "
                  f"--budget {budget} --model {name}'" + (
                      "" if result.feasible else
                      "\nthe model alone misses a target; 3D FE meets them all (FE-verified)"
                      if result.fe_verified else "\nINFEASIBLE target: closest design only"))
        with atomic_output_dir(folder, stale=SOMETIMES) as tmp:
            report = write_design_report(run, tmp, header=header, model=name)
            _write_html(run, report, tmp, name)
        if as_json:
            emit_json({**report, "model": name, "out": str(folder)})
        else:
            _print_summary(result, run.robustness, folder, report["files"])
            console.print(f"  cell model: {MODEL_WORDS.get(name, name)}", highlight=False)
        if not result.feasible:
            raise typer.Exit(EXIT_INFEASIBLE)


def _write_html(run: Any, report: dict[str, Any], folder: Path, model: str) -> None:
    """``report.html`` beside the other files (added to the report's ``files``; report.json
    is written again with it)."""
    from multimorph.io import write_json
    from multimorph.viz._design_report import design_report_html

    device = run.device_result
    text = (model_words(device.to_dict()) if device is not None
            else MODEL_WORDS.get(model, model))
    design_report_html(report, folder / "report.html", device_result=device,
                       model_text=text)
    report["files"].append("report.html")
    write_json(folder / "report.json", report)


def _print_summary(result: Any, rob: Any, folder: Path, files: list[str]) -> None:
    import math

    from multimorph.names import kind_name

    t = result.target
    if result.feasible:
        console.print(f"[bold green]feasible[/]: {t.name} — {result.evaluations} model "
                      f"evaluations, {result.wall_time:.1f} s")
    else:
        console.print(f"[bold red]infeasible[/]: {t.name}")
        for e in result.explanation:
            console.print(f"  - {e}", highlight=False)
    best = result.best
    for name, graded in result.graded_stages().items():
        pr = graded.get("predicted")
        if pr is None:
            continue
        kind = next(stage.kind for stage in t.stages if stage.name == graded["parts"][0])
        magnitude = pr["magnitude"]
        mag = ("—" if magnitude is None else f"{magnitude * 100:.3g} %" if kind == "stretch"
               else f"{math.degrees(magnitude):.3g} deg")
        w = graded["wanted"]
        console.print(f"  {name}: graded ({' + '.join(graded['parts'])}): starts "
                      f"{_kpa(pr['start_pressure'])} (wanted {_kpa(w['start_pressure'])}), "
                      f"completes {_kpa(pr['end_pressure'])} (wanted {_kpa(w['end_pressure'])}),"
                      f" {mag}: {'met' if pr['met'] else 'not met'}", highlight=False)
    if best is not None:
        for stage, found in zip(t.stages, best.stages, strict=True):
            mag = (f"{found.magnitude * 100:.3g} %" if stage.kind == "stretch"
                   else f"{math.degrees(found.magnitude):.3g} deg")
            pc = "—" if found.start is None else f"{found.start / 1e3:.4g}"
            ph = "—" if found.end is None else f"{found.end / 1e3:.4g}"
            console.print(f"  {stage.name:<12} {kind_name(stage.kind):<10} Pc {pc} kPa, "
                          f"Ph {ph} kPa "
                          f"(wanted {stage.end_pressure / 1e3:.4g}), {mag}, {found.n_cells} "
                          f"cells", highlight=False)
        from multimorph.design._report import twist_caveat

        caveat = twist_caveat(t.stages)
        if caveat:
            console.print(f"  note: {caveat}", highlight=False)
    if result.rounds:
        console.print(f"  calibrated model: {len(result.rounds)} search round(s) on the fast "
                      "variant, scored by the calibrated model", highlight=False)
    if result.fe_rounds:
        last = result.fe_rounds[-1]
        verdict = "FE-verified" if result.fe_verified else "NOT FE-verified"
        route = ("each module on its own" if result.fe_route == "modules"
                 else "the whole device")
        console.print(f"  3D FE ({route}): {verdict} ({len(result.fe_rounds)} FE "
                      "round(s))", highlight=False)
        fe_best = result.fe_best
        for stage, m, f in zip(last.wanted.stages, result.best.stages, fe_best.stages,
                               strict=True):
            console.print(f"    {stage.name:<12} Pc model {_kpa(m.start)} / FE {_kpa(f.start)}, "
                          f"Ph model {_kpa(m.end)} / FE {_kpa(f.end)} (wanted "
                          f"{_kpa(stage.end_pressure)})", highlight=False)
    if rob is not None:
        console.print(f"  robustness: P(order holds) = {rob.p_order:.1%}, P(all targets met) "
                      f"= {rob.p_meets:.1%} over {rob.n_samples} samples", highlight=False)
        if rob.outside_support:
            over = ("" if rob.p_order_supported is None else
                    f"; over the {rob.n_samples - rob.outside_support} it answered: "
                    f"{rob.p_order_supported:.1%} and {rob.p_meets_supported:.1%}")
            console.print(f"    {rob.outside_support} of them outside the calibrated model's "
                          f"support (no prediction, counted as failing){over}",
                          highlight=False)
    console.print(f"files in {folder}: {', '.join(files)}")


def _kpa(p: float | None) -> str:
    return "—" if p is None else f"{p / 1e3:.4g} kPa"


def register(app: typer.Typer) -> None:
    app.command("design", cls=PlainHelpCommand)(design_command)
