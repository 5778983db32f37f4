"""Design room: inverse design of sequentially morphing devices, and their robustness.

From a target (an ordered list of wanted motions with the pressures at which they should
complete, plus constraints) to ranked device designs whose predicted sequence meets it, an
explanation when none can, and Monte Carlo robustness figures. See ``docs/design.md``.
"""

from multimorph.design._evaluate import Evaluation, StageResult, evaluate_one
from multimorph.design._fe_check import (
    FE_ROUTES,
    TWIST_ROUTES,
    fe_checker,
    module_measure,
    strip_twist_response,
)
from multimorph.design._mapped import (
    Checker,
    MappingRound,
    correction_factors,
    mapped_design,
    model_checker,
    polish_stages,
)
from multimorph.design._models import (
    ROM_BATCH_NAMES,
    BatchModel,
    CountingModel,
    batched,
    rom_batch_model,
    single_cell,
)
from multimorph.design._optimise import DesignResult, DesignSettings, design, evaluate_population
from multimorph.design._pipeline import DesignRun, run_design, write_design_report
from multimorph.design._robust import RobustnessReport, material_stderr, robustness
from multimorph.design._space import (
    N_VARS,
    VAR_NAMES,
    Candidate,
    SearchSpace,
    build_device,
    device_length,
)
from multimorph.design._target import (
    GRADED_RATIO,
    GRADED_RATIO_CALIBRATED,
    STAGE_KINDS,
    Constraints,
    Stage,
    TargetSpec,
    Tolerance,
    graded_target,
    target_from_spec,
)

__all__ = [
    "FE_ROUTES",
    "GRADED_RATIO",
    "GRADED_RATIO_CALIBRATED",
    "N_VARS",
    "ROM_BATCH_NAMES",
    "STAGE_KINDS",
    "TWIST_ROUTES",
    "VAR_NAMES",
    "BatchModel",
    "Candidate",
    "Checker",
    "Constraints",
    "CountingModel",
    "DesignResult",
    "DesignRun",
    "DesignSettings",
    "Evaluation",
    "MappingRound",
    "RobustnessReport",
    "SearchSpace",
    "Stage",
    "StageResult",
    "TargetSpec",
    "Tolerance",
    "batched",
    "build_device",
    "correction_factors",
    "design",
    "device_length",
    "evaluate_one",
    "evaluate_population",
    "fe_checker",
    "graded_target",
    "mapped_design",
    "material_stderr",
    "model_checker",
    "module_measure",
    "polish_stages",
    "robustness",
    "rom_batch_model",
    "run_design",
    "single_cell",
    "strip_twist_response",
    "target_from_spec",
    "write_design_report",
]
