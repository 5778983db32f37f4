"""Materials in spec files: a library name or an inline table with units."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from multimorph.errors import SpecError, UnknownMaterialError
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

        try:
            return get_material(value)
        except UnknownMaterialError as exc:
            raise UnknownMaterialError(f"{field}: {exc}") from None
    if not isinstance(value, Mapping):
        raise SpecError(f"{field}: expected a library material name or a table, got {value!r}")
    if "model" not in value:
        raise SpecError(f"{field}: inline material table needs a 'model' key")
    if not isinstance(value["model"], str):
        raise SpecError(f"{field}.model: expected a law name such as \"gent\", got "
                        f"{value['model']!r}")
    try:
        law = get_law(value["model"])
    except SpecError as exc:
        raise SpecError(f"{field}.model: {exc}") from None
    sub = value.get("params", {})
    if not isinstance(sub, Mapping):
        raise SpecError(f"{field}.params: expected a table of parameters, got {sub!r}")
    known = {"model", "params", "name", "convention", "bulk_modulus", "break_stretch",
             "density", *law.param_names}
    unknown = sorted(set(value) - known)
    if unknown:
        raise SpecError(f"{field}: unknown key(s) {', '.join(unknown)}")
    raw = dict(sub)
    for k in law.param_names:
        if k in value:
            raw[k] = value[k]
    params: dict[str, float] = {}
    for k, unit in zip(law.param_names, law.param_units, strict=True):
        if k not in raw:
            raise SpecError(f"{field}: model {law.name} needs parameter {k!r}")
        params[k] = to_si(raw[k], "Pa" if unit == "Pa" else "dimensionless", field=f"{field}.{k}")
    for key in ("name", "convention"):
        if key in value and not isinstance(value[key], str):
            raise SpecError(f"{field}.{key}: expected a string, got {value[key]!r}")
    brk = value.get("break_stretch")
    if brk is not None and (isinstance(brk, bool) or not isinstance(brk, int | float)):
        raise SpecError(f"{field}.break_stretch: expected a number (uniaxial stretch at "
                        f"break, e.g. 6.0), got {brk!r}")
    bulk = value.get("bulk_modulus")
    try:
        return Material(
            model=law.name,
            params=params,
            name=str(value.get("name", f"{field}")),
            convention=value.get("convention"),
            bulk_modulus=None if bulk is None else to_si(bulk, "Pa",
                                                         field=f"{field}.bulk_modulus"),
            break_stretch=value.get("break_stretch"),
            density=None if value.get("density") is None else to_si(
                value["density"], "kg/m^3", field=f"{field}.density"),
        )
    except SpecError as exc:  # name the spec field, not only the material
        text = str(exc)
        raise SpecError(text if text.startswith(field) else f"{field}: {text}") from None
