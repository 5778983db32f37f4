"""What a pressure regulator observes, derived from a whole equilibrium path (pure NumPy).

Under pressure control only stable points with rising pressure can be followed. At a limit
point (pressure maximum along the path, or the end of a stable branch) the system snaps at
constant pressure to the next stable rising branch further along the path, if there is one
(strain hardening provides it); otherwise the loading curve ends there (runaway). Unloading
is the same rule applied to the path walked backwards with falling pressure: it snaps back at
the lower turning point, so loading and unloading enclose an elastic hysteresis loop.

Snap landing points are interpolated linearly along the path at the snap pressure and
marked in ``extra["snap"]`` (1.0 where the point was reached by a jump).

A lone point flagged unstable between two stable ones, with the pressure rising into it and
out of it, is walked through (:func:`_lone_flags`, definitions version 4): the FE's stability
test can flag one such point at the steepest rise, and taken as the end of the stable
branch it cut the loading curve there (no later point at that pressure to land on).
"""

from __future__ import annotations

import math

import numpy as np

from multimorph.response._types import PATH_ARRAYS, EquilibriumPath

__all__ = ["observed_curves", "observed_positions"]


def observed_positions(pressure: np.ndarray, stable: np.ndarray) -> tuple[np.ndarray,
                                                                            np.ndarray, bool]:
    """Positions along the path (fractional indices) of the pressure-controlled loading curve.

    Parameters
    ----------
    pressure : ndarray (n,)
        Pressure along the path (any unit), in path order.
    stable : ndarray (n,) of bool
        Stability at fixed pressure.

    Returns
    -------
    positions : ndarray (m,)
        Fractional path indices of the observed points, starting at 0.
    snap : ndarray (m,) of bool
        True where the point was reached by a snap at constant pressure.
    complete : bool
        False when the curve ends in a runaway (no stable branch to land on).

    Examples
    --------
    >>> P = np.array([0.0, 1.0, 2.0, 1.5, 1.0, 1.5, 2.5, 3.0])
    >>> st = np.array([1, 1, 1, 0, 0, 1, 1, 1], bool)
    >>> pos, snap, ok = observed_positions(P, st)
    >>> pos.tolist(), snap.tolist(), ok
    ([0.0, 1.0, 2.0, 5.5, 6.0, 7.0], [False, False, False, True, False, False], True)
    """
    Pa = np.asarray(pressure, float)
    sa = np.asarray(stable, bool)
    n = Pa.shape[0]
    # step[i]: the walk goes on from point i to i + 1 (rising to a stable point, or to a
    # lone unstable flag, _lone_flags); a run of such steps is taken at once
    step = np.zeros(max(n - 1, 0), bool)
    if n > 1:
        up = Pa[1:] > Pa[:-1]
        step = up & (sa[1:] | _lone_flags(Pa, sa, up)[1:])
    stops = np.append(np.flatnonzero(~step), max(n - 1, 0))
    # Python floats and bools for the snap search: it reads one element at a time, which
    # is several times faster on lists than on NumPy scalars (the same IEEE doubles)
    P = Pa.tolist()
    stable_mask = sa.tolist()
    pos, snap = [0.0], [False]
    i = 0
    complete = True
    while i < n - 1:
        if step[i]:
            end = int(stops[np.searchsorted(stops, i)])    # the first point not stepped from
            pos.extend(float(m) for m in range(i + 1, end + 1))
            snap.extend([False] * (end - i))
            i = end
            continue
        p_star = P[i]
        landing = None
        for j in range(i + 1, n - 1):
            if P[j + 1] > P[j] and stable_mask[j + 1] and P[j] <= p_star < P[j + 1]:
                landing = j + (p_star - P[j]) / (P[j + 1] - P[j])
                break
        if landing is None:
            complete = False
            break
        pos.append(float(landing))
        snap.append(True)
        i = math.floor(landing)
    return np.asarray(pos), np.asarray(snap, bool), complete


def _lone_flags(P: np.ndarray, stable: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Points flagged unstable that are lone flags on a rising branch: both neighbours
    stable and the pressure rising into them and out of them (``up[i]``: P[i+1] > P[i]).
    A branch loses stability at a fold (the pressure turns) or at a bifurcation, past
    which it stays unstable for a stretch; a single flagged point between two stable ones
    with the pressure still rising is the stability test's reading of a near-singular
    tangent at the steepest rise (a negative pivot of the factorisation; on 23 of the
    2,818 FE paths of the data set, docs/validation.md §1), and the loading curve goes on
    through it."""
    lone = np.zeros(P.shape[0], bool)
    lone[1:-1] = ~stable[1:-1] & stable[:-2] & stable[2:] & up[:-1] & up[1:]
    return lone


def _interp_path(path: EquilibriumPath, pos: np.ndarray, snap: np.ndarray) -> EquilibriumPath:
    idx = np.arange(len(path), dtype=float)

    def at(a: np.ndarray) -> np.ndarray:
        a = np.asarray(a, float)
        if a.ndim == 1:
            return np.interp(pos, idx, a)
        return np.stack([np.interp(pos, idx, a[:, k]) for k in range(a.shape[1])], axis=1)

    kw = {name: at(getattr(path, name)) for name in PATH_ARRAYS if name != "stable"}
    kw["stable"] = np.ones(pos.shape[0], bool)
    extra = {k: at(v) for k, v in path.extra.items() if np.asarray(v).dtype != bool}
    extra["snap"] = snap.astype(float)
    return EquilibriumPath._derived(extra, **kw)


def observed_curves(path: EquilibriumPath) -> tuple[EquilibriumPath, EquilibriumPath]:
    """Loading and unloading curves a pressure regulator observes on ``path``.

    Parameters
    ----------
    path : EquilibriumPath
        The whole equilibrium path from the unloaded state, in path order.

    Returns
    -------
    loading, unloading : EquilibriumPath
        Loading in order of rising pressure (ending at the path's end, or at the runaway
        limit point); unloading from the end of loading back to zero pressure, in order of
        falling pressure. ``extra["snap"]`` marks points reached by a jump.
    """
    n = len(path)
    if n < 2:
        return path, path
    pos, snap, complete = observed_positions(path.pressure, path.stable)
    loading = _interp_path(path, pos, snap)
    if not complete or pos[-1] < n - 1:
        rev = pos[::-1]
        return loading, _interp_path(path, rev, np.zeros(rev.shape[0], bool))
    rpos, rsnap, _ = observed_positions(-path.pressure[::-1], path.stable[::-1])
    unloading = _interp_path(path, (n - 1) - rpos, rsnap)
    return loading, unloading
