"""Sweep parameters: what a name like ``cell.top_wall``, ``ht/d`` or ``mu`` sets, and its values.

A parameter is either a *path* into the base spec (``cell.<length>``,
``cell.material.<param>``, ``cell.bottom_material.<param>``) or a *dimensionless group* of the
reference paper (``ht/d``, ``ws/d``, ``df/d``, ``hb/d``, ``w/d``, ``h/d``), the wall shear
modulus ``mu`` (Pa; the wall material is scaled so that its small-strain shear modulus equals
the value) or the modulus ratio ``mu_b/mu`` (the bottom material is scaled so that
μb = ratio · μ).

Values are a list, a linear range (``start``, ``stop``, ``num``) or a log range
(``scale = "log"``); quantities may carry units (``"1 mm"``, ``"300 kPa"``), bare numbers
are SI.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from multimorph.errors import SpecError
from multimorph.geometry import CELL_KEYS
from multimorph.limits import format_bytes
from multimorph.materials import Material
from multimorph.units import to_si

__all__ = ["RATIO_NAMES", "TILT_NAME", "Parameter", "parse_parameter"]

#: Dimensionless length ratios: name -> the cell field set to ratio × d.
RATIO_NAMES = {"ht/d": "top_wall", "ws/d": "side_wall", "df/d": "end_wall",
               "hb/d": "bottom_wall", "w/d": "width", "h/d": "height"}
#: Modulus parameters that scale a material (not paths into its parameters).
MODULUS_NAMES = ("mu", "mu_b/mu")
#: The chamber tilt β of a twisting sweep's tilted cells (angle; bare numbers are rad).
TILT_NAME = "tilt"
#: Most values of one parameter (a range's ``num`` or a list).
MAX_VALUES = 1_000_000
_ENTRY_KEYS = {"name", "path", "values", "start", "stop", "num", "scale", "label"}


@dataclass(frozen=True)
class Parameter:
    """One swept quantity and its values (SI).

    Attributes
    ----------
    name : str
        As written in the spec (``"cell.top_wall"``, ``"ht/d"``, ``"mu"`` …).
    kind : {"length", "material", "ratio", "modulus", "tilt"}
        What it sets: a cell length, a material parameter, a length ratio × d, a modulus
        scaling, or the chamber tilt of a twisting sweep's cells.
    target : str
        The cell field (``"top_wall"``), or ``"material.jm"``, ``"bottom_material.mu"``,
        ``"mu"``, ``"mu_b/mu"``.
    unit : str
        SI unit of the values (``"m"``, ``"Pa"``, ``"dimensionless"``).
    values : tuple of float
        The values for grid/zip combination (SI).
    low, high : float or None
        Sampling bounds for random sampling (ranges only).
    scale : {"list", "linear", "log"}
    """

    name: str
    kind: str
    target: str
    unit: str
    values: tuple[float, ...]
    low: float | None
    high: float | None
    scale: str

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` random values: uniform (linear), log-uniform (log) or drawn from the list."""
        if self.scale == "list":
            return rng.choice(np.asarray(self.values, float), size=n)
        assert self.low is not None and self.high is not None
        if self.scale == "log":
            return np.exp(rng.uniform(math.log(self.low), math.log(self.high), size=n))
        return rng.uniform(self.low, self.high, size=n)

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Values at points ``u`` of the unit interval (space-filling designs): linear or
        logarithmic between the range's ends, or the list entry of that quantile."""
        u = np.clip(np.asarray(u, float), 0.0, 1.0)
        if self.scale == "list":
            vals = np.asarray(self.values, float)
            return vals[np.minimum((u * len(vals)).astype(int), len(vals) - 1)]
        assert self.low is not None and self.high is not None
        if self.scale == "log":
            return np.exp(math.log(self.low) + u * (math.log(self.high) - math.log(self.low)))
        return self.low + u * (self.high - self.low)

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "kind": self.kind, "target": self.target, "unit": self.unit,
                "scale": self.scale, "values": list(self.values), "low": self.low,
                "high": self.high}


def _resolve(name: str, cell_table: Mapping[str, Any], base_material: Material,
             base_bottom: Material, field: str) -> tuple[str, str, str]:
    """(kind, target, unit) of a parameter name, or a SpecError listing what is allowed."""
    if name in RATIO_NAMES:
        return "ratio", RATIO_NAMES[name], "dimensionless"
    if name == "mu":
        return "modulus", "mu", "Pa"
    if name == "mu_b/mu":
        return "modulus", "mu_b/mu", "dimensionless"
    if name == TILT_NAME:
        return "tilt", "tilt", "rad"
    parts = name.split(".")
    if len(parts) == 2 and parts[0] == "cell" and parts[1] in CELL_KEYS:
        return "length", parts[1], "m"
    if len(parts) == 3 and parts[0] == "cell" and parts[1] in ("material", "bottom_material"):
        mat = base_material if parts[1] == "material" else base_bottom
        law = mat.law
        if parts[2] not in law.param_names:
            raise SpecError(
                f"{field}: unknown parameter path {name!r}: material model {law.name} has "
                f"parameters {', '.join(law.param_names)}")
        unit = law.param_units[law.param_names.index(parts[2])]
        return "material", f"{parts[1]}.{parts[2]}", "Pa" if unit == "Pa" else "dimensionless"
    known = ([f"cell.{k}" for k in CELL_KEYS]
             + [f"cell.material.{p}" for p in base_material.law.param_names]
             + [f"cell.bottom_material.{p}" for p in base_bottom.law.param_names]
             + list(RATIO_NAMES) + list(MODULUS_NAMES) + [TILT_NAME])
    raise SpecError(f"{field}: unknown parameter path {name!r}; known: {', '.join(known)}")


