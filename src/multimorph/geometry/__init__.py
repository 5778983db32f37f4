"""Geometry room: frozen, validated value objects for cells (modules and devices build on it)."""

from multimorph.geometry._cell import CELL_KEYS, CellGeometry
from multimorph.geometry._tilted import MAX_TILT, TiltedCell

__all__ = ["CELL_KEYS", "MAX_TILT", "CellGeometry", "TiltedCell"]
