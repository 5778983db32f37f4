"""The reference unit cell shared by the reduced-model tests (not a test module).

20 × 10 × 8 mm, 0.8 mm top wall, 2 mm bottom layer, 1.5 mm side and end walls; Gent walls
μ = 245 kPa (the paper's elastomer III), Jm = 20, and a Gent bottom layer of 1.2 MPa.
"""

from __future__ import annotations

from multimorph.geometry import CellGeometry
from multimorph.materials import Material

MU = 2.45e5
WALL = Material("gent", {"mu": MU, "jm": 20.0})
BOTTOM = Material("gent", {"mu": 1.2e6, "jm": 20.0})


def ref_cell(**kw: object) -> CellGeometry:
    """The reference cell, with any :class:`CellGeometry` field replaced by ``kw``."""
    base: dict[str, object] = dict(
        length=20e-3, width=10e-3, height=8e-3, top_wall=0.8e-3, bottom_wall=2e-3,
        side_wall=1.5e-3, end_wall=1.5e-3, material=WALL, bottom_material=BOTTOM)
    base.update(kw)
    return CellGeometry(**base)  # type: ignore[arg-type]
