"""Lazy imports of the optional FE stack (``pip install 'multimorph[fe]'``).

Only the ``fe`` room imports FElupe, tensortrax, contique, gmsh and meshio, and only inside
functions, so ``import multimorph`` works without them. A missing package raises
:class:`MissingExtraError` naming the extra that provides it.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from multimorph.errors import MultimorphError

__all__ = ["MissingExtraError", "require"]

_EXTRA = {
    "felupe": "fe",
    "tensortrax": "fe",
    "tensortrax.math": "fe",
    "contique": "fe",
    "gmsh": "fe",
    "meshio": "fe",
    "pypardiso": "fast",
}


class MissingExtraError(MultimorphError, ImportError):
    """An optional dependency of the FE room is not installed."""


def require(name: str) -> ModuleType:
    """Import ``name`` or raise :class:`MissingExtraError` naming the extra to install."""
    try:
        return importlib.import_module(name)
    except ImportError as exc:
        extra = _EXTRA.get(name, "fe")
        raise MissingExtraError(
            f"{name} is needed for finite-element analysis but is not installed "
            f"(install the extra: pip install 'multimorph[{extra}]'): {exc}"
        ) from exc
