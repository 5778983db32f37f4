"""Units at the edges: one pint registry, parsing to SI floats.

Inside multimorph everything is SI (Pa, m, rad). Spec files and the CLI accept strings
with units ("2 mm", "30 kPa"); bare numbers, also written as strings ("60"), are taken as
SI, except for angles (:func:`to_angle`), which always need their unit.

Examples
--------
>>> from multimorph.units import to_si
>>> to_si("2 mm", "m")
0.002
>>> to_si("30 kPa", "Pa")
30000.0
>>> to_si(0.5, "Pa")
0.5
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

from multimorph.errors import SpecError

__all__ = ["format_quantity", "registry", "to_angle", "to_si"]


@lru_cache(maxsize=1)
def registry() -> Any:
    """The single pint ``UnitRegistry`` used by multimorph."""
    import pint

    ureg = pint.UnitRegistry()
    return ureg


def to_si(value: Any, unit: str, *, field: str = "value") -> float:
    """Convert ``value`` (number, or string with units) to a float in the SI ``unit``.

    Parameters
    ----------
    value : float or str
        A bare number (taken to be SI already) or a string such as ``"2 mm"``.
    unit : str
        Target SI unit, e.g. ``"m"``, ``"Pa"``, ``"rad"``, ``"dimensionless"``.
    field : str
        Name used in error messages.
    """
    if isinstance(value, bool):
        raise SpecError(f"{field}: expected a number or a quantity string, got {value!r}")
    if isinstance(value, int | float):
        return float(value)
    if not isinstance(value, str):
        raise SpecError(f"{field}: expected a number or a quantity string, got {value!r}")
    try:  # a bare number written as a string follows the bare-number rule: SI
        return float(value.strip())
    except ValueError:
        pass
    first = value.strip().split(" ")[0].lstrip("+-").lower()
    if not any(ch.isdigit() for ch in value) and first not in ("nan", "inf", "infinity"):
        raise SpecError(f"{field}: {value!r} has no number (a quantity is a number and a unit, "
                        "e.g. \"2 mm\" or \"30 kPa\")")
    import pint

    ureg = registry()
    try:
        q = ureg.Quantity(value.strip())
    except (pint.errors.UndefinedUnitError, pint.errors.DefinitionSyntaxError, ValueError,
            TypeError, AttributeError) as exc:
        raise SpecError(f"{field}: cannot read {value!r} as a quantity ({exc})") from None
    if not isinstance(q, pint.Quantity):  # a bare number given as a string
        return float(q)
    try:
        return float(q.to(unit).magnitude)
    except pint.errors.DimensionalityError:
        raise SpecError(
            f"{field}: {value!r} has units of {q.dimensionality}, expected a quantity in {unit}"
        ) from None


def to_angle(value: Any, *, field: str = "angle",
             hint: str = 'give an angle with its unit, e.g. "90 deg"') -> float:
    """Convert an angle *with its unit* (``"30 deg"``, ``"0.5 rad"``, ``"0.25 turn"``) to rad.

    Bare numbers are refused for angles, whether written as numbers (``90``) or as strings
    without a unit (``"90"``): degrees and radians are both common, and a guess is wrong by
    a factor of 57. Dimensionless units that are not angles (``"30 %"``) are refused too.

    Parameters
    ----------
    value : str
        The angle with its unit.
    field : str
        Name used in error messages.
    hint : str
        What the message asks for when the unit is missing.

    Examples
    --------
    >>> round(to_angle("90 deg"), 6)
    1.570796
    """
    if not isinstance(value, str):
        raise SpecError(f"{field}: {hint} (got {value!r})")
    import pint

    ureg = registry()
    try:
        q = ureg.Quantity(value.strip())
    except (pint.errors.UndefinedUnitError, pint.errors.DefinitionSyntaxError, ValueError,
            TypeError, AttributeError) as exc:
        raise SpecError(f"{field}: cannot read {value!r} as an angle ({exc})") from None
    if not isinstance(q, pint.Quantity) or q.units == ureg.dimensionless:
        raise SpecError(f"{field}: {hint} (got {value!r}, a bare number)")
    if str(ureg.get_root_units(q.units)[1]) != "radian":
        raise SpecError(f"{field}: {value!r} is not an angle; {hint}")
    return float(q.to("rad").magnitude)


def format_quantity(value: float, unit: str, to: str, digits: int = 4) -> str:
    """Human-readable string of an SI ``value`` in ``unit`` converted to ``to`` units."""
    q = registry().Quantity(value, unit).to(to)
    return f"{q.magnitude:.{digits}g} {to}"
