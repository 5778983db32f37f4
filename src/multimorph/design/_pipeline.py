"""The design pipeline as one call: search, robustness, the best device's sequence, the FE
check, and the report files.

:func:`run_design` is what ``multimorph design`` runs: the search on one counting reduced
model (one batch shape for search, Monte Carlo and the final simulation), the Monte Carlo
robustness of a feasible best design, the simulated sequence of its device (a failure is
reported, not raised: the search result stays), and optionally the FE check of its cells.
:func:`write_design_report` writes ``report.json``, ``report.md``, the device TOML and the
figures.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from multimorph.design._evaluate import Evaluation
from multimorph.design._fe_check import fe_checker
from multimorph.design._mapped import (
    MappingRound,
    correction_factors,
    flat_factors,
    mapped_design,
    model_checker,
    rescore,
    screen_cells,
)
from multimorph.design._models import BatchModel, CountingModel, rom_batch_model, single_cell
from multimorph.design._optimise import DesignResult, DesignSettings, design
from multimorph.design._report import (
    convergence_figure,
    device_toml,
    fe_figure,
    report_dict,
    report_markdown,
    robustness_figure,
    sequence_figure,
)
from multimorph.design._robust import RobustnessReport, robustness
from multimorph.design._target import TargetSpec, graded_target
from multimorph.design._verify import verify_fe
from multimorph.device import simulate_device
from multimorph.errors import MultimorphError
from multimorph.io import write_json

__all__ = ["DesignRun", "run_design", "write_design_report"]


@dataclass(frozen=True, eq=False)
class DesignRun:
    """Everything one design run found.

    Attributes
    ----------
    result : DesignResult
        The search; ``result.target`` holds the searched stages (graded parts included).
    robustness : RobustnessReport or None
        Monte Carlo robustness of a feasible best design (``None`` when not run).
    device_result : multimorph.device.DeviceResult or None
        The best device simulated on the reduced model.
    sequence : dict or None
        Its sequence of motions (``device_result.sequence.to_dict()``).
    simulation_error : str or None
        Why the best device's simulation failed, if it did.
    verification : dict or None
        The FE check of the best design's cells (:func:`~multimorph.design.verify_fe`).
    """

    result: DesignResult
    robustness: RobustnessReport | None = None
    device_result: Any = None
    sequence: dict[str, Any] | None = None
    simulation_error: str | None = None
    verification: dict[str, Any] | None = None


def run_design(target: TargetSpec, settings: DesignSettings, *,
               model: BatchModel | None = None, robustness_samples: int = 64,
               check_fe: bool = False,
               progress: Callable[[int, int, str], None] | None = None,
               stage: Callable[[str], None] | None = None,
               search_model: BatchModel | None = None, rounds: int = 3,
               fe_rounds: int | None = None, fe_folder: Path | None = None,
               fe_mesh: str = "coarse", fe_wall_elements: int | None = None,
               fe_max_steps: int = 400, fe_route: str = "modules",
               fe_twist: str = "strip", fe_screen: int = 0) -> DesignRun:
    """Design a device for ``target``, then check the best design.

    Parameters
    ----------
    target : TargetSpec
    settings : DesignSettings
        Search settings (budget, population, seed, tolerances, gradient, graded stages).
    model : BatchModel, optional
        The batched cell model; default the reduced model traced design by design
        (:func:`rom_batch_model`).
    robustness_samples : int
        Monte Carlo samples for the robustness of a feasible best design (0: skip).
    check_fe : bool
        Check the best design's cells with the FE model (:func:`verify_fe`).
    progress : callable, optional
        ``progress(done, total, phase)`` during the search.
    search_model : BatchModel, optional
        A faster model to search on (e.g. ``calibrated-fast``): its best designs are
        scored by ``model``, and the targets are corrected by space mapping for up to
        ``rounds`` more searches (:func:`~multimorph.design.mapped_design`). The report,
        the Monte Carlo and the device simulation use ``model``.
    rounds : int
        Space-mapping corrections at most (with ``search_model``).
    fe_rounds : int, optional
        FE in the loop: after the search, the best design's whole device is inflated in 3D
        FE (:func:`~multimorph.design.fe_checker`, kept in ``fe_folder``); where FE misses
        a target, the targets are corrected by the model/FE ratio of that design and the
        search runs again near it, at most ``fe_rounds`` times. ``None``: no device FE.
    fe_mesh, fe_wall_elements, fe_max_steps
        The device FE's mesh and its most continuation steps.
    fe_route : {"modules", "device"}
        How FE inflates a design (:data:`~multimorph.design.FE_ROUTES`): each stage's
        module on its own (default), or the whole device as one problem.
    fe_twist : {"strip", "shaft"}
        On the ``modules`` route, a twisting module as one tilted cell of its strips with
        the module's shaft kinematics (default), or its strips on the shaft in one FE
        problem (:data:`~multimorph.design.TWIST_ROUTES`).
    fe_screen : int
        FE in the loop on the ``modules`` route: where FE misses, check up to this many
        other cells of the stage it misses most in FE too (one module's FE each;
        ``_fe_loop``). 0: none.
    stage : callable, optional
        ``stage(description)`` when a later step begins (robustness, FE check).

    Returns
    -------
    DesignRun
    """
    searched = graded_target(target, settings.graded_ratio) if settings.graded else target
    # one model, one batch shape for search, Monte Carlo and the final simulation
    model = CountingModel(model if model is not None else rom_batch_model(),
                          pad_to=settings.population * len(searched.stages))
    wanted = target if searched is not target else None
    fast = (CountingModel(search_model, pad_to=settings.population * len(searched.stages))
            if search_model is not None else None)

    def search(x0: Any = None, correction: Any = None, tag: str = "") -> DesignResult:
        tell = progress
        if tag and progress is not None:
            def tell(done: int, total: int, phase: str) -> None:
                progress(done, total, f"{tag}{phase}")
        plain = replace(settings, graded=False)       # ``searched`` holds the parts
        radius = None if x0 is None else FE_RADIUS
        if fast is None:
            return design(searched, model=model, settings=plain, progress=tell, x0=x0,
                          radius=radius, correction=correction,
                          model_order=correction is not None)
        return mapped_design(searched, search_model=fast,
                             check=model_checker(model, correction), settings=plain,
                             rounds=rounds, progress=tell, boxes=fast.support_boxes(), x0=x0,
                             radius=FE_RADIUS if x0 is not None else 0.15,
                             correction=correction,
                             polish_model=model if correction is None else None,
                             model_order=correction is not None)

    result = search()
    fe_records: list[Any] = []
    if fe_rounds is not None and result.best is not None:
        result = _fe_loop(searched, result, search, fe_rounds=fe_rounds, model=model,
                          folder=Path(fe_folder) if fe_folder is not None else Path(
                              "multimorph-out") / "fe-rounds",
                          mesh=fe_mesh, wall_elements=fe_wall_elements,
                          max_steps=fe_max_steps, stage=stage,
                          records=fe_records, route=fe_route, twist=fe_twist,
                          order_models=[fast] if fast is not None else [],
                          screen=fe_screen)
    result = replace(result, target=searched, wanted=wanted)
    target = result.target            # the searched stages (graded parts included)
    best = result.best
    report = None
    if best is not None and result.feasible and robustness_samples > 0:
        if stage is not None:
            stage("robustness (Monte Carlo)")
        report = robustness(target, best, n_samples=robustness_samples, seed=settings.seed,
                            model=model, wall_tolerance=settings.wall_tolerance,
                            default_cv=settings.default_cv)
    device_result, sequence, error = None, None, None
    if best is not None and best.device is not None:
        try:
            device_result = simulate_device(best.device, cell_model=single_cell(model))
            sequence = device_result.sequence.to_dict()
        except MultimorphError as exc:  # the search result stays; the report says why
            error = f"device simulation of the best design failed: {exc}"
    verification = None
    if check_fe and best is not None and result.feasible:
        if stage is not None:
            stage("FE verification of the best design…")
        verification = verify_fe(target, best)
    return DesignRun(result, report, device_result, sequence, error, verification)


#: Trust region (unit coordinates) of a search that corrects an FE-checked design.
FE_RADIUS = 0.1


def _agreed(fe: Evaluation, *models: Evaluation) -> bool:
    """FE meets the targets and every model alone (uncorrected: the checking model and the
    search model, i.e. ``calibrated`` and ``calibrated-fast``) keeps the stage order (its
    ``.order`` constraints): a design its device file can stand for, since users simulate
    it on a model (stop 37: the gripper's first FE-verified design swapped its stages on
    the calibrated model, its second on the fast one)."""
    return fe.meets and all(v <= 0 for m in models for k, v in m.violations.items()
                            if k.endswith(".order"))


def _rank(fe: Evaluation, agreed: bool) -> tuple[bool, bool, float]:
    """The FE loop's best design: one FE and the models agree on (:func:`_agreed`) first,
    then one FE verifies, then the FE objective."""
    return (not agreed, not fe.meets, fe.objective)


def _fe_loop(searched: TargetSpec, result: DesignResult, search: Callable[..., DesignResult],
             *, fe_rounds: int, model: Any, folder: Path, mesh: str,
             wall_elements: int | None, stage: Callable[[str], None] | None,
             records: list[Any], max_steps: int = 400, route: str = "modules",
             twist: str = "strip", order_models: Sequence[Any] = (),
             screen: int = 0) -> DesignResult:
    """FE in the loop: device FE of the best design; where it misses, the model corrected
    by the FE/model ratio of the round's design (space mapping on the newest iterate) and
    the search run again near the best FE-checked design, until FE meets the targets on a
    design whose stages also come in order on the model alone (:func:`_agreed`; the
    corrected checker asks for that order too). A round whose search returns a design FE
    has already checked ends the loop: the same FE result would only repeat (a
    round that moves away from the best one still corrects the next search: stop 34,
    where correcting by the best design's ratio alone ran the gripper's rounds 4–6 on one
    and the same design).

    ``screen`` (the ``modules`` route): where FE misses, the stage it misses most is
    checked in FE with up to this many other cells too (:func:`_screen_stage`): each
    module's FE is its own, so a design whose other stages FE has measured costs one
    module's FE, and a stage whose cells FE contradicts (the three-stage target's twist,
    stop 38: no hardening knee in FE on the cells the search kept proposing) is tried on
    cells the next round would not reach."""
    check = fe_checker(folder, mesh=mesh, wall_elements=wall_elements, max_steps=max_steps,
                       route=route, twist=twist,
                       progress=(lambda text: stage(text)) if stage is not None else None,
                       records=records)
    pmax = searched.constraints.max_pressure
    rounds: list[MappingRound] = []
    # (model, FE, agreed) of the best so far
    best_fe: tuple[Evaluation, Evaluation, bool] | None = None
    correction = None
    checked: list[np.ndarray] = []
    tried: dict[int, list[np.ndarray]] = {}
    for k in range(fe_rounds + 1):
        t0 = time.perf_counter()
        if k > 0:
            assert best_fe is not None
            result = search(x0=best_fe[1].candidate.x, correction=correction,
                            tag=f"FE round {k}: ")
            if result.best is None:
                break
            if any(np.allclose(result.best.candidate.x, x, rtol=0.0, atol=1e-9)
                   for x in checked):
                if stage is not None:
                    stage(f"FE round {k}: the search returned a design FE has checked; "
                          "stopping")
                break
        checked.append(np.asarray(result.best.candidate.x, float))
        mine = rescore(searched, result.best)          # the model's own view, uncorrected
        if stage is not None:
            stage(f"FE round {k}: {'module' if route == 'modules' else 'device'} FE of the "
                  "best design…")
        fe_ev = check(searched, [result.best])[0]
        # the other models' own view (the search model), uncorrected, for the stage order
        views = [model_checker(m)(searched, [result.best])[0] for m in order_models]
        agreed = _agreed(fe_ev, mine, *views)
        screened: list[dict[str, Any]] = []
        if screen > 0 and route == "modules" and not agreed:
            mine, fe_ev, agreed, screened = _screen_stage(
                searched, result, mine, fe_ev, agreed, check, model, order_models,
                screen, tried, correction=correction, seed=k, stage=stage,
                tag=f"FE round {k}: ")
            checked.extend(np.asarray(e["x"], float) for e in screened)
        if best_fe is None or _rank(fe_ev, agreed) < _rank(best_fe[1], best_fe[2]):
            best_fe = (mine, fe_ev, agreed)
        nxt = correction_factors(mine, fe_ev, pmax)
        rounds.append(MappingRound(k, searched, correction, mine, fe_ev,
                                   flat_factors(searched, nxt), result.evaluations,
                                   time.perf_counter() - t0,
                                   tuple({q: v for q, v in e.items() if q != "x"}
                                         for e in screened)))
        if best_fe[2]:
            break
        correction = nxt
    assert best_fe is not None
    others = [d for d in result.designs if d.candidate is not best_fe[0].candidate]
    return replace(result, fe_rounds=tuple(rounds), fe_best=best_fe[1], fe_route=route,
                   fe_twist=twist if route == "modules" else None,
                   designs=[best_fe[0], *others])


def _screen_stage(target: TargetSpec, result: DesignResult, mine: Evaluation,
                  fe_ev: Evaluation, agreed: bool, check: Callable[..., list[Evaluation]],
                  model: Any, order_models: Sequence[Any], n: int,
                  tried: dict[int, list[np.ndarray]], *,
                  correction: Any = None, seed: int = 0,
                  stage: Callable[[str], None] | None = None, tag: str = "",
                  ) -> tuple[Evaluation, Evaluation, bool, list[dict[str, Any]]]:
    """FE screening of the stage FE misses most: the round's design with that stage's cell
    replaced by up to ``n`` other cells, each checked in FE — on the ``modules`` route only
    that stage's module is new. The design with the best FE result (:func:`_rank`) is the
    round's. Returns its (model view, FE, agreed) and one record per screened cell.

    The cells (:func:`~multimorph.design._mapped.screen_cells`): that stage's cells of
    the search's designs (``result.pool``, else its ranked designs) and
    ``_mapped.SCREEN_SAMPLES`` random cells of the stage in the round's design, scored for
    that stage on the search's view (the first of ``order_models``, else ``model``; with
    the round's ``correction``). The first is the best scored, each next the one farthest
    from the cells FE has checked for the stage (``tried``, over the run) among the best
    scored (``_mapped.SCREEN_SHORTLIST``): a cell like the one FE contradicted is not the
    only kind tried."""
    from multimorph.design._evaluate import evaluate_one
    from multimorph.design._mapped import stage_score
    from multimorph.design._space import N_VARS, SearchSpace

    S = len(target.stages)
    misses = {i: stage_score(fe_ev, i, target) for i in range(S)}
    i = max(misses, key=lambda j: misses[j])
    if misses[i] <= 0.0:
        return mine, fe_ev, agreed, []
    cut = slice(i * N_VARS, (i + 1) * N_VARS)
    base = np.asarray(mine.candidate.x, float)
    seen = tried.setdefault(i, [])
    seen.append(base[cut].copy())
    boxes = (model.support_boxes() if callable(getattr(model, "support_boxes", None))
             else None)
    space = SearchSpace(target, boxes=boxes)
    picks = screen_cells(target, result.pool or result.designs, mine, i,
                         order_models[0] if order_models else model, space, correction, n,
                         seen, seed)
    best = (mine, fe_ev, agreed)
    name = target.stages[i].name
    log: list[dict[str, Any]] = []
    for z, n_cells in picks:
        x = base.copy()
        x[cut] = z
        cand = space.decode(x)
        out = list(model(cand.model_cells(model), target.constraints.max_pressure))
        counts = [s.n_cells for s in mine.stages]
        counts[i] = n_cells
        alt = evaluate_one(target, cand, out, fixed_cells=counts)
        if alt.device is None:
            continue
        if stage is not None:
            stage(f"{tag}FE screening of stage {name}: cell {len(log) + 1} of {len(picks)}")
        fe_alt = check(target, [alt])[0]
        views = [model_checker(m)(target, [alt])[0] for m in order_models]
        ok = _agreed(fe_alt, alt, *views)
        st = fe_alt.stages[i]
        log.append({"stage": name, "x": x, "fe_start_pressure": st.start,
                    "fe_end_pressure": st.end, "fe_magnitude": st.magnitude,
                    "model_start_pressure": alt.stages[i].start,
                    "model_end_pressure": alt.stages[i].end,
                    "model_magnitude": alt.stages[i].magnitude,
                    "fe_objective": fe_alt.objective, "kept": False})
        if _rank(fe_alt, ok) < _rank(best[1], best[2]):
            best = (alt, fe_alt, ok)
            for e in log:
                e["kept"] = e is log[-1]
    return (*best, log)


def write_design_report(run: DesignRun, folder: Path, *, header: str,
                        model: str | None = None) -> dict[str, Any]:
    """Write a design run's files into ``folder``: ``device.toml`` (``closest_device.toml``
    when the target is infeasible on the model and not FE-verified), ``sequence.png``,
    ``robustness.png``, ``fe_verification.png``, ``convergence.png``, ``report.json`` and
    ``report.md`` (all but the last three only where it has them: ``multimorph design``
    removes those an earlier run left in its folder, ``atomic_output_dir(stale=...)``).

    ``header`` heads the device TOML (how it was designed). Returns the report (the content
    of ``report.json``, with ``files``).
    """
    folder = Path(folder)
    result, best = run.result, run.result.best
    report = report_dict(result, run.robustness, run.sequence, run.verification,
                         simulation_error=run.simulation_error)
    if model is not None:
        # which cell model gave the numbers (the FE ones are under "fe" / "fe_rounds")
        report["model"] = model
        if result.rounds:
            report["search_model"] = "calibrated-fast"
    files = ["report.json", "report.md", "convergence.png"]
    if best is not None and best.device is not None:
        # FE is the reference: a design FE verified is the device, even where the model
        # alone misses a target by a little (that is what the FE rounds corrected)
        verified = result.fe_best is not None and result.fe_best.meets
        name = "device.toml" if result.feasible or verified else "closest_device.toml"
        (folder / name).write_text(device_toml(best.device, header=header))
        files.append(name)
    if run.device_result is not None:
        sequence_figure(run.device_result, result.target).savefig(folder / "sequence.png",
                                                                  dpi=120)
        files.append("sequence.png")
    if run.robustness is not None:
        robustness_figure(run.robustness, result.target).savefig(folder / "robustness.png",
                                                                 dpi=110)
        files.append("robustness.png")
    if result.fe_rounds:
        fe_figure(result).savefig(folder / "fe_verification.png", dpi=110)
        files.append("fe_verification.png")
    convergence_figure(result).savefig(folder / "convergence.png", dpi=110)
    report["files"] = files
    write_json(folder / "report.json", report)
    (folder / "report.md").write_text(report_markdown(
        result, run.robustness, run.sequence, run.verification,
        simulation_error=run.simulation_error))
    return report
