"""Finite-element verification (FElupe + contique + gmsh): the only room that imports them.

Structured hexahedral meshes of a cell, a module, a tilted (twisting) strip
(:func:`cell_mesh`), a device (:func:`device_mesh`: modules in series, twisting modules
and parallel branches tied on by rigid hubs) or a twisting module of tilted strips around a
shaft (:func:`twisting_module_mesh`), a nearly incompressible mixed u/p/J̄ model with the
package's own material energies (through tensortrax), follower pressure on the chamber
faces, pressure-controlled stepping with cutbacks and arc-length continuation through
limit points, measurements from node coordinates, and the shared
:class:`~multimorph.response.Response` (``backend="fe"``).

Heavy dependencies are imported inside functions; a missing one raises
:class:`MissingExtraError` naming ``multimorph[fe]``.
"""

from multimorph.fe._cell import (
    CELL_ENDS,
    FEResult,
    FESettings,
    build_cell_problem,
    simulate_cell,
)
from multimorph.fe._checkpoint import PathCheckpoint
from multimorph.fe._compare import (
    Comparison,
    ShearComparison,
    compare_cell,
    compare_responses,
    compare_shear,
    compare_shear_responses,
)
from multimorph.fe._deps import MissingExtraError
from multimorph.fe._device import (
    FE_MODULE_KINDS,
    DeviceMesh,
    FEDeviceResult,
    compare_device,
    device_mesh,
    fe_device_branches,
    fe_device_modules,
    simulate_device,
)
from multimorph.fe._linsolve import LinearSolver, NonFiniteSystemError, make_solver
from multimorph.fe._measure import (
    bend_and_twist,
    chamber_volume,
    circle_fit_curvature,
    line_stretch,
    peak_stretch,
    strip_strain,
)
from multimorph.fe._mesh import MESH_PRESETS, CellMesh, MeshDensity, cell_mesh, resolve_density
from multimorph.fe._problem import PressureProblem
from multimorph.fe._solve import PathPoint, PathRun, continuation, newton, pressure_control
from multimorph.fe._twist import FETwistResult, compare_twisting, simulate_twisting_module
from multimorph.fe._twist_mesh import TwistMesh, twisting_module_mesh

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
