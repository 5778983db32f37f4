"""The built-in material library: silicones fitted by our own code, plus literature sets.

Parameters live in ``materials/data/library.json``, generated deterministically by
``python -m multimorph.materials.build_library`` from the data files shipped beside it
(``data/marechal2021/``: Marechal et al. 2021, ODbL 1.0 / DbCL 1.0; ``data/treloar1944/``).
Every entry carries its provenance (source, DOI, licence, data file, fit range, fit error and
residual definition) and, for pull-to-failure data, the uniaxial stretch at break.

Names are kebab-case (``"dragon-skin-30"``); a model may be appended after a colon
(``"dragon-skin-30:yeoh"``). The default model is Gent, the law the reduced model uses.

Examples
--------
>>> from multimorph.materials import get_material
>>> m = get_material("dragon-skin-30")
>>> m.model, m.name
('gent', 'dragon-skin-30')
>>> get_material("dragon-skin-30:yeoh").model
'yeoh'
"""

from __future__ import annotations

import difflib
import json
from functools import cache
from importlib import resources
from typing import Any

from multimorph.errors import SpecError, UnknownMaterialError
from multimorph.materials._material import Material
from multimorph.materials._registry import get_law

__all__ = ["DEFAULT_MODEL", "get_material", "library_entry", "list_materials"]

#: Model returned when none is asked for (the reduced model uses Gent).
DEFAULT_MODEL = "gent"


@cache
def _library() -> dict[str, Any]:
    ref = resources.files("multimorph") / "materials" / "data" / "library.json"
    try:
        text = ref.read_text(encoding="utf-8")
    except FileNotFoundError:  # pragma: no cover - a broken installation
        raise SpecError(
            "the material library file materials/data/library.json is missing; regenerate "
            "it with 'python -m multimorph.materials.build_library'") from None
    return json.loads(text)


def _aliases() -> dict[str, str]:
    out: dict[str, str] = {}
    for name, entry in _library()["materials"].items():
        out[name] = name
        for a in entry.get("aliases", []):
            out[a] = name
    return out


def _key(name: str) -> str:
    return "-".join(str(name).strip().lower().replace("_", "-").split())


def list_materials() -> list[str]:
    """Names of the library materials, sorted.

    Examples
    --------
    >>> "ecoflex-00-30" in list_materials()
    True
    """
    return sorted(_library()["materials"])


def _resolve(name: str) -> tuple[str, str | None]:
    base, _, model = str(name).partition(":")
    key = _key(base)
    aliases = _aliases()
    if key not in aliases:
        close = difflib.get_close_matches(key, list(aliases), n=4, cutoff=0.5)
        hint = f"; did you mean {', '.join(close)}?" if close else ""
        raise UnknownMaterialError(
            f"unknown material {base.strip()!r}{hint} (see 'multimorph material list')")
    return aliases[key], (model.strip() or None)


def library_entry(name: str) -> dict[str, Any]:
    """The raw library entry of a material (title, source, break stretch, every model).

    Returns a copy: a dict with ``title``, ``supplier``, ``source``, ``break_stretch``,
    ``default_model`` and ``models`` (model name → parameters, provenance and fit stats).
    """
    canonical, _ = _resolve(name)
    return json.loads(json.dumps(_library()["materials"][canonical]))


def get_material(name: str, model: str | None = None) -> Material:
    """A library material as a :class:`Material` (SI parameters, with provenance).

    Parameters
    ----------
    name : str
        Library name, e.g. ``"ecoflex-00-30"``, optionally ``"name:model"``.
    model : str, optional
        Law to return (``"gent"``, ``"yeoh"``, ``"reduced-polynomial"`` …). Default: the
        model after the colon, else Gent, else the entry's own default (literature sets that
        exist only as, e.g., a Yeoh model).

    Raises
    ------
    UnknownMaterialError
        Unknown name (the message lists close matches) or a model the entry lacks.
    """
    canonical, suffix = _resolve(name)
    entry = _library()["materials"][canonical]
    wanted = model or suffix
    models = entry["models"]
    if wanted is None:
        key = DEFAULT_MODEL if DEFAULT_MODEL in models else entry["default_model"]
    else:
        try:
            key = get_law(wanted).name
        except SpecError as exc:
            raise UnknownMaterialError(str(exc)) from None
        if key not in models:
            raise UnknownMaterialError(
                f"material {canonical!r} has no {key} parameters; available: "
                f"{', '.join(models)}")
    d = dict(models[key])
    d["break_stretch"] = entry.get("break_stretch")
    return Material.from_dict(d, name=canonical)
