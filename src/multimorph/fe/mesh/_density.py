"""How finely a mesh divides a cell: the density presets and explicit element sizes."""

from __future__ import annotations

import math
from dataclasses import dataclass

from multimorph.errors import SpecError
from multimorph.geometry import CellGeometry

__all__ = ["MESH_PRESETS", "MeshDensity", "resolve_density"]


@dataclass(frozen=True)
class MeshDensity:
    """How finely to divide a cell.

    Parameters
    ----------
    wall_elements : int
        Elements through the thickness of every wall (≥ 1).
    size : float or None
        Target element edge length (m); ``None`` uses ``length_fraction``.
    length_fraction : float
        Target edge length as a fraction of the cell length d (used when ``size`` is None).
    """

    wall_elements: int = 2
    size: float | None = None
    length_fraction: float = 0.1

    def edge(self, geometry: CellGeometry) -> float:
        """The target edge length (m) for a cell of ``geometry``."""
        return self.size if self.size is not None else self.length_fraction * geometry.length


#: Named densities. At the reference cell (d 20, w 10, h 8, walls 1–2 mm) the half model has
#: about 1.6k (coarse), 4.7k (medium) and 11k (fine) displacement DOF.
MESH_PRESETS: dict[str, MeshDensity] = {
    "coarse": MeshDensity(wall_elements=2, length_fraction=1 / 10),
    "medium": MeshDensity(wall_elements=3, length_fraction=1 / 16),
    "fine": MeshDensity(wall_elements=4, length_fraction=1 / 24),
}


def resolve_density(mesh: str | MeshDensity = "coarse", element_size: float | None = None,
                    ) -> MeshDensity:
    """A :class:`MeshDensity` from a preset name and/or an explicit element size (m).

    An explicit size keeps at least two elements through each wall.
    """
    if isinstance(mesh, MeshDensity):
        base = mesh
    else:
        try:
            base = MESH_PRESETS[str(mesh).lower()]
        except KeyError:
            raise SpecError(f"mesh: unknown preset {mesh!r}; expected one of "
                            f"{', '.join(MESH_PRESETS)}") from None
    if element_size is not None:
        if not (math.isfinite(element_size) and element_size > 0):
            raise SpecError(f"element_size: must be a positive length, got {element_size!r}")
        return MeshDensity(wall_elements=max(2, base.wall_elements), size=float(element_size))
    return base
