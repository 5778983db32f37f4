"""The reduced (Ritz) model as the calibrated model's backbone: its paths and features.

The calibrated model uses the Ritz model where it is reliable — the stiffness of a cell at
small and moderate chamber inflation, which sets the scale of every pressure — and FE for
the rest. :func:`ritz_features` are that part: the Ritz pressures at two chamber volumes,
log(P/μ) at t = log(V/V0) = 0.25 and 0.75, and the Ritz signal over t at t = 0.25 (κd for
bending, λ − 1 for stretching, the strip shear for tilted cells) and the mid-height strain
over t there.
They are smooth functions of the dimensionless groups and are emulated for speed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache
from typing import Any

import numpy as np

from multimorph.geometry import CellGeometry, TiltedCell

__all__ = ["FEATURE_NAMES", "FEATURE_T", "RITZ_PMAX", "ritz_features", "ritz_paths"]

#: Chamber log volume ratios t = log(V/V0) at which the Ritz model is read.
TABLE_T = (0.05, 0.1, 0.2, 0.25, 0.3, 0.5, 0.75, 1.0)
#: The Ritz features the calibrated model uses (a subset of :func:`path_table` columns).
FEATURE_T = (0.25, 0.75)
FEATURE_NAMES = ("log_p_ritz_t025", "log_p_ritz_t075", "signal_per_t_ritz_t025",
                 "mid_strain_per_t_ritz_t025")
#: Columns of :func:`path_table`: log(P/μ), signal/t and mid-height strain/t at each t, and
#: log(Pc/μ) of the Ritz path (NaN where it has no Pc below :data:`RITZ_PMAX` μ).
TABLE_NAMES = (*(f"{q}_t{t:g}" for q in ("log_p", "signal_per_t", "mid_strain_per_t")
                  for t in TABLE_T), "log_pc")
#: Largest pressure of the Ritz traces, in units of the wall μ (every sampled design of the
#: calibrated box passes t = 1 below it).
RITZ_PMAX = 4.0


def _straight(c: CellGeometry | TiltedCell) -> CellGeometry:
    return c.cell if isinstance(c, TiltedCell) else c


def signal_of(path: Any, cell: CellGeometry | TiltedCell) -> np.ndarray:
    """The activation signal along a path: κd (bending), λ − 1 (stretching) or the strip
    shear in the sense of the tilt, (λ_mid − 1) sin 2|β| (tilted; the Ritz rule)."""
    c = _straight(cell)
    if isinstance(cell, TiltedCell):
        lam = np.asarray(path.axial_stretch) * (1.0 + np.asarray(path.curvature) * 0.5
                                                * c.height)
        return (lam - 1.0) * math.sin(2.0 * abs(cell.tilt))
    if c.symmetric:
        return np.asarray(path.axial_stretch) - 1.0
    return np.asarray(path.curvature) * c.length


def ritz_paths(cells: Sequence[CellGeometry | TiltedCell], pmax_over_mu: float = RITZ_PMAX,
               ) -> list[Any]:
    """Ritz equilibrium paths of ``cells`` (straight cells of tilted ones) to
    ``pmax_over_mu`` × μ, batched per law pair and kind; a design whose trace failed gives
    its path up to the failure (the caller checks coverage)."""
    from multimorph.rom import solve_batch

    straight = [_straight(c) for c in cells]
    out: list[Any] = [None] * len(cells)
    groups: dict[tuple[str, str, bool], list[int]] = {}
    for i, c in enumerate(straight):
        assert c.bottom_material is not None
        groups.setdefault((c.material.model, c.bottom_material.model, c.symmetric),
                          []).append(i)
    for idx in groups.values():
        batch = [straight[i] for i in idx]
        rb = solve_batch(batch, np.array([pmax_over_mu * c.mu for c in batch]))
        for j, i in enumerate(idx):
            out[i] = rb.path(j)
    return out


def path_features(path: Any, cell: CellGeometry | TiltedCell) -> np.ndarray:
    """The features of one path (NaN where the path does not reach the volume)."""
    c = _straight(cell)
    v0 = c.wc * c.hc * c.dc
    t = np.log(np.asarray(path.volume) / v0)
    P = np.asarray(path.pressure) / c.mu
    y = signal_of(path, cell)
    keep = np.concatenate([[True], np.diff(t) > 0])  # volume rises along the path
    t, P, y = t[keep], P[keep], y[keep]
    out = np.full(len(FEATURE_NAMES), np.nan)
    for k, tk in enumerate(FEATURE_T):
        if t[-1] >= tk:
            out[k] = math.log(float(np.interp(tk, t, P)))
    if t[-1] >= FEATURE_T[0]:
        out[2] = float(np.interp(FEATURE_T[0], t, y)) / FEATURE_T[0]
        mid = np.asarray(path.axial_stretch) * (1.0 + np.asarray(path.curvature) * 0.5
                                                * c.height) - 1.0
        out[3] = float(np.interp(FEATURE_T[0], t, mid[keep])) / FEATURE_T[0]
    return out


def path_row(path: Any, cell: CellGeometry | TiltedCell) -> np.ndarray:
    """:data:`TABLE_NAMES` of one Ritz path (NaN where it does not reach that volume)."""
    c = _straight(cell)
    v0 = c.wc * c.hc * c.dc
    t = np.log(np.asarray(path.volume) / v0)
    P = np.asarray(path.pressure) / c.mu
    y = signal_of(path, cell)
    mid = np.asarray(path.axial_stretch) * (1.0 + np.asarray(path.curvature) * 0.5
                                            * c.height) - 1.0
    prev = np.maximum.accumulate(t)
    keep = np.concatenate([[True], t[1:] > prev[:-1]])
    t, P, y, mid = t[keep], P[keep], y[keep], mid[keep]
    tt = np.asarray(TABLE_T)
    inside = tt <= t[-1]
    out = np.full(3 * len(tt) + 1, np.nan)
    k = len(tt)
    out[:k][inside] = np.log(np.maximum(np.interp(tt[inside], t, P), 1e-12))
    out[k:2 * k][inside] = np.interp(tt[inside], t, y) / tt[inside]
    out[2 * k:3 * k][inside] = np.interp(tt[inside], t, mid) / tt[inside]
    pc = ritz_pc(path, cell)
    out[3 * k] = math.log(pc / c.mu) if math.isfinite(pc) else np.nan
    return out


def ritz_pc(path: Any, cell: CellGeometry | TiltedCell) -> float:
    """The straight cell's critical pressure on a Ritz path (Pa; NaN: none on the path or
    a path too short to read)."""
    from multimorph.response import build_response

    c = _straight(cell)
    try:
        pc = build_response(path, length=c.length, shear_modulus=c.mu, backend="rom",
                            signal=c.signal).characteristic.critical
    except Exception:  # a path too short to read: no Pc
        return math.nan
    return math.nan if pc is None else float(pc)


def path_table(cells: Sequence[CellGeometry | TiltedCell]) -> np.ndarray:
    """:data:`TABLE_NAMES` of every cell's Ritz path, shape (n, 25)."""
    paths = ritz_paths(cells)
    return np.array([path_row(p, c) for p, c in zip(paths, cells, strict=True)])


