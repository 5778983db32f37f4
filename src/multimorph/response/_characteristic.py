"""Characteristic pressures of a response, from its equilibrium path (pure NumPy).

Definitions (physics-notes §6; the same for every backend):

* **Pc, critical pressure.** The *first* activation along the loading curve. If the curve
  shows a completed inflection before anything else — a maximum of dκ/dP, well above the
  initial slope, after which the slope falls by at least :data:`INFLECTION_PROMINENCE` of
  it before it rises again — Pc is that inflection (``"max_slope"``), even when a fold or
  a steeper rise follows later: on 3D FE cells a second instability at large bend (the
  curve steepens again near the end of the traced range, or folds there with nothing
  traced to land on) comes after a ballooning that has already run and hardened, and is
  not the activation (without this rule, 22 of the 373 bending cells of the FE reference
  data set read such a later event as their Pc, up to 4.8 × their ballooning pressure).
  Otherwise, if the path has a limit point (the first local maximum of the
  pressure along the path, after which the pressure falls) whose snap matters, Pc is that
  pressure (``critical_kind = "limit_point"``). A fold matters when the jump it causes under
  pressure control moves κ by at least :data:`SNAP_FRACTION` of the path's κ range, or when
  nothing stable is left to land on (runaway). Shallow folds on the hardening plateau
  (a 3 % pressure dip that moves κ by 0.02 % on a 3D FE cell) are not the activation.
  Otherwise Pc is the pressure of maximum dκ/dP on the loading curve (``"max_slope"``), the
  inflection of κ(P) where the ballooning runs fastest. An inflection is *reached* only when
  the traced curve shows it: the maximum slope lies at an interior point and the slope
  falls after it, by at least :data:`SLOPE_DROP` of the maximum before the end of the curve.
  A slope that is still rising (or level) where the path stops, at ``p_max`` or earlier,
  means the activation lies beyond the traced range: Pc is ``None`` ("not reached"), never
  the last pressure traced. A steepest rise before the chamber has ballooned (its volume
  below :data:`BALLOONING_VOLUME_RATIO` × the first) is never a max-slope Pc: on a cell
  that barely bends, the first steps' slope of a signal that moves by 10⁻³ is noise.
  Both are refined by a parabola through the three points around the discrete extremum.
* **Ph, hardening pressure.** The strain-hardening knee after Pc, where the steep rise turns
  into the plateau. After a max-slope Pc: the first pressure at which dκ/dP has fallen to
  :data:`KNEE_SLOPE_FRACTION` (2/3) of its value at Pc — on the sigmoid
  κ ∝ tanh((P − Pc)/w) exactly the point of most negative d²κ/dP², and on 3D FE curves the
  same knee read from the first derivative (the minimum of the second derivative wanders
  along a gently curving plateau: 20–30 % on the 24-design grid). After a snap that
  matters: the most negative d²κ/dP² on the branch it landed on. ``None`` when the curve
  does not get there before its end.
* **Failure pressure.** The first pressure on the loading curve at which the largest
  principal stretch reaches the material's break stretch (linear interpolation); ``None``
  without a break stretch or when not reached.

Curvatures at each are interpolated on the loading curve (at a limit point: on the path).

**The sense of the motion.** A cell may move against the sign convention (a bending cell
whose bottom layer is not stiff enough bends the other way, κ < 0). The activation is read
in the sense the signal actually moves: the signal is multiplied by the sign of its largest
excursion on the loading curve before the slopes are taken (without this, the maximum of
dκ/dP of a cell that bends to negative κ is the tiny positive slope at its first points,
and its "Pc" a few per cent of its real activation pressure). The reported κ keep their sign.

The signal is κ for bending (and twisting) cells. A mirror-symmetric stretching cell does not
bend; its activation is read on the axial stretch instead (``signal="axial_stretch"``): the
same definitions with λ in place of κ (κ at each pressure is still reported, zero there).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from multimorph.errors import SpecError
from multimorph.response._observed import observed_curves
from multimorph.response._types import CharacteristicPressures, EquilibriumPath

__all__ = ["BALLOONING_VOLUME_RATIO", "DEFINITIONS_VERSION", "INFLECTION_PROMINENCE",
           "INFLECTION_RISE", "INFLECTION_SHARE",
           "KNEE_SLOPE_FRACTION", "PRESSURE_RESOLUTION", "SIGNALS", "SLOPE_DROP",
           "SNAP_FRACTION", "characteristic_pressures", "critical_pressure",
           "hardening_pressure", "motion_sense"]

#: Version of these definitions: raised whenever a change moves Pc or Ph read on the same
#: path, so results cached with derived pressures (FE checks of designs) are not re-used
#: across it. 2: the first activation and the knee from the slope (stop 30). 3: no
#: max-slope Pc before the chamber has ballooned (:data:`BALLOONING_VOLUME_RATIO`). 4: a
#: lone unstable flag on a rising branch does not end the loading curve (stop 57,
#: ``_observed._lone_flags``).
DEFINITIONS_VERSION = 4

#: Path quantities the characteristic pressures can be read on.
SIGNALS = ("curvature", "axial_stretch", "twist_rate")

#: Least κ jump of a snap, as a fraction of the path's κ range, for a fold to count as the
#: activation (and for a snap to restart the search for the hardening knee).
SNAP_FRACTION = 0.05

#: Least fall of dκ/dP after its maximum, as a fraction of the maximum, for a max-slope Pc to
#: count as reached within the traced range (smaller falls are a slope still levelling off,
#: or noise, at the end of the path).
SLOPE_DROP = 0.05

#: Pressure steps smaller than this fraction of a loading curve's largest pressure are not
#: resolved when slopes are read (see :func:`_monotone`).
PRESSURE_RESOLUTION = 1e-3

#: Ph after a max-slope Pc: where dκ/dP has fallen to this fraction of its value at Pc.
#: On the canonical sigmoid κ ∝ tanh((P − Pc)/w) it is exactly the knee of most negative
#: d²κ/dP² (sech² = 2/3 at atanh(1/√3)); on 3D FE curves it reads the same knee from the
#: first derivative, where the second derivative's minimum wanders along a gently curving
#: plateau (tens of per cent on the 24-design grid).
KNEE_SLOPE_FRACTION = 2.0 / 3.0

#: Least fall of dκ/dP after a local maximum, as a fraction of it, before the slope rises
#: above it again, for that maximum to be a completed activation that precedes a later
#: fold or steepening (see the module docstring; 3D FE curves wiggle by a few per cent).
INFLECTION_PROMINENCE = 0.25

#: Least ratio of such a maximum to the slope at the first loaded point (the linear
#: response): below it a bump is not a ballooning.
INFLECTION_RISE = 1.5

#: Least share of the loading curve's κ range that such an activation must have moved by
#: its flattest point (a bump of the first loaded points is not the ballooning: on 3D FE
#: cells the first steps can bend a cell by a few per cent of its range at a few kPa).
INFLECTION_SHARE = 0.25

#: A steepest rise of the signal before the chamber volume has grown by this factor (over
#: its first point) is not the ballooning, and is not read as a max-slope Pc. Measured on
#: the FE reference data set (732 bending cells with a Pc): every ballooning reads at a
#: volume ratio of 2.0 or more, except two spurious readings at 1.09 and 1.10 (a cell that
#: barely bends, whose end rotation moves by 10⁻³ rad in its first steps: "Pc" 0.9 kPa
#: against a fold at 22.6 kPa); the reduced model reads every Pc at 1.57 or more except
#: one at 1.08 (6.5 kPa against about 60 kPa in FE). Paths without a volume skip the test.
BALLOONING_VOLUME_RATIO = 1.3


def _vertex(x: np.ndarray, y: np.ndarray, i: int) -> tuple[float, float]:
    """Abscissa and value of the parabola through points i-1, i, i+1 (falls back to i)."""
    if i <= 0 or i >= len(x) - 1:
        return float(x[i]), float(y[i])
    x0, x1, x2 = x[i - 1], x[i], x[i + 1]
    y0, y1, y2 = y[i - 1], y[i], y[i + 1]
    den = (x0 - x1) * (x0 - x2) * (x1 - x2)
    if den == 0:
        return float(x1), float(y1)
    a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / den
    b = (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / den
    if a == 0:
        return float(x1), float(y1)
    xv = -b / (2 * a)
    if not min(x0, x2) <= xv <= max(x0, x2):
        return float(x1), float(y1)
    c = y1 - a * x1 * x1 - b * x1
    return float(xv), float(a * xv * xv + b * xv + c)


def _gradient(f: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``np.gradient(f, x)`` of 1-D arrays (at least two points): the same second-order
    differences inside and first-order ones at the ends, to the bit, without its general
    n-D machinery (the characteristic pressures of a batch of curves call it four times a
    curve)."""
    f = np.asarray(f, float)
    dx = np.diff(np.asarray(x, float))
    if f.size < 2 or dx.size != f.size - 1:
        return np.gradient(f, x)
    out = np.empty_like(f)
    if (dx == dx[0]).all():              # NumPy's own shortcut for an even spacing
        out[1:-1] = (f[2:] - f[:-2]) / (2.0 * dx[0])
        out[0] = (f[1] - f[0]) / dx[0]
        out[-1] = (f[-1] - f[-2]) / dx[0]
        return out
    d1, d2 = dx[:-1], dx[1:]
    out[1:-1] = (-(d2 / (d1 * (d1 + d2))) * f[:-2] + ((d2 - d1) / (d1 * d2)) * f[1:-1]
                 + (d1 / (d2 * (d1 + d2))) * f[2:])
    out[0] = (f[1] - f[0]) / dx[0]
    out[-1] = (f[-1] - f[-2]) / dx[-1]
    return out


