r"""The tilted cells' strip shear, calibrated against FE: a law of the chamber volume
(since stop 40), or a factor on the Ritz rule.

A twisting module's tilted cell took its path from its straight cell's calibrated
response until stop 40 (since stop 35 with its pressures placed on the twisting kind's Pc
and Ph anchors; since stop 41 the twisting kind's own path, its shear this module's law
weighted with the kind's GP: ``CalibratedModel._tilted_shear``; the straight cell's
answer remains for a model without a twisting kind and for tilted cells outside its box),
and its strip shear from the Ritz rule γ = ε sin 2|β| (ε the mid-height strain along the
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

**The volume law (since stop 39).** In 3D FE the strip shear of a tilted cell follows its
chamber's volume: on the 130 tilted FE cells with both knees, the knee of the shear is the
knee of log V (Ph ratio median 1.00, 10-90 % 0.97-1.21), and along a path ln γ rises with
ln(V/V0 − 1) at a slope of 0.8 (median; 0.67-0.99 quartiles). So the shear is also fitted as

    ln(γ / sin 2|β|) = b0 + b1 |β| + b2 ln Jm + b3 ln(V/V0 − 1) + Σ_g b_g ln g,

g the cell's other groups (h/d, w/d, ht/d, hb/d, μb/μ, ws/d, df/d), V/V0 the chamber's
volume at the read pressure, by least squares on the same samples. Stops 39-40 read that
volume on the model's tilted path (the straight cell's, placed on the anchors: the law
absorbed its volume errors); since stop 41 the model's tilted path is its own, 4 % off FE
in pressure at a given volume, and a refit reads FE's own volume (:data:`VOLUME_SOURCE`;
the shipped law is stop 40's until the next refit: on the held-out tilted cells the two
gave the same curves within a design or two, and FE's volume has the better leave-one-out
error, 18 / 56 % against 19 / 61 % on the own path's volume). The factor's rule is read on
the straight cell's path (:meth:`CalibratedModel.tilted_by_straight`, where the factor is
used). Where it beats
the factor in leave-one-out (median and p90 both), it can be the model's form (``fit
twist-shear --form volume``): γ along a path is then this law of the path's volume, so the
module twists as its chambers grow. The groups are held at the edges of the fitted data;
the volume is not (γ → 0 as V → V0). It is fitted on each path at a few pressures (its
exponent the paths' own, :data:`SHAPE_FRACTIONS`). On stop 40's model its leave-one-out
error is 21 % / 67 % (median / p90) against the factor's 30 % / 81 %, held out 20 % / 61 %
against 31 % / 74 %. **It is the shipped form since stop 40.** Stop 39 had kept the factor
because the law spreads a module's twist over the inflation before Pc, and the designed
gripper's twist was asked to wait for its fingers' bend. 3D FE says the law is right there:
the FE-verified gripper's twister (one tilted cell of its strips with the module's shaft
kinematics, `design._fe_check.strip_twist_response`, the FE loop's mesh) turns 6.6°,
17°, 28°, 39°, 48°, 60°, 77° and 97° at 10, 20, 25, 28, 30, 32, 35 and 40 kPa: 39° of
its 97° before the fingers end their bend (29.3 kPa in FE). On the calibrated model the law
gives 9°, 16°, 21°, 27°, 35°, 53°, 55°, 57° there, the factor 2°, 5°, 9°, 13°, 20°, 37°,
39°, 42°. Both still twist faster after 30 kPa than before it
(tests/test_device_examples.py), as FE does (4.8° / kPa against 1.6° / kPa on average
before). The tilted held-out curves (docs/validation.md §3): their error median falls from
29 / 45 / 38 % to 28 / 20 / 27 % on the three tilted sets.

``python -m multimorph.calibrated.fit twist-shear`` fits it on the shipped model and data
and writes it into the model's manifest (``twisting_shear``); ``fit model`` does it too.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["SHEAR_FEATURES", "VOLUME_GROUPS", "fit_shear_factor", "plate_level",
           "shear_factor", "shear_of_volume", "shear_samples"]

#: The factor's regressors (besides the constant): the tilt |β| (rad) and ln Jm.
SHEAR_FEATURES = ("tilt", "ln_jm")
#: The volume law's groups besides the tilt and Jm (each enters as its logarithm).
VOLUME_GROUPS = ("h/d", "w/d", "ht/d", "hb/d", "mu_b/mu", "ws/d", "df/d")
#: The volume law's regressors (besides the constant).
VOLUME_FEATURES = ("tilt", "ln_jm", "ln_volume_excess", *(f"ln_{g}" for g in VOLUME_GROUPS))
#: V/V0 − 1 below which the volume law is not read (its logarithm held there).
VOLUME_EXCESS_FLOOR = 1e-6
#: The volume law is fitted on each path at these fractions of its read pressure too (its
#: exponent is then the paths' own: read past Pc alone, the designs' spread put it at 0.59
#: where a path rises at 0.8, and the law twisted a module by a third of its Pc twist at
#: 10 kPa, where FE has a few degrees).
SHAPE_FRACTIONS = (0.4, 0.6, 0.8, 0.9)
#: Where the volume law's volumes are read (:func:`shear_samples`): ``"fe"``, FE's own chamber
#: volume at each read pressure, or ``"model"``, the model's tilted path's.
VOLUME_SOURCE = "fe"


def _volume_features(groups: Mapping[str, float], excess: np.ndarray) -> np.ndarray:
    """Rows [1, |β|, ln Jm, ln(V/V0 − 1), ln g …] (one per volume excess)."""
    excess = np.atleast_1d(np.asarray(excess, float))
    fixed = [1.0, float(groups["tilt"]), math.log(groups["jm"])]
    logs = [math.log(groups[g]) for g in VOLUME_GROUPS]
    out = np.empty((len(excess), len(fixed) + 1 + len(logs)))
    out[:, :3] = fixed
    out[:, 3] = np.log(np.maximum(excess, VOLUME_EXCESS_FLOOR))
    out[:, 4:] = logs
    return out


def _features(tilt: float, jm: float) -> np.ndarray:
    return np.array([1.0, tilt, math.log(jm)])


def plate_level(model: Any) -> Any:
    """``model`` with its bending kind read at the plate level (``end_input`` 0), where a
    tilted cell's straight cell is read (the tilted FE cells, and the device FE check's
    twisting modules, are one cell with its far end tied to a plate); ``model`` itself
    when the kind has no end input."""
    return model.bending_at(0.0)


def shear_samples(model: Any, sets: Mapping[str, Any] | None = None, *,
                  volume: str = VOLUME_SOURCE) -> list[dict[str, Any]]:
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
            out.extend(_set_samples(model, name, ref, volume))
    return out


def _set_samples(model: Any, name: str, ref: Any, source: str) -> list[dict[str, Any]]:
    import warnings

    from multimorph.calibrated._box import cell_groups
    from multimorph.calibrated._validate import fe_response, signal_of_loading

    out = []
    for row in np.flatnonzero(ref.ok):
        cell, path = ref.cell(int(row)), ref.path(int(row))
        fe = fe_response(path, cell, "twisting")
        pc = fe.characteristic.critical
        top = 2.0 * float(np.max(path["pressure"]))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rule = model.tilted_by_straight([cell], top)[0]
            own = rule if source != "model" else model.responses([cell], top)[0]
        if (pc is None or isinstance(rule, Exception) or isinstance(own, Exception)
                or not str(rule.meta.get("model", "")).startswith("calibrated")
                or not str(own.meta.get("model", "")).startswith("calibrated")):
            continue
        applied = float((rule.meta.get("calibration") or {}).get("shear_factor", 1.0))
        Pf, gf = signal_of_loading(fe, "twisting")
        Pm, gm = signal_of_loading(rule, "twisting")
        gm = gm / applied                     # the bare rule, without a factor fitted earlier
        # the volume the law is fitted on: FE's own at the read pressure (since stop 41), or
        # the model's tilted path's (stops 39-40: the straight path placed on the anchors)
        lo = fe.loading if source == "fe" else own.loading
        v = np.asarray(lo.volume, float)
        Pl = np.asarray(lo.pressure, float)
        at = min(float(Pf.max()), float(Pm.max()), float(Pl.max()))
        if at < pc:
            continue

        def read(P: np.ndarray, y: np.ndarray, at: float = at) -> float:
            keep = np.concatenate([[True], np.diff(P) > 0])
            return float(np.interp(at, P[keep], y[keep]))

        g_fe, g_rule = read(Pf, gf), read(Pm, gm)
        if g_fe <= 0 or g_rule <= 0:
            continue
        groups = cell_groups(cell)
        volume = read(Pl, v / v[0]) if v[0] > 0 else math.nan
        # the path's shape for the volume law: FE's shear and the model's volume at
        # fractions of the read pressure too
        shape = []
        for f in SHAPE_FRACTIONS:
            gf_f = read(Pf, gf, f * at)
            if v[0] > 0 and gf_f > 0:
                shape.append({"pressure": f * at, "fe": gf_f,
                              "volume": read(Pl, v / v[0], f * at)})
        out.append({"set": name, "design": int(ref.design[row]),
                    "holdout": bool(ref.holdout[row]), "tilt": float(groups["tilt"]),
                    "jm": float(groups["jm"]), "pressure": at, "fe": g_fe, "rule": g_rule,
                    "volume": volume, "groups": {k: float(v) for k, v in groups.items()},
                    "shape": shape})
    return out


def fit_shear_factor(samples: list[dict[str, Any]], form: str = "factor") -> dict[str, Any]:
    """Fit ln c on the training samples; the result (stored in the model's manifest) has
    the coefficients, the fitted ranges, the leave-one-out and held-out errors of the
    shear with and without the factor (|γ − γ_FE| / γ_FE: median, p90) and the scatter;
    and, where the samples carry the model's volume, the volume law (``volume_law``, with
    its own errors). ``form``: the model's form (``out["form"]``): ``"factor"``, or
    ``"volume"`` where the law beats the factor in leave-one-out (median and p90)."""
    if form not in ("factor", "volume"):
        raise ValueError(f"twist shear form: expected factor or volume, got {form!r}")
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
    law = _fit_volume_law(train, held, stats)
    out["form"] = "factor"
    if law is not None:
        out["volume_law"] = law
        better = (law["leave_one_out_error"]["median"] < out["leave_one_out_error"]["median"]
                  and law["leave_one_out_error"]["p90"] < out["leave_one_out_error"]["p90"])
        if form == "volume" and better:
            out["form"] = "volume"
    return out


def _fit_volume_law(train: list[dict[str, Any]], held: list[dict[str, Any]],
                    stats: Any) -> dict[str, Any] | None:
    """The volume law (module docstring) on the samples that carry the model's volume and
    groups; None with too few of them."""
    def usable(ss: list[dict[str, Any]]) -> list[dict[str, Any]]:
        return [s for s in ss if "groups" in s and math.isfinite(s.get("volume", math.nan))
                and s["volume"] > 1.0]

    train, held = usable(train), usable(held)
    k = 1 + len(VOLUME_FEATURES)
    if len(train) < 3 * k:
        return None

    def xy(ss: list[dict[str, Any]], shape: bool = False,
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        rows, ys, who = [], [], []
        for i, s in enumerate(ss):
            pts = [s] + ([p for p in s.get("shape", []) if p["volume"] > 1.0] if shape else [])
            for p in pts:
                rows.append(_volume_features(s["groups"], p["volume"] - 1.0)[0])
                ys.append(math.log(p["fe"] / math.sin(2.0 * s["groups"]["tilt"])))
                who.append(i)
        return np.array(rows), np.array(ys), np.array(who)

    X, y, who = xy(train, shape=True)
    coef = np.linalg.lstsq(X, y, rcond=None)[0]
    X1, y1, _ = xy(train)
    loo = []              # by design: all its points out, scored at its read pressure
    for i in range(len(train)):
        keep = who != i
        c = np.linalg.lstsq(X[keep], y[keep], rcond=None)[0]
        loo.append(y1[i] - X1[i] @ c)
    loo_a = np.asarray(loo)
    law: dict[str, Any] = {
        "features": ["1", *VOLUME_FEATURES], "coefficients": [float(v) for v in coef],
        # the inputs' fitted ranges (the law holds them at the edges; the volume excess
        # only from below)
        "low": [float(v) for v in X[:, 1:].min(axis=0)],
        "high": [float(v) for v in X[:, 1:].max(axis=0)],
        "sigma_log": float(np.std(loo_a, ddof=1)), "training_designs": len(train),
        "leave_one_out_error": stats(loo_a)}
    if held:
        Xh, yh, _ = xy(held)
        law["holdout_error"] = stats(yh - Xh @ coef)
    # the shape: at the fractions of the read pressure, FE's shear against the law's
    Xs, ys, _ = xy(train, shape=True)
    law["shape_error"] = stats(ys - Xs @ coef)
    return law


def shear_of_volume(law: Mapping[str, Any], groups: Mapping[str, float],
                    volume_ratio: np.ndarray) -> tuple[np.ndarray, bool]:
    """γ (in the tilt's sense, ≥ 0) along a path whose chamber volume is ``volume_ratio`` ×
    its first, by the volume law ``law`` (``fit["volume_law"]``), and whether the cell's
    groups lie inside the law's fitted ranges (else held at their edges)."""
    v = np.asarray(volume_ratio, float)
    X = _volume_features(groups, v - 1.0)
    lo, hi = np.asarray(law["low"], float), np.asarray(law["high"], float)
    fixed = [j for j in range(X.shape[1] - 1) if j != 2]       # all but the volume excess
    inside = bool(np.all((X[0, 1:][fixed] >= lo[fixed] - 1e-12)
                         & (X[0, 1:][fixed] <= hi[fixed] + 1e-12)))
    X[:, 1:] = np.where(np.arange(X.shape[1] - 1) == 2, X[:, 1:],
                        np.clip(X[:, 1:], lo, hi))
    X[:, 3] = np.maximum(X[:, 3], math.log(VOLUME_EXCESS_FLOOR))
    gamma = math.sin(2.0 * float(groups["tilt"])) * np.exp(X @ np.asarray(
        law["coefficients"], float))
    gamma = np.where(v - 1.0 > VOLUME_EXCESS_FLOOR, gamma, 0.0)
    return gamma, inside


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