def features_from_table(table: np.ndarray) -> np.ndarray:
    """:data:`FEATURE_NAMES` (n, 4) read from :func:`path_table` rows (interpolated in t)."""
    table = np.atleast_2d(table)
    tt = np.asarray(TABLE_T)
    k = len(tt)

    def at(block: np.ndarray, t: float) -> np.ndarray:
        return np.array([np.interp(t, tt, row) for row in block])

    return np.column_stack([at(table[:, :k], FEATURE_T[0]), at(table[:, :k], FEATURE_T[1]),
                            at(table[:, k:2 * k], FEATURE_T[0]),
                            at(table[:, 2 * k:3 * k], FEATURE_T[0])])


def log_pc_from_table(table: np.ndarray) -> np.ndarray:
    """log(Pc/μ) of the Ritz paths of :func:`path_table` rows (NaN: none)."""
    return np.atleast_2d(table)[:, 3 * len(TABLE_T)]


def ritz_features(cells: Sequence[CellGeometry | TiltedCell]) -> np.ndarray:
    """:data:`FEATURE_NAMES` of every cell, shape (n, 4) (NaN where not reached): the
    pressures at two volumes, the signal and the mid-height strain (the twisting modules'
    ε) at the smaller one."""
    return ritz_features_and_pc(cells)[0]


