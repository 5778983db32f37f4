"""Finite-element verification (FElupe + contique + gmsh): the only room that imports them.

Structured hexahedral meshes of a cell, a module, a tilted (twisting) strip
(:func:`cell_mesh`), a device (:func:`device_mesh`: modules in series, twisting modules
and parallel branches tied on by rigid hubs) or a twisting module of tilted strips around a
shaft (:func:`twisting_module_mesh`), a nearly incompressible mixed u/p/J̄ model with the
package's own material energies (through tensortrax), follower pressure on the chamber
faces, pressure-controlled stepping with cutbacks and arc-length continuation through
limit points, measurements from node coordinates, and the shared
:class:`~multimorph.response.Response` (``backend="fe"``).

Four sub-packages, imported one way (mesh, engine → analyses → report):
:mod:`~multimorph.fe.mesh` (the hexahedral meshes), :mod:`~multimorph.fe.engine` (problem,
material adapter, linear solvers, the one path driver, checkpoints),
:mod:`~multimorph.fe.analyses` (cell, device and twisting module on one run skeleton, their
measurements, ROM vs FE, the route of one run) and :mod:`~multimorph.fe.report` (files,
plots, solids). This package re-exports the names most callers need.

Heavy dependencies are imported inside functions; a missing one raises
:class:`MissingExtraError` naming ``multimorph[fe]``.
"""

from multimorph.fe._deps import MissingExtraError
from multimorph.fe.analyses import (
    CELL_ENDS,
    Comparison,
    FEDeviceResult,
    FEResult,
    FETwistResult,
    ShearComparison,
    bend_and_twist,
    build_cell_problem,
    chamber_volume,
    circle_fit_curvature,
    compare_cell,
    compare_device,
    compare_responses,
    compare_shear,
    compare_shear_responses,
    compare_twisting,
    line_stretch,
    peak_stretch,
    simulate_cell,
    simulate_device,
    simulate_twisting_module,
    strip_strain,
)
from multimorph.fe.engine import (
    FESettings,
    LinearSolver,
    NonFiniteSystemError,
    PathCheckpoint,
    PathPoint,
    PathRun,
    PressureProblem,
    continuation,
    make_solver,
    newton,
    pressure_control,
)
from multimorph.fe.mesh import (
    FE_MODULE_KINDS,
    MESH_PRESETS,
    CellMesh,
    DeviceMesh,
    MeshDensity,
    TwistMesh,
    cell_mesh,
    device_mesh,
    fe_device_branches,
    fe_device_modules,
    resolve_density,
    twisting_module_mesh,
)

__all__ = [
    "CELL_ENDS",
    "FE_MODULE_KINDS",
    "MESH_PRESETS",
    "CellMesh",
    "Comparison",
    "DeviceMesh",
    "FEDeviceResult",
    "FEResult",
    "FESettings",
    "FETwistResult",
    "LinearSolver",
    "MeshDensity",
    "MissingExtraError",
    "NonFiniteSystemError",
    "PathCheckpoint",
    "PathPoint",
    "PathRun",
    "PressureProblem",
    "ShearComparison",
    "TwistMesh",
    "bend_and_twist",
    "build_cell_problem",
    "cell_mesh",
    "chamber_volume",
    "circle_fit_curvature",
    "compare_cell",
    "compare_device",
    "compare_responses",
    "compare_shear",
    "compare_shear_responses",
    "compare_twisting",
    "continuation",
    "device_mesh",
    "fe_device_branches",
    "fe_device_modules",
    "line_stretch",
    "make_solver",
    "newton",
    "peak_stretch",
    "pressure_control",
    "resolve_density",
    "simulate_cell",
    "simulate_device",
    "simulate_twisting_module",
    "strip_strain",
    "twisting_module_mesh",
]
