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

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from multimorph.design._mapped import mapped_design, model_checker
from multimorph.design._models import BatchModel, CountingModel, rom_batch_model, single_cell
from multimorph.design._optimise import DesignResult, DesignSettings, design
from multimorph.design._report import (
    convergence_figure,
    device_toml,
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
               search_model: BatchModel | None = None, rounds: int = 3) -> DesignRun:
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
    if search_model is None:
        result = design(target, model=model, settings=settings, progress=progress)
    else:
        fast = CountingModel(search_model, pad_to=settings.population * len(searched.stages))
        result = mapped_design(target, search_model=fast, check=model_checker(model),
                               settings=settings, rounds=rounds, progress=progress,
                               boxes=fast.support_boxes())
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


def write_design_report(run: DesignRun, folder: Path, *, header: str) -> dict[str, Any]:
    """Write a design run's files into ``folder``: ``device.toml`` (``closest_device.toml``
    when the target is infeasible), ``sequence.png``, ``robustness.png``,
    ``convergence.png``, ``report.json`` and ``report.md``.

    ``header`` heads the device TOML (how it was designed). Returns the report (the content
    of ``report.json``, with ``files``).
    """
    folder = Path(folder)
    result, best = run.result, run.result.best
    report = report_dict(result, run.robustness, run.sequence, run.verification,
                         simulation_error=run.simulation_error)
    files = ["report.json", "report.md", "convergence.png"]
    if best is not None and best.device is not None:
        name = "device.toml" if result.feasible else "closest_device.toml"
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
    convergence_figure(result).savefig(folder / "convergence.png", dpi=110)
    report["files"] = files
    write_json(folder / "report.json", report)
    (folder / "report.md").write_text(report_markdown(
        result, run.robustness, run.sequence, run.verification,
        simulation_error=run.simulation_error))
    return report
