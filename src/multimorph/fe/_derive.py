"""Observed curves and characteristic pressures from an FE equilibrium path.

Used until (or unless) the shared implementations in :mod:`multimorph.response` are
available; same definitions as physics-notes §6:

* observed loading: the stable points whose pressure exceeds every earlier one (a regulator
  snaps at constant P from a limit point to the next stable branch); unloading likewise from
  the end of the path backwards;
* Pc: the first limit point (a pressure maximum of the path followed by a fall), else the
  point of maximum dκ/dP on the observed loading curve;
* Ph: the knee after Pc, argmin d²κ/dP² on the observed loading curve beyond Pc;
* failure: the first pressure at which the peak principal stretch reaches the break stretch.
"""

from __future__ import annotations

import numpy as np

from multimorph.response import CharacteristicPressures, EquilibriumPath

__all__ = ["characteristic_pressures", "observed_curves"]


def observed_curves(path: EquilibriumPath) -> tuple[EquilibriumPath, EquilibriumPath]:
    """Loading and unloading curves a pressure regulator observes (stable points only)."""
    p = path.pressure
    st = path.stable
    load, top = [], -np.inf
    for i in range(len(p)):
        if st[i] and p[i] > top:
            load.append(i)
            top = p[i]
    unload, bottom = [], np.inf
    for i in range(len(p) - 1, -1, -1):
        if st[i] and p[i] < bottom:
            unload.append(i)
            bottom = p[i]
    return path.take(np.array(load, dtype=int)), path.take(np.array(unload, dtype=int))


def _first_limit_point(p: np.ndarray) -> int | None:
    for i in range(1, len(p) - 1):
        if p[i] >= p[i - 1] and p[i] > p[i + 1] and np.any(p[i + 1:] < p[i] * (1 - 1e-4)):
            # a genuine fall, not round-off on a plateau
            return i
    return None


def _parabolic_peak(v: np.ndarray, p: np.ndarray, i: int) -> float:
    """Pressure maximum from a parabola P(V) through the three points around index i."""
    V, P = v[i - 1:i + 2], p[i - 1:i + 2]
    if len(V) < 3 or len(set(V.tolist())) < 3:
        return float(p[i])
    a, b, c = np.polyfit(V - V[1], P, 2)
    if a >= 0:
        return float(p[i])
    return float(max(p[i], c - b * b / (4 * a)))


def _derivatives(P: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    s = np.gradient(q, P, edge_order=1) if len(P) > 2 else np.zeros_like(P)
    c = np.gradient(s, P, edge_order=1) if len(P) > 2 else np.zeros_like(P)
    return s, c


def characteristic_pressures(path: EquilibriumPath, loading: EquilibriumPath | None = None,
                             break_stretch: float | None = None) -> CharacteristicPressures:
    """Pc, Ph and the failure pressure (Pa) of a path; see the module docstring."""
    if loading is None:
        loading, _ = observed_curves(path)
    P, k = loading.pressure, loading.curvature
    crit = kind = hard = None
    k_at: dict[str, float | None] = {"critical": None, "hardening": None, "failure": None}
    i_lp = _first_limit_point(path.pressure)
    if i_lp is not None:
        crit, kind = _parabolic_peak(path.volume, path.pressure, i_lp), "limit_point"
        k_at["critical"] = float(path.curvature[i_lp])
    elif len(P) >= 4:
        s, _ = _derivatives(P, k)
        j = int(np.argmax(np.abs(s[1:-1]))) + 1
        if np.abs(s[j]) > 0:
            crit, kind = float(P[j]), "max_slope"
            k_at["critical"] = float(k[j])
    if crit is not None and len(P) >= 4:
        sel = np.flatnonzero(P > crit)
        if len(sel) >= 3:
            Pa, ka = P[sel[0] - 1:], k[sel[0] - 1:]
            _, c = _derivatives(Pa, np.abs(ka))
            j = int(np.argmin(c[1:-1])) + 1 if len(Pa) > 2 else 0
            if c[j] < 0:
                hard = float(Pa[j])
                k_at["hardening"] = float(ka[j])
    fail = None
    if break_stretch is not None:
        hit = np.flatnonzero(loading.peak_stretch >= break_stretch)
        if len(hit):
            fail = float(loading.pressure[hit[0]])
            k_at["failure"] = float(loading.curvature[hit[0]])
    return CharacteristicPressures(critical=crit, critical_kind=kind, hardening=hard,
                                   failure=fail, curvature_at=k_at)
