"""One call from an equilibrium path to a full :class:`Response` (any backend)."""

from __future__ import annotations

from typing import Any

from multimorph.response._characteristic import characteristic_pressures
from multimorph.response._observed import observed_curves
from multimorph.response._types import EquilibriumPath, Response

__all__ = ["build_response"]


def build_response(path: EquilibriumPath, *, length: float, shear_modulus: float,
                   backend: str, break_stretch: float | None = None,
                   meta: dict[str, Any] | None = None,
                   signal: str = "curvature") -> Response:
    """Observed loading/unloading curves and characteristic pressures of ``path``.

    Parameters
    ----------
    path : EquilibriumPath
        The whole equilibrium path (Pa, 1/m, ...).
    length : float
        Reference length of the cell/module (m).
    shear_modulus : float
        Wall shear modulus μ (Pa).
    backend : str
        ``"rom"`` or ``"fe"``.
    break_stretch : float, optional
        Stretch at break of the wall material, for the failure pressure.
    meta : dict, optional
        Solver statistics (JSON-able).
    signal : {"curvature", "axial_stretch", "twist_rate"}
        What Pc and Ph are read on (see :func:`characteristic_pressures`): the axial stretch
        for a mirror-symmetric stretching cell, which does not bend; the twist rate for a
        whole twisting module (FE).
    """
    loading, unloading = observed_curves(path)
    char = characteristic_pressures(path, loading=loading, break_stretch=break_stretch,
                                    signal=signal)
    return Response(path=path, loading=loading, unloading=unloading, characteristic=char,
                    length=float(length), shear_modulus=float(shear_modulus), backend=backend,
                    meta=dict(meta or {}))
