r"""The tilted cells' strip shear, calibrated against FE: a factor on the Ritz rule.

A twisting module's tilted cell takes its path from its straight cell's calibrated
response (the tilt barely changes how a chamber balloons; since stop 35 its pressures are
placed on the twisting kind's Pc and Ph anchors, ``CalibratedModel.tilted_by_kind``), and
its strip shear from the Ritz rule γ = ε sin 2|β| (ε the mid-height strain along the
chamber). On the FE reference data set's
tilted cells that rule over-predicts the shear: FE / rule is a median 0.59 past Pc, lower at
small tilts (the strip's bottom layer and side walls resist the shear that a free strip of
chambers would take). This module fits an effective factor

    γ = c(β, Jm) · ε sin 2|β|,    ln c = a0 + a1 |β| + a2 ln Jm

by least squares on ln(γ_FE / γ_rule) of the tilted training designs, each read at one
pressure past its FE Pc (the last pressure both the FE path and the calibrated path reach;
the calibrated path is the model's own answer for the tilted cell, so the factor is fitted
on the pressures the model gives).
The factor multiplies a whole path, so Pc and Ph (read on the shear) do not move; the
twist a module makes does. Outside the fitted tilts and Jm the factor is held at the edge
of the data (no extrapolation), and it carries its leave-one-out scatter as an uncertainty.

``python -m multimorph.calibrated.fit twist-shear`` fits it on the shipped model and data
and writes it into the model's manifest (``twisting_shear``); ``fit model`` does it too.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["SHEAR_FEATURES", "fit_shear_factor", "plate_level", "shear_factor",
           "shear_samples"]

#: The factor's regressors (besides the constant): the tilt |β| (rad) and ln Jm.
SHEAR_FEATURES = ("tilt", "ln_jm")


def _features(tilt: float, jm: float) -> np.ndarray:
    return np.array([1.0, tilt, math.log(jm)])


def plate_level(model: Any) -> Any:
    """``model`` with its bending kind read at the plate level (``end_input`` 0), where a
    tilted cell's straight cell is read (the tilted FE cells, and the device FE check's
    twisting modules, are one cell with its far end tied to a plate); ``model`` itself
    when the kind has no end input."""
    return model.bending_at(0.0)


def shear_samples(model: Any, sets: Mapping[str, Any] | None = None,
                  ) -> list[dict[str, Any]]:
    """One sample per tilted FE design that passed its Pc: its tilt, Jm, whether it is held
    out, the pressure it is read at, FE's strip shear and the rule's (the calibrated straight
    cell's mid-height strain × sin 2|β|) there, from every set of tilted cells."""
    from multimorph.calibrated._dataset import load_reference
    from multimorph.calibrated._fit import KIND_SETS

    sets = sets if sets is not None else load_reference()
    out = []
    for name in KIND_SETS["twisting"]:
        ref = sets.get(name)
        if ref is not None:
            out.extend(_set_samples(model, name, ref))
    return out


def _set_samples(model: Any, name: str, ref: Any) -> list[dict[str, Any]]:
    import warnings

    from multimorph.calibrated._box import cell_groups
    from multimorph.calibrated._validate import fe_response, signal_of_loading

    out = []
    for row in np.flatnonzero(ref.ok):
        cell, path = ref.cell(int(row)), ref.path(int(row))
        fe = fe_response(path, cell, "twisting")
        pc = fe.characteristic.critical
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rule = model.responses([cell], 2.0 * float(np.max(path["pressure"])))[0]
        if (pc is None or isinstance(rule, Exception)
                or not str(rule.meta.get("model", "")).startswith("calibrated")):
            continue
        applied = float((rule.meta.get("calibration") or {}).get("shear_factor", 1.0))
        Pf, gf = signal_of_loading(fe, "twisting")
        Pm, gm = signal_of_loading(rule, "twisting")
        gm = gm / applied                     # the bare rule, without a factor fitted earlier
        at = min(float(Pf.max()), float(Pm.max()))
        if at < pc:
            continue

        def read(P: np.ndarray, y: np.ndarray, at: float = at) -> float:
            keep = np.concatenate([[True], np.diff(P) > 0])
            return float(np.interp(at, P[keep], y[keep]))

        g_fe, g_rule = read(Pf, gf), read(Pm, gm)
        if g_fe <= 0 or g_rule <= 0:
            continue
        groups = cell_groups(cell)
        out.append({"set": name, "design": int(ref.design[row]),
                    "holdout": bool(ref.holdout[row]), "tilt": float(groups["tilt"]),
                    "jm": float(groups["jm"]), "pressure": at, "fe": g_fe, "rule": g_rule})
    return out


def fit_shear_factor(samples: list[dict[str, Any]]) -> dict[str, Any]:
    """Fit ln c on the training samples; the result (stored in the model's manifest) has
    the coefficients, the fitted ranges, the leave-one-out and held-out errors of the
    shear with and without the factor (|γ − γ_FE| / γ_FE: median, p90) and the scatter."""
    train = [s for s in samples if not s["holdout"]]
    held = [s for s in samples if s["holdout"]]
    if len(train) < 3 * len(_features(0.5, 30.0)):
        raise ValueError(f"twist shear factor: {len(train)} tilted training designs past "
                         "Pc; at least 9 are needed")

    def xy(ss: list[dict[str, Any]]) -> tuple[np.ndarray, np.ndarray]:
        return (np.array([_features(s["tilt"], s["jm"]) for s in ss]),
                np.array([math.log(s["fe"] / s["rule"]) for s in ss]))

    X, y = xy(train)
    coef = np.linalg.lstsq(X, y, rcond=None)[0]
    loo = []
    for i in range(len(y)):
        keep = np.arange(len(y)) != i
        c = np.linalg.lstsq(X[keep], y[keep], rcond=None)[0]
        loo.append(y[i] - X[i] @ c)
    loo = np.asarray(loo)

    def stats(residual_log: np.ndarray) -> dict[str, float]:
        e = np.abs(np.exp(-residual_log) - 1.0)        # |γ_model − γ_FE| / γ_FE
        return {"n": len(e), "median": round(float(np.median(e)), 4),
                "p90": round(float(np.percentile(e, 90)), 4)} if len(e) else {"n": 0}

    out: dict[str, Any] = {
        "features": ["1", *SHEAR_FEATURES], "coefficients": [float(v) for v in coef],
        "tilt_range": [min(s["tilt"] for s in train), max(s["tilt"] for s in train)],
        "jm_range": [min(s["jm"] for s in train), max(s["jm"] for s in train)],
        "sigma_log": float(np.std(loo, ddof=1)),
        "training_designs": len(train),
        "rule_error": stats(y), "leave_one_out_error": stats(loo),
        "read_at": "the last pressure both the FE path and the calibrated path reach, past "
                   "the FE Pc",
    }
    if held:
        Xh, yh = xy(held)
        out["holdout_error"] = stats(yh - Xh @ coef)
        out["holdout_rule_error"] = stats(yh)
    return out


def shear_factor(fit: Mapping[str, Any] | None, tilt: float, jm: float,
                 ) -> tuple[float, float, bool]:
    """(c, σ of ln c, inside) for a tilted cell: the calibrated factor on the Ritz rule at
    |β| = ``tilt`` (rad) and the wall's equivalent Jm, held at the fitted range's edges
    (``inside`` False there); (1, 0, False) without a fit."""
    if not fit:
        return 1.0, 0.0, False
    t0, t1 = fit["tilt_range"]
    j0, j1 = fit["jm_range"]
    t, j = min(max(tilt, t0), t1), min(max(jm, j0), j1)
    c = float(np.exp(_features(t, j) @ np.asarray(fit["coefficients"], float)))
    return c, float(fit["sigma_log"]), bool(t == tilt and j == jm)
