"""Geometry room: frozen, validated value objects for cells (modules and devices build on it)."""

from multimorph.geometry._cell import CELL_KEYS, CellGeometry

__all__ = ["CELL_KEYS", "CellGeometry"]
