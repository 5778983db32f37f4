"""FE meshes: structured hexahedral grids of a cell or module, a device and a twisting module.

Every mesh is a :class:`HexMesh` (points, VTK hexahedra, region tags, the chamber surface as
quad faces, the clamped and mirror nodes, and its bodies of one material each), so the
analyses build their FE problem from any of them alike.
"""

from multimorph.fe.mesh._branches import (
    FE_DEVICE_KINDS,
    FE_MODULE_KINDS,
    FEBranch,
    device_pieces,
    fe_device_branches,
    fe_device_modules,
    flipped,
    in_grid,
)
from multimorph.fe.mesh._cell import MAX_TILT, CellMesh, cell_mesh
from multimorph.fe.mesh._density import MESH_PRESETS, MeshDensity, resolve_density
from multimorph.fe.mesh._device import DeviceMesh, Hub, device_mesh
from multimorph.fe.mesh._hex import (
    BOTTOM,
    HEX_FACES,
    REGION_NAMES,
    SHAFT,
    WALL,
    HexMesh,
    hex_boundary,
)
from multimorph.fe.mesh._twist import CORE, TwistMesh, twisting_module_mesh

__all__ = [
    "BOTTOM",
    "CORE",
    "FE_DEVICE_KINDS",
    "FE_MODULE_KINDS",
    "HEX_FACES",
    "MAX_TILT",
    "MESH_PRESETS",
    "REGION_NAMES",
    "SHAFT",
    "WALL",
    "CellMesh",
    "DeviceMesh",
    "FEBranch",
    "HexMesh",
    "Hub",
    "MeshDensity",
    "TwistMesh",
    "cell_mesh",
    "device_mesh",
    "device_pieces",
    "fe_device_branches",
    "fe_device_modules",
    "flipped",
    "hex_boundary",
    "in_grid",
    "resolve_density",
    "twisting_module_mesh",
]