def _monotone(P: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The points of a loading curve (pressures non-decreasing) at least
    :data:`PRESSURE_RESOLUTION` of the largest pressure above the last point kept: slopes
    and their derivatives are not read across pressure steps a path tracer makes only
    to resolve a fold or a snap (3D FE paths end in clusters of points a few Pa apart,
    where dκ/dP of neighbours spikes by 10³)."""
    P = np.asarray(P, float)
    if P.size < 2:
        return P, np.asarray(k, float)
    tol = PRESSURE_RESOLUTION * max(1.0, float(np.max(np.abs(P))))
    # a point more than tol above its predecessor is kept whatever came before; only the
    # points of clusters are decided one by one, against the last point kept
    keep = np.concatenate([[True], np.diff(P) > tol])
    if not keep.all():
        safe = np.maximum.accumulate(np.where(keep, np.arange(P.size), 0))
        last = -1
        for i in np.flatnonzero(~keep):
            ref = max(int(safe[i]), last)
            if P[i] - P[ref] > tol:
                keep[i] = True
                last = int(i)
    return P[keep], np.asarray(k, float)[keep]


def _kappa_range(k: np.ndarray) -> float:
    return float(np.max(k) - np.min(k)) if k.size else 0.0


def _snap_matters(path: EquilibriumPath, i: int) -> bool:
    """Whether the pressure-controlled snap from the fold at point ``i`` moves κ by at least
    :data:`SNAP_FRACTION` of the path's κ range (True when there is nowhere to land)."""
    P, k, st = path.pressure, path.curvature, path.stable
    for j in range(i + 1, len(P) - 1):
        if P[j + 1] > P[j] and st[j + 1] and P[j] <= P[i] < P[j + 1]:
            k_land = k[j] + (P[i] - P[j]) / (P[j + 1] - P[j]) * (k[j + 1] - k[j])
            return bool(abs(k_land - k[i]) >= SNAP_FRACTION * _kappa_range(k))
    return True


def _limit_point(path: EquilibriumPath) -> int | None:
    P = path.pressure
    for i in range(1, len(P) - 1):
        if P[i] >= P[i - 1] and P[i] > P[i + 1]:
            # a genuine fold: the pressure keeps falling or the state turns unstable
            if not path.stable[i + 1] or (i + 2 < len(P) and P[i + 2] < P[i]):
                if _snap_matters(path, i):
                    return i
    return None


def _first_inflection(k: np.ndarray, slope: np.ndarray,
                      early: np.ndarray | None = None) -> int | None:
    """Index of the first completed activation of a loading curve κ with slope dκ/dP: an
    interior local maximum of the slope at least :data:`INFLECTION_RISE` × the first slope,
    followed by a fall of :data:`INFLECTION_PROMINENCE` of it — with κ still rising there: a
    knee, not a turn — before the slope exceeds it again, and whose rise up to the flattest
    point before that moves κ by at least :data:`INFLECTION_SHARE` of the curve's range
    (None: none). Points marked ``early`` (before the ballooning) are no candidates."""
    if len(slope) < 3:
        return None
    base = max(float(slope[0]), 0.0)
    span = _kappa_range(k)
    mid = slope[1:-1]
    peaks = 1 + np.flatnonzero((mid > 0) & (mid >= slope[:-2]) & (mid >= slope[2:])
                               & (mid >= INFLECTION_RISE * base))
    for j in peaks:
        if early is not None and early[j]:
            continue
        sj = slope[j]
        after = slope[j + 1:]
        higher = np.flatnonzero(after > sj)
        seg = after[:higher[0]] if higher.size else after
        low = np.flatnonzero(seg <= (1.0 - INFLECTION_PROMINENCE) * sj)
        if not low.size or not seg[low[0]] > 0:
            # no fall, or the signal turns back instead of levelling off (a swing of a
            # coarsely traced path, not a knee)
            continue
        if k[j + 1 + int(np.argmin(seg))] - k[0] >= INFLECTION_SHARE * span:
            return j
    return None


def _before_ballooning(loading: EquilibriumPath, P: np.ndarray) -> np.ndarray | None:
    """At each pressure ``P`` of the loading curve: whether its chamber volume is still
    below :data:`BALLOONING_VOLUME_RATIO` × its first volume (None: no usable volume)."""
    lp = np.asarray(loading.pressure, float)
    v = np.asarray(loading.volume, float)
    if v.size != lp.size or v.size < 2 or not (np.all(np.isfinite(v)) and v[0] > 0):
        return None
    order = np.argsort(lp, kind="stable")
    return np.interp(P, lp[order], v[order]) < BALLOONING_VOLUME_RATIO * v[0]


def critical_pressure(path: EquilibriumPath, loading: EquilibriumPath | None = None,
                      ) -> tuple[float | None, str | None, float | None]:
    """Pc, its kind and κ there (see the module docstring for the definition)."""
    if len(path) < 3:
        return None, None, None
    i = _limit_point(path)
    loading = loading if loading is not None else observed_curves(path)[0]
    P, k = _monotone(loading.pressure, loading.curvature)
    early = _before_ballooning(loading, P)
    if i is not None:
        # the loading curve up to the fold: a completed activation there comes first
        before = P <= path.pressure[i]
        j = None
        if before.sum() >= 4:
            slope = _gradient(k[before], P[before])
            j = _first_inflection(k[before], slope,
                                  None if early is None else early[before])
        if j is not None:
            pc, _ = _vertex(P[before], slope, j)
            return pc, "max_slope", float(np.interp(pc, P, k))
        s = np.arange(len(path), dtype=float)
        sv, pc = _vertex(s, path.pressure, i)
        kc = float(np.interp(sv, s, path.curvature))
        return pc, "limit_point", kc
    if len(P) < 3:
        return None, None, None
    slope = _gradient(k, P)
    j = _first_inflection(k, slope, early)
    if j is None:
        ballooned = slope if early is None else np.where(early, -np.inf, slope)
        j = int(np.argmax(ballooned))
        if early is not None and early[j]:
            return None, None, None
        if not _inflection_reached(slope, j):
            return None, None, None
    pc, _ = _vertex(P, slope, j)
    return pc, "max_slope", float(np.interp(pc, P, k))


def _inflection_reached(slope: np.ndarray, j: int) -> bool:
    """Whether the maximum slope at index ``j`` is an inflection inside the traced range:
    interior, positive, and followed by a fall of at least :data:`SLOPE_DROP` of it."""
    if not 0 < j < len(slope) - 1 or not slope[j] > 0:
        return False
    return bool(np.min(slope[j:]) <= (1.0 - SLOPE_DROP) * slope[j])


def hardening_pressure(loading: EquilibriumPath, pc: float | None,
                       ) -> tuple[float | None, float | None]:
    """Ph and κ there: the knee of the loading curve above Pc (see the module docstring)."""
    if pc is None:
        return None, None
    start = 0
    snaps = np.flatnonzero(loading.extra.get("snap", np.zeros(len(loading))) > 0)
    jump = SNAP_FRACTION * _kappa_range(loading.curvature)
    snaps = snaps[[abs(loading.curvature[j] - loading.curvature[j - 1]) >= jump
                   for j in snaps]] if snaps.size else snaps
    if snaps.size:
        start = int(snaps[-1])
    P, k = _monotone(loading.pressure[start:], loading.curvature[start:])
    if len(P) < 4:
        return None, None
    slope = _gradient(k, P)
    curv = _gradient(slope, P)
    above = np.flatnonzero(P >= pc)
    if above.size == 0:
        return None, None
    if start == 0:
        return _knee_by_slope(P, k, slope, pc, int(above[0]))
    j = int(above[np.argmin(curv[above])])
    if curv[j] >= 0 or j >= len(P) - 2:
        return None, None
    if j == 0 and snaps.size:
        return float(P[0]), float(k[0])
    ph, _ = _vertex(P, curv, j)
    ph = max(ph, pc)
    return ph, float(np.interp(ph, P, k))


def _knee_by_slope(P: np.ndarray, k: np.ndarray, slope: np.ndarray, pc: float, a0: int,
                   ) -> tuple[float | None, float | None]:
    """The knee after a max-slope activation at ``pc`` (``a0`` the first point at or above
    it): the first pressure where dκ/dP has fallen to :data:`KNEE_SLOPE_FRACTION` of its
    value at Pc (linear interpolation; None if it does not within the curve)."""
    s_pc = float(np.max(slope[max(a0 - 1, 0):a0 + 1]))
    if not s_pc > 0:
        return None, None
    target = KNEE_SLOPE_FRACTION * s_pc
    below = np.flatnonzero(slope[a0:] <= target)
    if below.size == 0:
        return None, None
    m = a0 + int(below[0])
    if m == 0:
        return None, None
    f = (slope[m - 1] - target) / (slope[m - 1] - slope[m]) if slope[m - 1] != slope[m] else 1.0
    ph = max(float(P[m - 1] + f * (P[m] - P[m - 1])), pc)
    return ph, float(np.interp(ph, P, k))


def _failure(loading: EquilibriumPath, break_stretch: float | None,
             ) -> tuple[float | None, float | None]:
    if break_stretch is None:
        return None, None
    lam = loading.peak_stretch
    over = np.flatnonzero(lam >= break_stretch)
    if over.size == 0:
        return None, None
    j = int(over[0])
    if j == 0:
        return float(loading.pressure[0]), float(loading.curvature[0])
    f = (break_stretch - lam[j - 1]) / (lam[j] - lam[j - 1])
    P = loading.pressure[j - 1] + f * (loading.pressure[j] - loading.pressure[j - 1])
    k = loading.curvature[j - 1] + f * (loading.curvature[j] - loading.curvature[j - 1])
    return float(P), float(k)


def motion_sense(signal: np.ndarray) -> float:
    """+1 or −1: the sign of the signal's largest excursion from zero (+1 for none)."""
    k = np.asarray(signal, float)
    k = k[np.isfinite(k)]
    if k.size == 0:
        return 1.0
    return -1.0 if k[int(np.argmax(np.abs(k)))] < 0 else 1.0


def characteristic_pressures(path: EquilibriumPath, *, loading: EquilibriumPath | None = None,
                             break_stretch: float | None = None,
                             signal: str = "curvature") -> CharacteristicPressures:
    """Pc, Ph and the failure pressure (Pa) of an equilibrium path, with κ at each.

    Parameters
    ----------
    path : EquilibriumPath
        The whole equilibrium path (pressure in Pa, curvature in 1/m).
    loading : EquilibriumPath, optional
        Its observed loading curve (computed with :func:`observed_curves` if omitted).
    break_stretch : float, optional
        Uniaxial stretch at break of the wall material (-).
    signal : {"curvature", "axial_stretch", "twist_rate"}
        The path quantity whose activation and hardening define Pc and Ph: κ (bending and
        twisting cells), the axial stretch (mirror-symmetric stretching cells) or the twist
        rate (a whole twisting module in FE, in the sense of its tilt).

    Returns
    -------
    CharacteristicPressures
    """
    if signal not in SIGNALS:
        raise SpecError(f"signal must be one of {', '.join(SIGNALS)}, got {signal!r}")
    if loading is None:
        loading = observed_curves(path)[0]
    real = loading
    if signal != "curvature":
        path = replace(path, curvature=np.asarray(getattr(path, signal), float))
        loading = replace(loading, curvature=np.asarray(getattr(loading, signal), float))
    sense = motion_sense(loading.curvature)
    if sense < 0:
        path = replace(path, curvature=-np.asarray(path.curvature, float))
        loading = replace(loading, curvature=-np.asarray(loading.curvature, float))
    pc, kind, kc = critical_pressure(path, loading)
    ph, kh = hardening_pressure(loading, pc)
    pf, kf = _failure(loading, break_stretch)
    kc, kh, kf = (None if x is None else sense * x for x in (kc, kh, kf))
    if signal != "curvature":
        P, k = _monotone(real.pressure, real.curvature)
        kc, kh, kf = (None if x is None else float(np.interp(x, P, k)) for x in (pc, ph, pf))
    return CharacteristicPressures(critical=pc, critical_kind=kind, hardening=ph, failure=pf,
                                   curvature_at={"critical": kc, "hardening": kh,
                                                 "failure": kf}, signal=signal)
