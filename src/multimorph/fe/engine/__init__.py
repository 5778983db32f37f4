"""The FE engine: the pressure problem, the material adapter, linear solvers, the path
driver and its checkpoint.

Nothing here knows a mesh or a measurement: :class:`PressureProblem` takes a FElupe mesh,
bodies of one material each, the pressurised nodes and the fixed DOF; :func:`trace_path`
traces its pressure path and hands every converged :class:`PathPoint` to the caller's
recorder.
"""

from multimorph.fe.engine._checkpoint import PathCheckpoint
from multimorph.fe.engine._linsolve import (
    LinearSolver,
    NonFiniteSystemError,
    make_solver,
    pardiso_available,
)
from multimorph.fe.engine._material import (
    TENSORTRAX_MATH,
    InvariantHyperelastic,
    TensortraxMath,
    felupe_umat,
)
from multimorph.fe.engine._path import (
    RETRACE_RESTARTS,
    FESettings,
    path_end,
    retraced,
    trace_path,
)
from multimorph.fe.engine._plane import PlaneTie
from multimorph.fe.engine._problem import AssemblyStats, PressureProblem
from multimorph.fe.engine._solve import (
    NewtonInfo,
    PathPoint,
    PathRun,
    continuation,
    newton,
    pressure_control,
)

__all__ = [
    "RETRACE_RESTARTS",
    "TENSORTRAX_MATH",
    "AssemblyStats",
    "FESettings",
    "InvariantHyperelastic",
    "LinearSolver",
    "NewtonInfo",
    "NonFiniteSystemError",
    "PathCheckpoint",
    "PathPoint",
    "PathRun",
    "PlaneTie",
    "PressureProblem",
    "TensortraxMath",
    "continuation",
    "felupe_umat",
    "make_solver",
    "newton",
    "pardiso_available",
    "path_end",
    "pressure_control",
    "retraced",
    "trace_path",
]
