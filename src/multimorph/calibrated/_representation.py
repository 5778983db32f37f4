"""A cell's equilibrium path on a fixed grid of chamber volumes, and back.

Every model of a single-chamber cell gives a path that the chamber volume orders: the volume
grows monotonically along it through the ballooning and the limit points, where pressure
does not. So the calibrated model describes a path by smooth functions of the log volume
ratio t = log(V/V0) on :data:`T_GRID` (V0 the undeformed chamber volume):

* ``log_p``  log(P/μ);
* ``y_t``    the activation signal over t: κd/t (bending: the end rotation per cell),
  (λ − 1)/t (stretching: the axial stretch), γ/t (tilted: the strip's shear in the sense of
  its tilt). Signed (a cell whose stiff layer is not stiff enough bends the other way) and
  finite as t → 0, where the response is linear in the inflation;
* ``log_l``  log(Λ − 1), Λ the largest principal stretch anywhere;
* ``e_t``    the bottom edge's axial strain over t (bending only).

:func:`grid_values` samples a path there; :func:`path_from_grid` rebuilds an
:class:`~multimorph.response.EquilibriumPath` from grid values (monotone cubic in t,
stability from dP/dt > 0: a single chamber under pressure control is stable where its
pressure rises with its volume).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.interpolate import PchipInterpolator

from multimorph.geometry import CellGeometry, TiltedCell
from multimorph.response import EquilibriumPath

__all__ = ["QUANTITIES", "T_GRID", "grid_values", "path_from_grid", "paths_from_grid",
           "quantities_of"]

#: The log volume ratios t = log(V/V0) of the grid: dense at small inflation (the linear
#: regime and the approach to the ballooning), then evenly up to V/V0 = 25 (the FE data set's stop).
T_GRID = np.concatenate([np.geomspace(0.01, 0.2, 7), np.linspace(0.3, math.log(25.0), 25)])
#: Quantities per cell kind (see the module docstring).
QUANTITIES = {"bending": ("log_p", "y_t", "log_l", "e_t"),
              "stretching": ("log_p", "y_t", "log_l"),
              "twisting": ("log_p", "y_t", "log_l")}
#: Quantities that are logarithms (the others are ratios to t).
_LOGS = ("log_p", "log_l")
_TINY = 1e-9


def kind_of(cell: CellGeometry | TiltedCell) -> str:
    if isinstance(cell, TiltedCell):
        return "twisting"
    return "stretching" if cell.symmetric else "bending"


def quantities_of(cell: CellGeometry | TiltedCell) -> tuple[str, ...]:
    return QUANTITIES[kind_of(cell)]


def _straight(cell: CellGeometry | TiltedCell) -> CellGeometry:
    return cell.cell if isinstance(cell, TiltedCell) else cell


def grid_values(t: np.ndarray, P: np.ndarray, y: np.ndarray, peak: np.ndarray,
                axial: np.ndarray, mu: float, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """Grid values (len(T_GRID), len(QUANTITIES[kind])) of a path given on its own points
    (t the log volume ratio, P in Pa, y the signal, peak the largest stretch, axial the
    axial stretch), and the mask of the grid points the path covers."""
    t = np.asarray(t, float)
    # the points where the volume exceeds every earlier one (a path that turns back in
    # volume, rare, keeps its monotone part)
    prev = np.maximum.accumulate(np.where(np.isfinite(t), t, -np.inf))
    keep = np.isfinite(t) & np.concatenate([[True], t[1:] > prev[:-1] + 1e-12])
    t = t[keep]
    tz = np.where(t > 0, t, np.inf)
    cols = {"log_p": np.log(np.maximum(np.asarray(P, float)[keep] / mu, _TINY)),
            "y_t": np.asarray(y, float)[keep] / tz,
            "log_l": np.log(np.maximum(np.asarray(peak, float)[keep] - 1.0, _TINY)),
            "e_t": (np.asarray(axial, float)[keep] - 1.0) / tz}
    names = QUANTITIES[kind]
    pos = t > 0
    out = np.full((len(T_GRID), len(names)), np.nan)
    if pos.sum() < 2:
        return out, np.zeros(len(T_GRID), bool)
    tp = t[pos]
    covered = T_GRID <= tp[-1]
    # below the first loaded point the response is linear in the inflation: P, y, Λ − 1
    # and e are proportional to t there, so the logs continue with slope 1 in log t and
    # the ratios to t stay constant
    t0 = min(0.5 * T_GRID[0], 0.5 * tp[0])
    for q, name in enumerate(names):
        v = cols[name][pos]
        v0 = v[0] + math.log(t0 / tp[0]) if name in _LOGS else v[0]
        f = PchipInterpolator(np.log(np.concatenate([[t0], tp])),
                              np.concatenate([[v0], v]), extrapolate=False)
        out[covered, q] = f(np.log(T_GRID[covered]))
    covered &= np.all(np.isfinite(out), axis=1)
    return out, covered


def path_from_grid(values: np.ndarray, cell: CellGeometry | TiltedCell, *,
                   points: int = 96, t_end: float | None = None) -> EquilibriumPath:
    """An :class:`EquilibriumPath` (SI) from grid values of :func:`grid_values`'s layout,
    on ``points`` log volumes from 0 to ``t_end`` (default the grid's end). Grid values are
    interpolated by monotone cubics in log t (the small-inflation regime is a power law)."""
    names = QUANTITIES[kind_of(cell)]
    t_end = float(T_GRID[-1] if t_end is None else t_end)
    tt = np.concatenate([[0.0], np.geomspace(T_GRID[0], t_end, points - 1)])
    at = PchipInterpolator(np.log(T_GRID), values[:, :len(names)], axis=0)(np.log(tt[1:]))
    return _path(at, tt, cell)


def paths_from_grid(values: np.ndarray, cells: list[CellGeometry | TiltedCell],
                    t_end: np.ndarray, *, points: int = 96) -> list[EquilibriumPath]:
    """:func:`path_from_grid` of a batch of same-kind cells (values (n, J, Q), t_end (n,)):
    one monotone cubic for the whole batch (the knots are shared), evaluated at each
    design's own volumes — the same paths, without a spline object per design."""
    n = len(cells)
    if n == 0:
        return []
    nq = len(QUANTITIES[kind_of(cells[0])])
    x = np.log(T_GRID)
    J = len(x)
    cols = np.moveaxis(np.asarray(values, float)[:, :, :nq], 1, 0).reshape(J, n * nq)
    coef = PchipInterpolator(x, cols, axis=0).c            # (4, J − 1, n·nq)
    u = np.linspace(0.0, 1.0, points - 1)
    ends = np.log(np.asarray(t_end, float))
    xe = x[0] + u[None, :] * (ends - x[0])[:, None]        # (n, points − 1) log volumes
    seg = np.clip(np.searchsorted(x, xe, side="right") - 1, 0, J - 2)
    dx = xe - x[seg]
    out = []
    for i in range(n):
        c_i = coef[:, seg[i], i * nq:(i + 1) * nq]          # (4, points − 1, nq)
        d = dx[i][:, None]
        at = ((c_i[0] * d + c_i[1]) * d + c_i[2]) * d + c_i[3]
        tt = np.concatenate([[0.0], np.exp(xe[i])])
        out.append(_path(at, tt, cells[i]))
    return out


def _path(at: np.ndarray, tt: np.ndarray, cell: CellGeometry | TiltedCell) -> EquilibriumPath:
    """The path of grid quantities ``at`` (points − 1, Q) read at log volumes ``tt[1:]``."""
    c = _straight(cell)
    kind = kind_of(cell)
    names = QUANTITIES[kind]
    points = len(tt)
    vals = {n: at[:, q] for q, n in enumerate(names)}
    P = np.concatenate([[0.0], np.exp(vals["log_p"])]) * c.mu
    y = np.concatenate([[0.0], vals["y_t"] * tt[1:]])
    peak = 1.0 + np.concatenate([[0.0], np.exp(vals["log_l"])])
    axial = np.ones(points)
    curvature = np.zeros(points)
    twist = np.zeros(points)
    extra: dict[str, Any] = {"log_volume_ratio": tt}
    if kind == "bending":
        curvature = y / c.length
        axial = 1.0 + np.concatenate([[0.0], vals["e_t"] * tt[1:]])
    elif kind == "stretching":
        axial = 1.0 + y
    else:
        extra["shear"] = y
    dP = np.gradient(P, tt)
    stable = dP > 0
    v0 = c.wc * c.hc * c.dc
    return EquilibriumPath(pressure=P, curvature=curvature, twist_rate=twist,
                           axial_stretch=axial, volume=v0 * np.exp(tt), peak_stretch=peak,
                           stable=stable, extra=extra)
