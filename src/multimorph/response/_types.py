"""Value objects for results: equilibrium paths, characteristic pressures, responses.

Array-axis convention: every per-point array has shape ``(n,)`` along the path, ordered by
path parameter (arc length), *not* necessarily by pressure (a path may fold back at a limit
point). SI units: Pa, 1/m, rad, m³.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from multimorph.errors import MultimorphError

__all__ = ["PATH_ARRAYS", "CharacteristicPressures", "EquilibriumPath", "Response"]

#: the arrays every equilibrium path has, one value per point
PATH_ARRAYS = ("pressure", "curvature", "twist_rate", "axial_stretch", "volume",
               "peak_stretch", "stable")


@dataclass(frozen=True, eq=False)
class EquilibriumPath:
    """Points of an equilibrium path (or of an observed curve derived from one).

    Attributes
    ----------
    pressure : ndarray (n,)
        Gauge pressure P (Pa).
    curvature : ndarray (n,)
        Bending curvature κ about the cell's x axis (1/m); positive bends the top outward
        (the stiff bottom on the inside).
    twist_rate : ndarray (n,)
        Twist per unit length about the cell axis (rad/m); zero for pure bending cells.
    axial_stretch : ndarray (n,)
        Stretch of the cell's reference (neutral) line along its axis (-).
    volume : ndarray (n,)
        Chamber volume (m³).
    peak_stretch : ndarray (n,)
        Largest principal stretch anywhere in the walls (-).
    stable : ndarray (n,) of bool
        Stable at fixed pressure (smallest eigenvalue of the Hessian positive).
    extra : dict of str to ndarray
        Backend-specific per-point outputs (e.g. generalised coordinates), each (n,) or (n, k).
    """

    pressure: np.ndarray
    curvature: np.ndarray
    twist_rate: np.ndarray
    axial_stretch: np.ndarray
    volume: np.ndarray
    peak_stretch: np.ndarray
    stable: np.ndarray
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = None
        for name in PATH_ARRAYS:
            arr = np.asarray(getattr(self, name), dtype=bool if name == "stable" else float)
            if arr.ndim != 1:
                raise MultimorphError(f"path.{name}: expected a 1-D array, got shape {arr.shape}")
            if n is None:
                n = arr.shape[0]
            elif arr.shape[0] != n:
                raise MultimorphError(f"path.{name}: length {arr.shape[0]} != {n}")
            if name != "stable" and not np.isfinite(arr).all():
                raise MultimorphError(f"path.{name}: contains NaN or inf")
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @classmethod
    def _derived(cls, extra: dict[str, np.ndarray], **arrays: np.ndarray) -> EquilibriumPath:
        """A path built from a checked one (interpolated along it): its arrays are 1-D,
        finite and of one length by construction, so they are only made read-only, not
        checked again (the observed curves of every response; a batch builds two per
        curve)."""
        obj = object.__new__(cls)
        for name in PATH_ARRAYS:
            arr = np.asarray(arrays[name], dtype=bool if name == "stable" else float)
            arr.setflags(write=False)
            object.__setattr__(obj, name, arr)
        object.__setattr__(obj, "extra", extra)
        return obj

    def __len__(self) -> int:
        return int(self.pressure.shape[0])

    def bend_angle(self, length: float) -> np.ndarray:
        """Central angle θ = κ d of a cell of length ``length`` (rad)."""
        return self.curvature * length

    def take(self, index: Any) -> EquilibriumPath:
        """Sub-path at ``index`` (slice, integer array or boolean mask)."""
        kw = {name: np.asarray(getattr(self, name))[index] for name in PATH_ARRAYS}
        kw["extra"] = {k: np.asarray(v)[index] for k, v in self.extra.items()}
        return EquilibriumPath(**kw)

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {name: getattr(self, name).tolist() for name in PATH_ARRAYS}
        return d


@dataclass(frozen=True)
class CharacteristicPressures:
    """The pressures that characterise a response (Pa; ``None`` when not reached).

    Attributes
    ----------
    critical : float or None
        Pc: the limit point (pressure maximum) where one exists, else the point of maximum
        dκ/dP (steepest rise) on the loading path.
    critical_kind : {"limit_point", "max_slope"} or None
    hardening : float or None
        Ph: the strain-hardening knee after Pc (where the curve turns from steep to flat).
    failure : float or None
        Pressure at which the peak principal stretch reaches the material's break stretch.
    curvature_at : dict
        κ (1/m) at ``"critical"``, ``"hardening"``, ``"failure"`` (``None`` when not reached).
    signal : {"curvature", "axial_stretch"}
        The path quantity Pc and Ph were read on: κ, or the axial stretch of a
        mirror-symmetric (stretching) cell, which does not bend.
    """

    critical: float | None
    critical_kind: str | None
    hardening: float | None
    failure: float | None
    curvature_at: dict[str, float | None] = field(default_factory=dict)
    signal: str = "curvature"

    def to_dict(self) -> dict[str, Any]:
        return {
            "critical_pressure": self.critical,
            "critical_kind": self.critical_kind,
            "hardening_pressure": self.hardening,
            "failure_pressure": self.failure,
            "curvature_at": dict(self.curvature_at),
            "signal": self.signal,
        }


@dataclass(frozen=True, eq=False)
class Response:
    """What one backend predicts for one cell or module under one pressure line.

    Attributes
    ----------
    path : EquilibriumPath
        The whole equilibrium path (through limit points), loading direction.
    loading, unloading : EquilibriumPath
        What a pressure regulator observes: stable branches only, snapping at constant
        pressure at limit points (loading up, unloading down; elastic hysteresis between).
    characteristic : CharacteristicPressures
    length : float
        Reference length of the cell/module (m), for bend angles θ = κ d.
    shear_modulus : float
        Wall shear modulus μ (Pa), for P/μ.
    backend : str
        ``"rom"`` or ``"fe"``.
    meta : dict
        Solver statistics and settings (JSON-able).
    """

    path: EquilibriumPath
    loading: EquilibriumPath
    unloading: EquilibriumPath
    characteristic: CharacteristicPressures
    length: float
    shear_modulus: float
    backend: str
    meta: dict[str, Any] = field(default_factory=dict)

    def with_meta(self, **meta: Any) -> Response:
        return replace(self, meta={**self.meta, **meta})
