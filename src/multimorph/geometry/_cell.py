"""The pneu-net unit cell in the reference paper's notation (Jeong et al. 2023, Fig. 4A).

Axes: y along the cell (length/depth d), x across (width w), z up (height h). A cuboid
chamber wc × hc × dc is surrounded by a top wall ht, a bottom wall hb of a (stiffer) bottom
material, side walls ws (normal to x) and front/rear (end) walls df (normal to y)::

    w = wc + 2 ws,   h = hc + ht + hb,   d = dc + 2 df

All lengths in metres.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

from multimorph.errors import SpecError
from multimorph.limits import MAX_CELL_SIZE
from multimorph.materials._material import Material
from multimorph.units import to_si

__all__ = ["CELL_KEYS", "CellGeometry"]

#: TOML keys of a ``[cell]`` table (lengths) and the paper's symbols.
CELL_KEYS = {
    "length": "d",
    "width": "w",
    "height": "h",
    "top_wall": "ht",
    "bottom_wall": "hb",
    "side_wall": "ws",
    "end_wall": "df",
}


def _is_bare_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _fmt(x: float) -> str:
    return f"{x * 1e3:.4g} mm"


@dataclass(frozen=True)
class CellGeometry:
    """A unit cell: outer size, wall thicknesses (m) and materials.

    Parameters
    ----------
    length, width, height : float
        Outer length d (along y, the cell axis), width w (x) and height h (z) (m).
    top_wall, bottom_wall, side_wall, end_wall : float
        Wall thicknesses ht, hb, ws, df (m).
    material : Material
        Elastomer of the top, side and end walls.
    bottom_material : Material, optional
        Elastomer of the bottom wall (the strain-limiting layer); default ``material``.
    symmetric : bool
        The cell is mirror-symmetric about its mid-height (a stretching cell: bottom wall =
        top wall, one elastomer). The reduced model then bulges the bottom wall like the top
        one and the cell stretches instead of bending (``RomOptions(mirror=True)``). Set by
        stretching modules; requires ``bottom_wall == top_wall`` and
        ``bottom_material == material``.

    Examples
    --------
    >>> from multimorph.materials import Material
    >>> m = Material("gent", {"mu": 2.45e5, "jm": 20.0})
    >>> c = CellGeometry(20e-3, 10e-3, 8e-3, 1e-3, 2e-3, 2e-3, 2e-3, material=m)
    >>> round(c.chamber_width * 1e3, 6), round(c.chamber_height * 1e3, 6)
    (6.0, 5.0)
    """

    length: float
    width: float
    height: float
    top_wall: float
    bottom_wall: float
    side_wall: float
    end_wall: float
    material: Material
    bottom_material: Material | None = None
    symmetric: bool = False

    def __post_init__(self) -> None:
        for key in CELL_KEYS:
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise SpecError(f"{key}: expected a length, got {v!r}")
            v = float(v)
            if not math.isfinite(v) or v <= 0:
                raise SpecError(f"{key}: must be a positive length, got {v!r} m")
            object.__setattr__(self, key, v)
        if not isinstance(self.material, Material):
            raise SpecError(f"material: expected a Material, got {type(self.material).__name__}")
        if self.bottom_material is None:
            object.__setattr__(self, "bottom_material", self.material)
        elif not isinstance(self.bottom_material, Material):
            raise SpecError("bottom_material: expected a Material")
        if not isinstance(self.symmetric, bool):
            raise SpecError(f"symmetric: expected true or false, got {self.symmetric!r}")
        if self.symmetric and (self.bottom_material != self.material
                               or not math.isclose(self.bottom_wall, self.top_wall,
                                                   rel_tol=1e-9)):
            raise SpecError(
                f"symmetric: a mirror-symmetric cell needs bottom_wall = top_wall (got "
                f"{_fmt(self.bottom_wall)} and {_fmt(self.top_wall)}) and bottom_material = "
                f"material")
        if self.chamber_width <= 0:
            raise SpecError(
                f"side_wall {_fmt(self.side_wall)} leaves no chamber in width {_fmt(self.width)}"
                f" (needs 2 × side_wall < width)")
        if self.chamber_height <= 0:
            raise SpecError(
                f"top_wall {_fmt(self.top_wall)} + bottom_wall {_fmt(self.bottom_wall)} leave no "
                f"chamber in height {_fmt(self.height)}")
        if self.chamber_length <= 0:
            raise SpecError(
                f"end_wall {_fmt(self.end_wall)} leaves no chamber in length {_fmt(self.length)}"
                f" (needs 2 × end_wall < length)")

    # paper symbols ---------------------------------------------------------------
    d = property(lambda self: self.length)
    w = property(lambda self: self.width)
    h = property(lambda self: self.height)
    ht = property(lambda self: self.top_wall)
    hb = property(lambda self: self.bottom_wall)
    ws = property(lambda self: self.side_wall)
    df = property(lambda self: self.end_wall)

    @property
    def chamber_width(self) -> float:
        """wc = w − 2 ws (m)."""
        return self.width - 2.0 * self.side_wall

    @property
    def chamber_height(self) -> float:
        """hc = h − ht − hb (m)."""
        return self.height - self.top_wall - self.bottom_wall

    @property
    def chamber_length(self) -> float:
        """dc = d − 2 df (m)."""
        return self.length - 2.0 * self.end_wall

    wc = chamber_width
    hc = chamber_height
    dc = chamber_length

    @property
    def signal(self) -> str:
        """The path quantity that shows the cell's activation: ``"axial_stretch"`` for a
        mirror-symmetric (stretching) cell, which does not bend, else ``"curvature"``."""
        return "axial_stretch" if self.symmetric else "curvature"

    @property
    def mu(self) -> float:
        """Shear modulus of the wall material (Pa)."""
        return self.material.shear_modulus

    def ratios(self) -> dict[str, float]:
        """The dimensionless groups of the paper: ws/d, df/d, ht/d (and w/d, h/d, hb/d)."""
        d = self.length
        return {"ws/d": self.ws / d, "df/d": self.df / d, "ht/d": self.ht / d,
                "w/d": self.w / d, "h/d": self.h / d, "hb/d": self.hb / d}

    def scaled(self, factor: float) -> CellGeometry:
        """Geometrically similar cell with every length multiplied by ``factor``."""
        if not factor > 0:
            raise SpecError(f"scale factor must be > 0, got {factor}")
        return replace(self, **{k: getattr(self, k) * factor for k in CELL_KEYS})

    def with_materials(self, material: Material, bottom_material: Material | None = None,
                       ) -> CellGeometry:
        return replace(self, material=material, bottom_material=bottom_material)

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {k: getattr(self, k) for k in CELL_KEYS}
        d["material"] = self.material.to_dict()
        assert self.bottom_material is not None
        d["bottom_material"] = self.bottom_material.to_dict()
        if self.symmetric:
            d["symmetric"] = True
        return d

    def mirrored(self) -> CellGeometry:
        """The same cell declared mirror-symmetric (bottom wall and material = the top's)."""
        return replace(self, bottom_wall=self.top_wall, bottom_material=self.material,
                       symmetric=True)

    @classmethod
    def from_spec(cls, table: Mapping[str, Any], *, field: str = "cell") -> CellGeometry:
        """Build from a ``[cell]`` TOML table (lengths as strings with units; numbers are m)."""
        from multimorph.materials._spec import material_from_spec

        if not isinstance(table, Mapping):
            raise SpecError(f"{field}: expected a table")
        allowed = set(CELL_KEYS) | {"material", "bottom_material", "symmetric"}
        unknown = sorted(set(table) - allowed)
        if unknown:
            raise SpecError(f"{field}: unknown key(s) {', '.join(unknown)}; expected "
                            f"{', '.join(sorted(allowed))}")
        kw: dict[str, Any] = {}
        for key in CELL_KEYS:
            if key not in table:
                raise SpecError(f"{field}.{key}: missing (a length such as \"2 mm\")")
            kw[key] = to_si(table[key], "m", field=f"{field}.{key}")
            if not (math.isfinite(kw[key]) and kw[key] > 0):
                raise SpecError(f"{field}.{key}: must be a positive length, got "
                                f"{table[key]!r}")
            if kw[key] > MAX_CELL_SIZE:
                bare = not isinstance(table[key], str) or _is_bare_number(table[key])
                raise SpecError(
                    f"{field}.{key}: {table[key]!r} is {kw[key]:.3g} m, larger than any cell "
                    f"({MAX_CELL_SIZE:g} m)" + (f"; a bare number is in metres: did you mean "
                                                f"\"{table[key]} mm\"?" if bare else ""))
        if "material" not in table:
            raise SpecError(f"{field}.material: missing (a library name or an inline table)")
        kw["material"] = material_from_spec(table["material"], f"{field}.material")
        if "bottom_material" in table:
            kw["bottom_material"] = material_from_spec(table["bottom_material"],
                                                       f"{field}.bottom_material")
        if "symmetric" in table:
            if not isinstance(table["symmetric"], bool):
                raise SpecError(f"{field}.symmetric: expected true or false, got "
                                f"{table['symmetric']!r}")
            kw["symmetric"] = table["symmetric"]
        try:
            return cls(**kw)
        except SpecError as exc:
            raise SpecError(f"{field}: {exc}") from None