def ritz_features_and_pc(cells: Sequence[CellGeometry | TiltedCell],
                         ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`ritz_features` and each straight cell's Ritz critical pressure (Pa; NaN when
    its Ritz path has none below :data:`RITZ_PMAX` μ): the FE reference data were traced
    to a multiple of it, so it bounds the pressures the calibrated model has data for."""
    paths = ritz_paths(cells)
    feats = np.array([path_features(p, c) for p, c in zip(paths, cells, strict=True)])
    pcs = np.array([ritz_pc(p, c) for p, c in zip(paths, cells, strict=True)])
    return feats, pcs


#: Names of the linear-response features (:func:`linear_features`).
LINEAR_NAMES = ("log_ritz_stiffness", "ritz_signal_rate", "ritz_mid_strain_rate")


@lru_cache(maxsize=8)
def _linear_kernel(wall: str, bottom: str, options: Any) -> Any:
    import jax
    import jax.numpy as jnp

    from multimorph.rom import announced, cell_kernel

    ck = cell_kernel(wall, bottom, options)
    n = ck.n_free

    def one(theta: Any) -> Any:
        _, H = ck.derivatives(jnp.zeros(n), jnp.asarray(0.0), theta)
        K, b = H[:n, :n], -H[:n, n]
        dq = jnp.linalg.solve(K, b)
        return dq, b @ dq

    return announced(jax.jit(jax.vmap(one)), f"linear {wall} {bottom} {options!r}")


def linear_features(cells: Sequence[CellGeometry | TiltedCell]) -> np.ndarray:
    """The Ritz model's small-inflation response of every cell, shape (n, 3).

    At P = 0 the Ritz energy's Hessian K = ∂²Π/∂q² and the pressure's coupling
    b = ∂ΔV/∂q give dq/dp = K⁻¹ b and dV/dp = bᵀK⁻¹b (p = P/μ, lengths over d). The
    features are log(dp/dt) (the chamber's pressure stiffness per log volume, t = log V/V0),
    dy/dt (the signal: κd, or λ − 1 for a mirror-symmetric cell) and the mid-height
    strain's dε/dt, exactly and at the cost of one Hessian per design (vectorised).
    """
    import jax
    import jax.numpy as jnp

    from multimorph.rom._model import cell_theta, options_for

    straight = [_straight(c) for c in cells]
    out = np.full((len(cells), len(LINEAR_NAMES)), np.nan)
    groups: dict[tuple[str, str, bool], list[int]] = {}
    for i, c in enumerate(straight):
        assert c.bottom_material is not None
        groups.setdefault((c.material.model, c.bottom_material.model, c.symmetric),
                          []).append(i)
    for (wall, bottom, sym), idx in groups.items():
        opts = options_for(sym)
        free = list(opts.free)
        thetas = [cell_theta(straight[i]) for i in idx]
        stacked = jax.tree_util.tree_map(lambda *a: jnp.asarray(np.array(a, float)), *thetas)
        dq, dv = _linear_kernel(wall, bottom, opts)(stacked)
        dq, dv = np.asarray(dq), np.asarray(dv)
        for j, i in enumerate(idx):
            c = straight[i]
            full = np.zeros(5)
            full[free] = dq[j]
            v0 = c.wc * c.hc * c.dc / c.length**3
            dt_dp = dv[j] / v0
            k_rate, e_rate = full[0], full[3]
            y_rate = e_rate if c.symmetric else k_rate
            mid_rate = e_rate + k_rate * 0.5 * c.height / c.length
            out[i] = [-math.log(dt_dp), y_rate / dt_dp, mid_rate / dt_dp]
    return out