def _quantity(value: Any, unit: str, field: str) -> float:
    v = to_si(value, unit, field=field)
    if not math.isfinite(v):
        raise SpecError(f"{field}: must be finite, got {value!r}")
    return v


def parse_parameter(entry: Mapping[str, Any], *, field: str, base_material: Material,
                    base_bottom: Material, cell_table: Mapping[str, Any]) -> Parameter:
    """Parse one ``[[sweep.parameter]]`` table into a :class:`Parameter`.

    Parameters
    ----------
    entry : mapping
        ``name`` (or ``path``) and either ``values`` or ``start``/``stop``/``num`` with
        optional ``scale = "linear" | "log"``.
    field : str
        Spec location used in error messages, e.g. ``"sweep.parameter[2]"``.
    base_material, base_bottom : Material
        The base cell's materials (to check material parameter paths).
    cell_table : mapping
        The base ``[cell]`` table.

    Raises
    ------
    SpecError
        Unknown key or parameter path, empty values or range, malformed range.
    """
    if not isinstance(entry, Mapping):
        raise SpecError(f"{field}: expected a table with 'name' and values")
    unknown = sorted(set(entry) - _ENTRY_KEYS)
    if unknown:
        raise SpecError(f"{field}: unknown key(s) {', '.join(unknown)}; expected "
                        f"{', '.join(sorted(_ENTRY_KEYS - {'label'}))}")
    if ("name" in entry) == ("path" in entry):
        raise SpecError(f"{field}: give exactly one of 'name' or 'path' (e.g. name = \"ht/d\")")
    name = entry.get("name", entry.get("path"))
    if not isinstance(name, str) or not name.strip():
        raise SpecError(f"{field}.name: expected a parameter path or ratio, got {name!r}")
    name = name.strip()
    field = f"{field} ({name})"
    kind, target, unit = _resolve(name, cell_table, base_material, base_bottom, field)

    has_values = "values" in entry
    has_range = any(k in entry for k in ("start", "stop", "num"))
    if has_values == has_range:
        raise SpecError(f"{field}: give either 'values = [...]' or a range "
                        "'start', 'stop', 'num' (with optional scale = \"log\")")
    if has_values:
        raw = entry["values"]
        if "scale" in entry:
            raise SpecError(f"{field}: 'scale' applies to ranges, not to 'values'")
        if not isinstance(raw, list):
            raise SpecError(f"{field}.values: expected a list, got {raw!r}")
        if not raw:
            raise SpecError(f"{field}.values: empty list (no values to sweep)")
        if len(raw) > MAX_VALUES:
            raise SpecError(f"{field}.values: {len(raw)} values; a parameter takes at most "
                            f"{MAX_VALUES}")
        vals = tuple(_quantity(v, unit, f"{field}.values[{i}]") for i, v in enumerate(raw))
        return Parameter(name, kind, target, unit, vals, None, None, "list")

    missing = [k for k in ("start", "stop") if k not in entry]
    if missing:
        raise SpecError(f"{field}: range needs {' and '.join(missing)}")
    start = _quantity(entry["start"], unit, f"{field}.start")
    stop = _quantity(entry["stop"], unit, f"{field}.stop")
    scale = entry.get("scale", "linear")
    if scale not in ("linear", "log"):
        raise SpecError(f"{field}.scale: expected \"linear\" or \"log\", got {scale!r}")
    num = entry.get("num")
    if num is not None and (isinstance(num, bool) or not isinstance(num, int)):
        raise SpecError(f"{field}.num: expected an integer, got {num!r}")
    if num is not None and num < 1:
        raise SpecError(f"{field}: empty range (num = {num}); need num >= 1")
    if num is not None and num > MAX_VALUES:
        raise SpecError(f"{field}.num: {num} values ({format_bytes(8.0 * num)} for the values "
                        f"alone); a parameter takes at most {MAX_VALUES}")
    if scale == "log" and not (start > 0 and stop > 0):
        raise SpecError(f"{field}: a log range needs start > 0 and stop > 0, got "
                        f"{entry['start']!r} .. {entry['stop']!r}")
    if num is None:
        vals: tuple[float, ...] = ()
    elif scale == "log":
        vals = tuple(float(v) for v in np.geomspace(start, stop, num))
    else:
        vals = tuple(float(v) for v in np.linspace(start, stop, num))
    return Parameter(name, kind, target, unit, vals, min(start, stop), max(start, stop), scale)
