"""Fitting the law map of :mod:`._law` on FE of Yeoh-walled cells (stop 49).

    python -m multimorph.calibrated.fit law-map

:func:`law_map_costs` reads, for every training design of ``yeoh2_mirror``, the mismatch
of the calibrated model against FE with the wall replaced by each Gent wall of a grid
(:data:`._law.SEARCH_MU_FACTOR` × :data:`._law.SEARCH_JM`); :func:`fit_law_map` fits the
line through them; :func:`law_map_spread` reads the spread the map leaves on Pc and Ph.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from multimorph.calibrated._law import (
    LAW_MAP_SET,
    ONE_SIDED_COST,
    SEARCH_JM,
    SEARCH_MU_FACTOR,
    law_shape,
    membrane_limit_point,
)
from multimorph.geometry import CellGeometry

__all__ = ["design_costs", "fit_law_map", "fit_ph_shift", "law_map_costs", "law_map_spread"]


def design_costs(model: Any, cell: CellGeometry, fe: Any, p_max: float, *,
                 fast: bool = True) -> np.ndarray:
    """The mismatch J(s, Jm) of the calibrated model of ``cell`` with its wall replaced by
    Gent(s μ, Jm) against the FE response ``fe``, over :data:`SEARCH_MU_FACTOR` ×
    :data:`SEARCH_JM`: |ΔPc|/Pc + |ΔPh|/Ph (where both have one) + the graph error
    (docs/validation.md §3); NaN where the model has no answer."""
    from multimorph.calibrated._validate import compare, one_sided
    from multimorph.materials import Material

    wall = cell.material
    cells = []
    for s in SEARCH_MU_FACTOR:
        for jm in SEARCH_JM:
            m = Material("gent", {"mu": wall.shear_modulus * float(s), "jm": float(jm)},
                         break_stretch=wall.break_stretch)
            cells.append(replace(cell, material=m))
    want = "calibrated-fast" if fast else "calibrated"
    J = np.full(len(cells), np.nan)
    for i, r in enumerate(model.responses(cells, p_max, fast=fast, fallback=False)):
        if isinstance(r, Exception) or r.meta.get("model") != want:
            continue
        d = compare(r, fe, "bending")
        if not math.isfinite(d.graph_error):
            continue
        J[i] = d.graph_error
        for err, a, b in ((d.pc_error, d.pc_fe, d.pc_model), (d.ph_error, d.ph_fe, d.ph_model)):
            if math.isfinite(err):
                J[i] += err
            elif one_sided(a, b, d.top_fe, d.top_model):
                J[i] += ONE_SIDED_COST
    return J.reshape(len(SEARCH_MU_FACTOR), len(SEARCH_JM))


def _fe_designs(model: Any, set_name: str, holdout: bool) -> Any:
    """``(model at the set's end level, rows)``: per training design of ``set_name`` (the
    held-out ones with ``holdout``) its design index, cell, FE response and the pressure
    its FE run was asked for; and the shapes of all its designs."""
    from multimorph.calibrated._fit import fe_training_data
    from multimorph.calibrated._model import load_model
    from multimorph.calibrated._validate import fe_response
    from multimorph.calibrated.validate import at_end_of, requested_pressure

    data = fe_training_data("bending", set_names=(set_name,), ritz=False)
    model, _ = at_end_of(model or load_model(), "bending", set_name)
    rows = [(int(data.design[r]), data.cells[r], fe_response(data.paths[r], data.cells[r],
                                                             "bending"),
             requested_pressure(set_name, int(data.design[r]), data.paths[r]))
            for r in range(len(data.cells)) if bool(data.holdout[r]) == holdout]
    return model, rows, [law_shape(c.material) for c in data.cells]


def law_map_costs(model: Any = None, *, fast: bool = True, holdout: bool = False,
                  set_name: str = LAW_MAP_SET) -> dict[str, Any]:
    """:func:`design_costs` of every training design of ``set_name`` (the held-out fifth
    with ``holdout``): ``{"design", "shape", "cost" (n, S, J)}``."""
    import warnings

    from multimorph.calibrated import CalibrationWarning

    model, rows, every = _fe_designs(model, set_name, holdout)
    costs = []
    for _, cell, fe, p in rows:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", CalibrationWarning)
            costs.append(design_costs(model, cell, fe, p, fast=fast))
    return {"design": np.array([r[0] for r in rows]),
            "shape": np.array([law_shape(r[1].material) for r in rows]),
            "cost": np.array(costs),
            # the shapes the set samples (held-out designs too), as a box is its sampling's
            "set_shape_range": [float(np.nanmin(every)), float(np.nanmax(every))]}


def fit_law_map(costs: dict[str, Any], *, set_name: str = LAW_MAP_SET) -> dict[str, Any]:
    """The mapping (ln s, ln Jm_eff linear in ln k) that minimises the mean of the training
    designs' costs (:func:`law_map_costs`, read off their grids by bilinear interpolation
    in ln s, ln Jm); started from the line through the designs' own best walls."""
    from scipy.interpolate import RegularGridInterpolator
    from scipy.optimize import minimize

    cost = np.asarray(costs["cost"], float)
    lk = np.log(np.asarray(costs["shape"], float))
    ls, lj = np.log(SEARCH_MU_FACTOR), np.log(SEARCH_JM)
    keep = np.array([np.isfinite(c).any() for c in cost])
    cost, lk = cost[keep], lk[keep]
    interps = []
    for c in cost:
        filled = np.where(np.isfinite(c), c, np.nanmax(c) + 1.0)
        interps.append(RegularGridInterpolator((ls, lj), filled))

    def line(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return (np.clip(theta[0] + theta[1] * lk, ls[0], ls[-1]),
                np.clip(theta[2] + theta[3] * lk, lj[0], lj[-1]))

    def objective(theta: np.ndarray) -> float:
        a, b = line(theta)
        return float(np.mean([f((x, y)) for f, x, y in zip(interps, a, b, strict=True)]))

    best = np.array([np.unravel_index(np.nanargmin(c), c.shape) for c in cost])
    x0 = np.concatenate([np.polyfit(lk, ls[best[:, 0]], 1)[::-1],
                         np.polyfit(lk, lj[best[:, 1]], 1)[::-1]])
    starts = [x0, np.array([0.0, 0.0, math.log(30.0), 0.0]),
              np.array([float(np.median(ls[best[:, 0]])), 0.0,
                        float(np.median(lj[best[:, 1]])), 0.0])]
    # the cost is piecewise bilinear and flat along a ridge of μ against Jm, where
    # Nelder–Mead stops at the first plateau it meets: lines of x0's slopes through the
    # quartiles of the designs' own best walls as well (stop 52: from the three starts
    # above the refit stopped at a mean cost of 0.2865 where 0.2815 lay four of these
    # nine starts away)
    k_mid = float(np.median(lk))
    for qs in (0.25, 0.5, 0.75):
        for qj in (0.25, 0.5, 0.75):
            s_mid = float(np.quantile(ls[best[:, 0]], qs))
            j_mid = float(np.quantile(lj[best[:, 1]], qj))
            starts.append(np.array([s_mid - x0[1] * k_mid, x0[1], j_mid - x0[3] * k_mid,
                                    x0[3]]))
    res = min((minimize(objective, s, method="Nelder-Mead",
                        options={"xatol": 1e-4, "fatol": 1e-5, "maxiter": 4000})
               for s in starts), key=lambda r: r.fun)
    a, b = line(res.x)
    per = np.array([f((x, y)) for f, x, y in zip(interps, a, b, strict=True)])
    own = np.array([np.nanmin(c) for c in cost])
    return {"set": set_name, "training_designs": len(cost),
            "shape_range": costs.get("set_shape_range",
                                     [float(np.exp(lk.min())), float(np.exp(lk.max()))]),
            "training_shape_range": [float(np.exp(lk.min())), float(np.exp(lk.max()))],
            "log_mu_factor": [float(res.x[0]), float(res.x[1])],
            "log_jm": [float(res.x[2]), float(res.x[3])],
            "cost": {"mean": float(per.mean()), "median": float(np.median(per)),
                     "p90": float(np.percentile(per, 90)),
                     "each_design_own_best_median": float(np.median(own))},
            "search": {"mu_factor": [float(SEARCH_MU_FACTOR[0]), float(SEARCH_MU_FACTOR[-1])],
                       "jm": [float(SEARCH_JM[0]), float(SEARCH_JM[-1])]}}


def _comparisons(model: Any, rows: list[Any], *, fast: bool, keep: Any = None) -> Any:
    """``model``'s comparison with FE (``_validate.compare``) for each of ``rows`` (from
    :func:`_fe_designs`) whose cell ``keep`` accepts; a design the model cannot answer is
    left out."""
    import warnings

    from multimorph.calibrated import CalibrationWarning
    from multimorph.calibrated._validate import compare

    for _, cell, fe, p in rows:
        if keep is not None and not keep(cell):
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", CalibrationWarning)
            resp = model.responses([cell], p, fast=fast)[0]
        if not isinstance(resp, Exception):
            yield compare(resp, fe, "bending")


def law_map_spread(model: Any, *, fast: bool = True, set_name: str = LAW_MAP_SET
                   ) -> dict[str, float]:
    """The spread the map adds: the RMS of log(model / FE) of Pc and Ph over the training
    designs of ``set_name`` answered with ``model`` (its ``law_map`` set) — added to the
    bands of a mapped wall's Pc and Ph (:func:`widen_band`), whose GP knows only Gent walls."""
    model, rows, _ = _fe_designs(model, set_name, holdout=False)
    logs: dict[str, list[float]] = {"pc": [], "ph": []}
    for d in _comparisons(model, rows, fast=fast):
        for key, a, b in (("pc", d.pc_model, d.pc_fe), ("ph", d.ph_model, d.ph_fe)):
            if a is not None and b is not None and a > 0 and b > 0:
                logs[key].append(math.log(a / b))
    return {f"sigma_log_{k}": float(np.sqrt(np.mean(np.square(v)))) if v else math.nan
            for k, v in logs.items()} | {f"n_{k}": len(v) for k, v in logs.items()}


def fit_ph_shift(model: Any, *, fast: bool = True, set_name: str = LAW_MAP_SET
                 ) -> dict[str, Any]:
    """The factor on Ph of a bending cell whose mapped wall's membrane has no limit point
    (stop 50): the mean of log(Ph_FE / Ph_model) over the training designs of ``set_name``
    with such a wall and a Ph on both sides, answered with ``model`` (its ``law_map``, no
    shift yet). Such a wall never locks, so past Pc it keeps stretching before it hardens,
    and its effective Gent wall, which locks, reads the knee early."""
    model, rows, _ = _fe_designs(model, set_name, holdout=False)
    logs = [math.log(d.ph_fe / d.ph_model)
            for d in _comparisons(model, rows, fast=fast,
                                  keep=lambda c: membrane_limit_point(c.material) is False)
            if d.ph_model is not None and d.ph_fe is not None and d.ph_model > 0 < d.ph_fe]
    n = len(logs)
    return {"log_factor": float(np.mean(logs)) if n >= 3 else 0.0,
            "std": float(np.std(logs, ddof=1)) if n >= 3 else math.nan,
            "training_designs": n, "kinds": ["bending"],
            "rule": "bending cells of a mapped wall whose membrane has no limit point"}
