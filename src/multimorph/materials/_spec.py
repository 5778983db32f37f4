"""Materials in spec files: a library name or an inline table with units."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from multimorph.errors import SpecError
from multimorph.materials._material import Material
from multimorph.materials._registry import get_law
from multimorph.units import to_si

__all__ = ["material_from_spec"]


def material_from_spec(value: Any, field: str = "material") -> Material:
    """Resolve a spec value to a :class:`Material`.

    ``value`` is either a library name (``"dragon-skin-30"``) or a table::

        [cell.material]
        model = "gent"
        mu = "250 kPa"      # moduli with units (bare numbers: Pa)
        jm = 20
        # optional: name, convention (Ogden), bulk_modulus, break_stretch

    Parameters may also sit in a ``params`` sub-table.
    """
    if isinstance(value, Material):
        return value
    if isinstance(value, str):
        from multimorph.materials.library import get_material

        return get_material(value)
    if not isinstance(value, Mapping):
        raise SpecError(f"{field}: expected a library material name or a table, got {value!r}")
    if "model" not in value:
        raise SpecError(f"{field}: inline material table needs a 'model' key")
    law = get_law(str(value["model"]))
    raw = dict(value.get("params", {}))
    for k in law.param_names:
        if k in value:
            raw[k] = value[k]
    params: dict[str, float] = {}
    for k, unit in zip(law.param_names, law.param_units, strict=True):
        if k not in raw:
            raise SpecError(f"{field}: model {law.name} needs parameter {k!r}")
        params[k] = to_si(raw[k], "Pa" if unit == "Pa" else "dimensionless", field=f"{field}.{k}")
    known = {"model", "params", "name", "convention", "bulk_modulus", "break_stretch",
             "density", *law.param_names}
    unknown = sorted(set(value) - known)
    if unknown:
        raise SpecError(f"{field}: unknown key(s) {', '.join(unknown)}")
    bulk = value.get("bulk_modulus")
    return Material(
        model=law.name,
        params=params,
        name=str(value.get("name", f"{field}")),
        convention=value.get("convention"),
        bulk_modulus=None if bulk is None else to_si(bulk, "Pa", field=f"{field}.bulk_modulus"),
        break_stretch=value.get("break_stretch"),
        density=None if value.get("density") is None else to_si(
            value["density"], "kg/m^3", field=f"{field}.density"),
    )
