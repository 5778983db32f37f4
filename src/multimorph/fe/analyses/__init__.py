"""FE analyses: a cell or module, a device, a twisting module; what they measure, ROM against
FE, and the route of one run (:class:`FEJob`, :func:`run_job`).

Every analysis runs one skeleton (:func:`run_path`): the mesh's nondimensional problem, the
one path driver (:func:`~multimorph.fe.engine.trace_path`) and the one
:class:`PathRecorder`, whose :class:`StopRules` end every path alike. An analysis adds only
its :class:`Measure` (what it reads from the nodes at every converged point) and how its
response is read from the recorded rows.
"""

from multimorph.fe.analyses._cell import (
    CELL_ENDS,
    STRIP_KEYS,
    CellMeasure,
    FEResult,
    build_cell_problem,
    simulate_cell,
)
from multimorph.fe.analyses._compare import (
    Comparison,
    RomComparison,
    ShearComparison,
    compare_cell,
    compare_cell_run,
    compare_device,
    compare_responses,
    compare_shear,
    compare_shear_responses,
    compare_twisting,
)
from multimorph.fe.analyses._device import DeviceMeasure, FEDeviceResult, simulate_device
from multimorph.fe.analyses._job import JOB_KINDS, FEJob, FEOutcome, run_job
from multimorph.fe.analyses._measure import (
    StripStrain,
    bend_and_twist,
    chamber_volume,
    circle_fit_curvature,
    largest_stretch,
    line_stretch,
    peak_element,
    peak_stretch,
    peak_summary,
    section_motion,
    strip_strain,
    unwrapped,
)
from multimorph.fe.analyses._oracles import (
    OracleResult,
    clamped_strip,
    clamped_strip_exact,
    thick_sphere,
    thick_sphere_exact,
    thick_sphere_limit,
)
from multimorph.fe.analyses._run import (
    Measure,
    Measured,
    PathRecord,
    PathRecorder,
    Progress,
    StopRules,
    activation,
    mesh_problem,
    reached,
    run_path,
)
from multimorph.fe.analyses._twist import (
    FETwistResult,
    TwistMeasure,
    simulate_twisting_module,
    tilt_sense,
)

__all__ = [
    "CELL_ENDS",
    "JOB_KINDS",
    "STRIP_KEYS",
    "CellMeasure",
    "Comparison",
    "DeviceMeasure",
    "FEDeviceResult",
    "FEJob",
    "FEOutcome",
    "FEResult",
    "FETwistResult",
    "Measure",
    "Measured",
    "OracleResult",
    "PathRecord",
    "PathRecorder",
    "Progress",
    "RomComparison",
    "ShearComparison",
    "StopRules",
    "StripStrain",
    "TwistMeasure",
    "activation",
    "bend_and_twist",
    "build_cell_problem",
    "chamber_volume",
    "circle_fit_curvature",
    "clamped_strip",
    "clamped_strip_exact",
    "compare_cell",
    "compare_cell_run",
    "compare_device",
    "compare_responses",
    "compare_shear",
    "compare_shear_responses",
    "compare_twisting",
    "largest_stretch",
    "line_stretch",
    "mesh_problem",
    "peak_element",
    "peak_stretch",
    "peak_summary",
    "reached",
    "run_job",
    "run_path",
    "section_motion",
    "simulate_cell",
    "simulate_device",
    "simulate_twisting_module",
    "strip_strain",
    "thick_sphere",
    "thick_sphere_exact",
    "thick_sphere_limit",
    "tilt_sense",
    "unwrapped",
]
