"""A tilted unit cell: the cell of a twisting module's strip, its chambers at an angle β.

The twisting module (``device``, ``kind = "twisting"``) lays cells along strips with their
chambers tilted by β to the strip axis. The straight cell's expansion along the chamber axis
then shears the strip. A :class:`TiltedCell` is the straight :class:`CellGeometry` plus
that angle, so that a model (the FE of a tilted strip, the calibrated cell model) can be
asked for the strip's shear γ(P) of one design.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from multimorph.errors import SpecError
from multimorph.geometry._cell import CellGeometry

__all__ = ["MAX_TILT", "TiltedCell"]

#: Largest chamber tilt |β| (rad) of a tilted cell (tan β grows without bound at 90°).
MAX_TILT = math.radians(80.0)


@dataclass(frozen=True)
class TiltedCell:
    """A straight cell and the tilt β (rad) of its chambers to the strip axis.

    Parameters
    ----------
    cell : CellGeometry
        The straight cell (lengths in m, materials).
    tilt : float
        Chamber tilt β (rad), 0 < |β| < 80°. Positive β twists a strip left-handed about
        its axis (``docs/fe.md``, tilted cells).

    Examples
    --------
    >>> import math
    >>> from multimorph.materials import Material
    >>> m = Material("gent", {"mu": 1e5, "jm": 20.0})
    >>> c = CellGeometry(10e-3, 12e-3, 10e-3, 0.5e-3, 4e-3, 2.5e-3, 0.75e-3, material=m)
    >>> round(TiltedCell(c, math.radians(30)).ratios()["tilt"], 4)
    0.5236
    """

    cell: CellGeometry
    tilt: float

    def __post_init__(self) -> None:
        if not isinstance(self.cell, CellGeometry):
            raise SpecError(f"cell: expected a CellGeometry, got {type(self.cell).__name__}")
        if self.cell.symmetric:
            raise SpecError("cell: a tilted (twisting) cell has a bottom layer; it cannot be "
                            "mirror-symmetric")
        t = self.tilt
        if isinstance(t, bool) or not isinstance(t, int | float):
            raise SpecError(f"tilt: expected an angle, got {t!r}")
        t = float(t)
        if not (math.isfinite(t) and 0.0 < abs(t) < MAX_TILT):
            raise SpecError(f"tilt: must lie strictly between 0 and "
                            f"{math.degrees(MAX_TILT):.0f} deg in size, got "
                            f"{math.degrees(t):.4g} deg")
        object.__setattr__(self, "tilt", t)

    @property
    def length(self) -> float:
        """The cell length d (m)."""
        return self.cell.length

    @property
    def mu(self) -> float:
        """Shear modulus of the wall material (Pa)."""
        return self.cell.mu

    def ratios(self) -> dict[str, float]:
        """The straight cell's dimensionless groups plus ``tilt`` (rad)."""
        return {**self.cell.ratios(), "tilt": self.tilt}

    def to_dict(self) -> dict[str, Any]:
        return {**self.cell.to_dict(), "tilt": self.tilt}
