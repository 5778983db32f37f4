"""Fitting the calibrated cell model: Ritz-feature emulators and FE-trained GPs per kind.

For each kind of cell (bending, stretching, tilted):

1. inputs: the design's groups scaled to the calibrated box, and its Ritz features
   (:mod:`._ritz`: the reduced model's pressures at two inflations and its signal), which
   carry the physics the Ritz model gets right — how stiff the cell is at small inflation;
2. outputs: the FE path on the grid of chamber volumes (:mod:`._representation`);
3. a multi-output GP (:mod:`._gp`) from inputs to outputs, trained on the designs of the
   calibration split (the held-out 20 % and the 24-design grid are never seen);
4. two scalar GPs, each with its own kernel, from the same inputs to the FE's activation
   and hardening pressures, log(Pc/μ) and log(Ph/μ) (the shared definitions of
   :mod:`multimorph.response` read on the FE path): the *anchors*. Pc and Ph are
   functionals of the whole curve (an inflection, a knee) that a path read back from grid
   values places poorly; predicted on their own they are about twice as close to FE, and
   the model reports them as the response's Pc and Ph where its path reaches them, the
   path itself unchanged (:func:`~._anchor.anchored_characteristic`).

The shipped model computes each cell's Ritz features with the Ritz model at run time (the
cost of one batched Ritz trace). Optionally (``fit model --emulators``) they are emulated
instead: a GP over the groups trained on the Ritz table (:mod:`._ritz_table`), one for the
bending box (bending and tilted cells) and one for the stretching box; faster, but the
emulator's own error adds to the model's. Everything is saved to ``data/model.npz`` with its
provenance (``data/model.json``).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from multimorph.calibrated._box import DERIVED_INPUTS, GROUP_NAMES, Box, cell_groups
from multimorph.calibrated._dataset import (
    DATA_DIR,
    ReferenceSet,
    is_holdout,
    load_reference,
    reference_spec,
)
from multimorph.calibrated._gp import MultiOutputGP, fit_gp, fit_gp_cv
from multimorph.calibrated._representation import QUANTITIES, T_GRID, grid_values
from multimorph.calibrated._ritz import ritz_features

__all__ = ["ANCHORS", "DEFAULT_KINDS", "KIND_SETS", "MODEL_FILE", "STRAIGHT_FEATURES",
           "STRAIGHT_FEATURES_V1", "TrainingData",
           "add_part", "add_signal", "fe_training_data", "fit_anchors",
           "fit_and_save", "fit_log_signal", "fit_path", "fit_pressure", "fit_signal",
           "model_inputs",
           "straight_features", "twin_set"]

MODEL_FILE = DATA_DIR / "model.npz"
MODEL_MANIFEST = DATA_DIR / "model.json"
#: The calibration sets of each kind. Stretching cells since stop 31: the sets with mirror
#: ends (the cell as inside a module; the plate sets were 8 % (Pc) and 16 % (Ph) stiffer,
#: median, docs/validation.md §1); since stop 37 with a second sample, `stretching2_mirror`
#: (fitted on 215 designs against 124: held-out Pc 6.2 / 20.8 → 2.2 / 6.9 %, median / p90).
#: Bending since stop 33: the plate sets and their mirror
#: twins together, the end condition a GP input (:func:`end_column`) and the model
#: predicting mirror ends. The plate sets are the larger, complete sample; the twins say
#: how far a plate is from the cell inside a module (pairs 0.94 on Pc, median, down to 0.79).
#: Fitted on the twins alone it was worse on held-out twins (Ph median / p90 3.5 / 13.2 %
#: against 2.7 / 10.9 % with both) and on the 24-design grid's (Ph 6.0 / 14.8 % against
#: 4.6 / 10.3 %; docs/validation.md §3, stop 33). Since stop 47 with a third sample of the
#: box, `bending3_mirror` (its training four-fifths; docs/validation.md §4 stop 47); since
#: stop 48 with the soft-bottom refinement, `bending_softbottom_mirror` (μb/μ 1.1–3.0,
#: where the curves missed most; docs/validation.md §4 stop 48); since stop 52 with
#: `bending_lowbt_mirror` (a weak bottom against the top wall, μb·hb/(μ·ht) mostly below
#: 3.5, where the curves still missed after stop 51; docs/validation.md §4 stop 52); since
#: stop 59 with `bending_single3_mirror` (a third one-elastomer sample, μb/μ 1.0–1.1, where the
#: curves missed most; docs/validation.md §4 stop 59).
KIND_SETS = {"bending": ("bending", "bending_narrow", "bending_single", "bending_single2",
                         "bending_mirror", "bending_narrow_mirror", "bending_single_mirror",
                         "bending_single2_mirror", "bending3_mirror",
                         "bending_softbottom_mirror", "bending_lowbt_mirror",
                         "bending_single3_mirror"),
             "stretching": ("stretching_mirror", "stretching_narrow_mirror",
                            "stretching2_mirror"),
             "twisting": ("twisting", "twisting2", "twisting_narrow")}
#: The kinds ``fit model`` fits by default. The twisting kind (shipped since stop 35) is a
#: GP on the tilted FE cells whose inputs include the straight cell's calibrated features
#: (:data:`STRAIGHT_FEATURES`). Since stop 41 a tilted cell is its own grid path (its
#: pressure and, weighted with the volume law, its strip shear at each chamber volume:
#: ``_model.CalibratedModel._tilted_shear``) with the kind's Pc and Ph anchors; stops 35–40
#: placed the straight cell's path on those anchors (docs/validation.md §2: the own path's
#: pressure at a given volume is 3–4 % off FE, the placed one 7–14 %). Anchors on the 27
#: held-out tilted designs of `twisting`: Pc 11.5 / 20.2 %, Ph 16.4 / 24.6 % (median / p90)
#: against the straight cell's 10.8 / 30.5 % and 18.9 / 40.6 %; refitted on three sets in
#: stop 39 (`twisting_narrow` where the designer's twisting modules sit): 7.7 / 20.8 % and
#: 10.4 / 15.8 %. (Stop 34's own shear curves, on 65 designs, had a far tail: p90 285 % of
#: the FE range; on 268 designs, weighted with the law, 51 %.)
DEFAULT_KINDS = ("bending", "stretching", "twisting")
#: A kind is fitted only with at least this many training designs per GP input (its
#: groups and three Ritz features): with fewer, the linear means alone nearly interpolate
#: (15 tilted cells for 12 inputs gave log P errors of 100 % and more in cross-validation).
MIN_DESIGNS_PER_INPUT = 5
#: The emulator family of each kind's Ritz features.
FAMILY = {"bending": "bending", "twisting": "bending", "stretching": "stretching"}


def _log(msg: str) -> None:
    print(f"[calibrate] {msg}", file=sys.stderr, flush=True)


def kind_features(kind: str, feats: np.ndarray, tilt: np.ndarray | None = None,
                  straight: np.ndarray | None = None) -> np.ndarray:
    """The features a kind's GP takes: log P at t = 0.25 and 0.75 and the signal over t at
    t = 0.25 of the Ritz model (n, 3; tilted cells: the mid-height strain times sin 2|β|).
    Tilted cells with ``straight`` (n, s; :data:`STRAIGHT_FEATURES`, read off the fitted
    bending kind) take those in place of the Ritz pressures (n, s + 1)."""
    feats = np.atleast_2d(feats)
    if kind == "twisting":
        assert tilt is not None
        sig = feats[:, 3] * np.sin(2.0 * np.abs(np.asarray(tilt, float)))
        if straight is not None:
            return np.column_stack([np.atleast_2d(straight), sig])
    else:
        sig = feats[:, 2]
    return np.column_stack([feats[:, 0], feats[:, 1], sig])


#: The tilted cells' features from their straight cell (since stop 34): the calibrated
#: bending kind's log(P/μ) at t = 0.25 and 0.75 and its log(Pc/μ) anchor. A tilted cell
#: balloons much as its straight cell does, 10 % stiffer at a given volume (median, more
#: at larger tilts, docs/validation.md §3): the calibrated straight cell is a far better
#: low-fidelity input than the Ritz model (5-fold cross-validation on 66 tilted cells:
#: log P at t = 0.66 within 5.1 / 14.1 % median / p90 against 10.0 / 28.2 % on Ritz
#: features). The straight cell is read at the plate level (``straight_end`` 0): the
#: tilted FE cells, and the device FE check's twisting modules, are one tilted cell with
#: its far end tied to a plate (there is no mirror-ended tilted FE: PlaneTie turns about
#: x only).
STRAIGHT_FEATURES = ("log_p_straight_t025", "log_p_straight_t075", "log_pc_straight",
                     "y_t_straight_t075", "e_t_straight_t075")
#: Since stop 62 also the straight cell's signal over t (κd/t) and bottom-edge strain over t
#: at t = 0.75. Tried for the tilted curves, whose strip shear at a given volume is what
#: misses most (FE's own shear on the model's volumes takes the held-out graphs from 61 to
#: 79 % within 10 %, FE's pressures from 61 to 63 %); what they improve is the pressures.
#: 5-fold cross-validation of the fast variant on the 237 tilted training designs with an
#: FE Pc, three fold seeds (59, 7, 2026): Pc and Ph p90 lower on every seed (by 1.4 and 1.3
#: points on average), graphs within 10 % unchanged beyond the seeds' own spread, narrow
#: cells (``twisting_narrow``) worse on seed 59 (docs/validation.md §4 stop 62). A model
#: fitted before names none in its manifest and reads the first three
#: (:data:`STRAIGHT_FEATURES_V1`).
STRAIGHT_FEATURES_V1 = STRAIGHT_FEATURES[:3]
_STRAIGHT_NAME = re.compile(r"^(?P<q>[a-z_]+)_straight_t(?P<t>\d+)$")


def _straight_quantity(name: str) -> tuple[str, float]:
    """The bending grid quantity and the t of a straight feature ``<q>_straight_t<100 t>``."""
    m = _STRAIGHT_NAME.match(name)
    if m is None or m["q"] not in QUANTITIES["bending"]:
        raise ValueError(f"not a straight-cell feature: {name!r}")
    return m["q"], int(m["t"]) / 100.0


#: The volumes (log V/V0) of the first two straight features (read off their names).
STRAIGHT_T = tuple(_straight_quantity(n)[1] for n in STRAIGHT_FEATURES[:2])


def straight_features(grid_prediction: Any,
                      names: Sequence[str] = STRAIGHT_FEATURES) -> np.ndarray:
    """The straight features ``names`` (n, len(names)) of a bending-kind grid prediction:
    ``<q>_straight_t<100 t>`` its grid quantity q (:data:`~._representation.QUANTITIES`)
    at t, ``log_pc_straight`` its Pc anchor (NaN where the straight cell is outside its
    support)."""
    values = grid_prediction.values
    cols = []
    for name in names:
        if name == "log_pc_straight":
            cols.append(grid_prediction.anchors[:, 0] if grid_prediction.anchors is not None
                        else np.full(len(values), np.nan))
            continue
        q, t = _straight_quantity(name)
        v = values[:, :, QUANTITIES["bending"].index(q)]
        cols.append(np.array([np.interp(t, T_GRID, row) for row in v]))
    out = np.column_stack(cols)
    out[~np.asarray(grid_prediction.inside, bool)] = np.nan
    return out


def model_inputs(box: Box, groups: np.ndarray, kfeats: np.ndarray, fmean: np.ndarray,
                 fstd: np.ndarray, end: np.ndarray | float | None = None) -> np.ndarray:
    """GP inputs: scaled groups (and the box's derived inputs, :meth:`Box.inputs`) and
    standardised Ritz features, and with ``end`` the cell's end condition (0 plate, 1
    mirror: :func:`end_column`)."""
    cols = [box.inputs(groups), (kfeats - fmean) / fstd]
    if end is not None:
        cols.append(np.broadcast_to(np.asarray(end, float), (len(groups),))[:, None])
    return np.column_stack(cols)


def end_column(data: TrainingData) -> np.ndarray | None:
    """The end-condition input of a kind trained on plate-ended and mirror-ended sets (1
    mirror, 0 plate; None when its sets share one end condition). With it the GPs learn a
    plate cell and its mirror twin as two correlated levels of one response (the indicator
    form of multi-fidelity co-kriging: its length scale says how far apart they are), and
    the model predicts at 1, the cell as inside a module."""
    if data.end is None or not len(data.end) or np.all(data.end == data.end[0]):
        return None
    return data.end


def twin_set(name: str) -> str:
    """The set of the same designs with the other end condition (``bending`` ↔
    ``bending_mirror``); it may not exist."""
    return name.removesuffix("_mirror") if name.endswith("_mirror") else f"{name}_mirror"


@dataclass(frozen=True, eq=False)
class TrainingData:
    """FE grid data of one kind (all finished designs of its sets, and the split)."""

    kind: str
    set_name: np.ndarray
    design: np.ndarray
    groups: np.ndarray
    features: np.ndarray
    y: np.ndarray
    mask: np.ndarray
    holdout: np.ndarray
    cells: list[Any]
    paths: list[dict[str, np.ndarray]]
    #: log(Pc/μ) and log(Ph/μ) of the FE path (n, 2); NaN where it has none
    anchors: np.ndarray | None = None
    #: the end condition of each design's set: 1.0 mirror ends, 0.0 a plate (or free)
    end: np.ndarray | None = None
    #: tilted cells: their straight cell's :data:`STRAIGHT_FEATURES` at their end level
    #: (None: the twisting kind takes Ritz features)
    straight: np.ndarray | None = None
    #: the names of ``straight``'s columns (written into the fitted kind's manifest)
    straight_names: tuple[str, ...] = STRAIGHT_FEATURES
    #: log(p_max/μ) of a design whose FE run stopped at its pressure limit (its pressure
    #: still rising: every grid volume past its end lies above it), NaN otherwise
    #: (:data:`STOPPED_AT_P_MAX`)
    censor: np.ndarray | None = None

    def lower(self, rows: np.ndarray) -> np.ndarray:
        """The censoring bound of log(P/μ) (len(rows), grid): finite at the grid volumes
        past the end of a design stopped at its pressure limit."""
        n = len(self.mask)
        c = np.full(n, np.nan) if self.censor is None else self.censor
        return np.where(~self.mask & np.isfinite(c)[:, None], c[:, None], np.nan)[rows]


#: The stop reason of an FE path that reached its pressure limit with the pressure still
#: rising (``multimorph.fe.engine._path.path_end``): its pressure at every larger
#: volume is above that limit, a censored observation (``_gp.censored_residuals``).
STOPPED_AT_P_MAX = "reached p_max"


def fe_signal(kind: str, path: dict[str, np.ndarray], n_cells: int) -> np.ndarray:
    """The FE signal of a stored path: the end rotation per cell (bending, = κd), the axial
    stretch − 1 (stretching) or the strip shear (tilted)."""
    if kind == "bending":
        return np.asarray(path["bend_angle"], float) / n_cells
    if kind == "stretching":
        return np.asarray(path["axial_stretch"], float) - 1.0
    return np.asarray(path["shear"], float)


def fe_training_data(kind: str, sets: dict[str, ReferenceSet] | None = None,
                     set_names: tuple[str, ...] | None = None, *,
                     ritz: bool = True) -> TrainingData:
    """Grid data of the finished, successful designs of ``kind``'s sets (with their exact
    Ritz features unless ``ritz=False``: NaN then)."""
    sets = sets if sets is not None else load_reference()
    names = set_names or KIND_SETS[kind]
    box_names = GROUP_NAMES[kind]
    from multimorph.calibrated._validate import fe_response

    rows: dict[str, list[Any]] = {k: [] for k in ("set", "design", "groups", "y", "mask",
                                                   "holdout", "cell", "path", "anchors",
                                                   "end", "censor")}
    for name in names:
        ref = sets.get(name)
        if ref is None:
            continue
        hold = np.array(ref.holdout, bool)
        # a design held out in its twin set (the same design with the other end condition)
        # stays out of a fit on both: its twin would tell the GP its answer
        if twin_set(name) in names:
            hold |= np.array([is_holdout(twin_set(name), int(d)) for d in ref.design], bool)
        mirror = reference_spec(name).options.get("end") == "mirror"
        for r in np.flatnonzero(ref.ok):
            cell = ref.cell(int(r))
            c = cell.cell if hasattr(cell, "tilt") else cell
            path = ref.path(int(r))
            n_cells = int(ref.meta[r].get("n_cells", 1))
            v0 = c.wc * c.hc * c.dc * n_cells
            t = np.log(np.asarray(path["volume"], float) / v0)
            y, cov = grid_values(t, path["pressure"], fe_signal(kind, path, n_cells),
                                 path["peak_stretch"], path["axial_stretch"], c.mu, kind)
            g = cell_groups(cell)
            rows["set"].append(name)
            rows["design"].append(int(ref.design[r]))
            rows["groups"].append([g[n] for n in box_names])
            rows["y"].append(y)
            rows["mask"].append(cov)
            rows["holdout"].append(bool(hold[r]))
            rows["end"].append(1.0 if mirror else 0.0)
            rows["cell"].append(cell)
            rows["path"].append(path)
            p_max = ref.meta[r].get("p_max")
            rows["censor"].append(
                math.log(float(p_max) / c.mu)
                if ref.meta[r].get("stop_reason") == STOPPED_AT_P_MAX and p_max else math.nan)
            ch = fe_response(path, cell, kind, n_cells).characteristic
            rows["anchors"].append([finite_log((ch.critical or 0.0) / c.mu),
                                    finite_log((ch.hardening or 0.0) / c.mu)])
    n = len(rows["set"])
    if ritz and n:
        _log(f"{kind}: {n} FE designs; computing their Ritz features")
        t0 = time.monotonic()
        feats = ritz_features(rows["cell"])
        _log(f"{kind}: Ritz features of {n} designs in {(time.monotonic() - t0) / 60:.1f} min")
    else:
        feats = np.full((n, 4), np.nan)
    anchors = np.array(rows["anchors"], float).reshape(n, 2)
    anchors[~np.isfinite(anchors)] = np.nan
    return TrainingData(
        kind=kind, set_name=np.array(rows["set"]), design=np.array(rows["design"]),
        groups=np.array(rows["groups"], float).reshape(n, len(box_names)), features=feats,
        y=np.array(rows["y"]).reshape(n, len(T_GRID), len(QUANTITIES[kind])),
        mask=np.array(rows["mask"], bool).reshape(n, len(T_GRID)),
        holdout=np.array(rows["holdout"], bool), cells=rows["cell"], paths=rows["path"],
        anchors=anchors, end=np.array(rows["end"], float),
        censor=np.array(rows["censor"], float))


def _tilts(data: TrainingData) -> np.ndarray | None:
    if data.kind != "twisting":
        return None
    return np.array([abs(c.tilt) for c in data.cells])


def data_features(data: TrainingData) -> np.ndarray:
    """The GP features of the training designs (:func:`kind_features`)."""
    return kind_features(data.kind, data.features, _tilts(data), data.straight)


def fit_kind(data: TrainingData, box: Box, *, train: np.ndarray | None = None,
             restarts: int = 2) -> tuple[MultiOutputGP, np.ndarray, np.ndarray]:
    """The FE GP of one kind on the rows ``train`` (default: not held out, features
    finite); returns (gp, feature mean, feature std)."""
    kf = data_features(data)
    ok = np.all(np.isfinite(kf), axis=1)
    sel = (~data.holdout if train is None else train) & ok
    fmean = kf[sel].mean(axis=0)
    fstd = kf[sel].std(axis=0) + 1e-12
    return fit_path(data, box, fmean, fstd, train=sel, restarts=restarts), fmean, fstd


def fit_path(data: TrainingData, box: Box, fmean: np.ndarray, fstd: np.ndarray, *,
             train: np.ndarray | None = None, restarts: int = 2) -> MultiOutputGP:
    """The path GP of one kind (every grid quantity at every grid volume, one kernel) on
    the rows ``train`` (default: not held out, features finite), its inputs scaled by
    ``fmean`` and ``fstd``."""
    kf = data_features(data)
    ok = np.all(np.isfinite(kf), axis=1)
    sel = (~data.holdout if train is None else train) & ok
    end = end_column(data)
    x = model_inputs(box, data.groups[sel], kf[sel], fmean, fstd,
                     None if end is None else end[sel])
    nq = len(QUANTITIES[data.kind])
    y = data.y[sel].reshape(int(sel.sum()), -1)
    mask = np.repeat(data.mask[sel], nq, axis=1)
    # the kernel is fitted on the pressure and the signal at grid volumes most designs reach
    reach = data.mask[sel].mean(axis=0)
    jj = np.flatnonzero(reach >= 0.9)
    jj = jj[np.linspace(0, len(jj) - 1, min(6, len(jj))).astype(int)]
    fit_out = np.array([j * nq + q for j in jj for q in (0, 1)])
    return fit_gp(x, y, mask, fit_outputs=fit_out, restarts=restarts)


#: The pressure GP's kernel is fitted on log P at this many grid volumes from
#: :data:`PRESSURE_T_FROM` on (that most training designs reach): the ballooning and its
#: plateau, where a few per cent of pressure is a large error of the signal at a given
#: pressure (docs/validation.md §2).
PRESSURE_KERNEL_POINTS = 8
PRESSURE_T_FROM = 0.4


def fit_pressure(data: TrainingData, box: Box, fmean: np.ndarray, fstd: np.ndarray, *,
                 train: np.ndarray | None = None, restarts: int = 2) -> MultiOutputGP:
    """The pressure GP of one kind: log(P/μ) at every grid volume, with a kernel of its own
    fitted on the plateau's volumes. The path GP's kernel is a compromise between the signal
    and the pressure at volumes from the first loaded steps on; on its own the pressure
    takes longer length scales, and its held-out error on the ballooning plateau
    (0.4 ≤ t ≤ 2.5) falls by about 40 % (bending: mean |Δ log P| 0.050 → 0.030;
    stretching: 0.033 → 0.019)."""
    return _fit_quantity(data, box, fmean, fstd, 0, PRESSURE_T_FROM, 0.9,
                         PRESSURE_KERNEL_POINTS, train=train, restarts=restarts,
                         censored=True)


def _fit_quantity(data: TrainingData, box: Box, fmean: np.ndarray, fstd: np.ndarray,
                  q: int, t_from: float, min_reach: float, points: int, *,
                  train: np.ndarray | None, restarts: int,
                  censored: bool = False) -> MultiOutputGP:
    """A GP of grid quantity ``q`` alone at every grid volume (the rows ``train``, default
    not held out, features finite), its kernel fitted on ``points`` grid volumes from
    ``t_from`` on that at least ``min_reach`` of those designs reach. ``censored`` (the
    pressure, q = 0): a design stopped at its pressure limit informs the grid volumes past
    its end as censored outputs (:meth:`TrainingData.lower`, ``_gp.censored_residuals``)."""
    kf = data_features(data)
    ok = np.all(np.isfinite(kf), axis=1)
    sel = (~data.holdout if train is None else train) & ok
    end = end_column(data)
    x = model_inputs(box, data.groups[sel], kf[sel], fmean, fstd,
                     None if end is None else end[sel])
    y = data.y[sel][:, :, q]
    mask = data.mask[sel] & np.isfinite(y)
    reach = mask.mean(axis=0)
    jj = np.flatnonzero((reach >= min_reach) & (T_GRID >= t_from))
    jj = jj[np.linspace(0, len(jj) - 1, min(points, len(jj))).astype(int)]
    lower = data.lower(np.flatnonzero(sel)) if censored and q == 0 else None
    return fit_gp(x, np.where(mask, y, 0.0), mask, fit_outputs=jj, restarts=restarts,
                  lower=lower)


#: The signal GP's kernel (:func:`fit_signal`) is fitted on the signal at this many grid
#: volumes from :data:`SIGNAL_T_FROM` on, among those at least :data:`SIGNAL_MIN_REACH` of
#: the training designs reach: past the snap, where the path GP's compromise kernel (fitted
#: at volumes 90 % of the designs reach, mostly before it) leaves the largest errors. Tried
#: in stop 40 (held-out bending designs, the largest |Δκd| at V/V0 ≥ e over the largest
#: |κd|, median / p90, mirror ends; the path GP 0.110 / 0.353, the never-trained grid
#: 0.037 / 0.069): from t = 0.8 where half the designs reach, 0.077 / 0.249 (grid 0.046 /
#: 0.079); 0.8 and 70 %, 0.079 / 0.264; 0.4 and 90 %, 0.090 / 0.299 (grid 0.083); 1.2 and
#: 30 %, 0.074 / 0.247 (grid 0.042 / 0.078). Every kernel of its own is a little worse on
#: the grid than the path GP; the run time averages the two (:data:`SIGNAL_WEIGHT`).
SIGNAL_KERNEL_POINTS = 8
#: The kinds with a signal GP of their own: bending since stop 40; twisting since stop 53,
#: where the path GP's kernel (fitted at the small volumes 90 % of the tilted designs reach)
#: let the strip shear wander past the snap — on 5 of the 10 worst held-out tilted curves
#: it turned negative at large volumes while FE's kept rising. With its own kernel past
#: t = 1.2 (averaged with the path GP's, :data:`SIGNAL_WEIGHT`) the 160 held-out tilted
#: curves (`calibrated-fast`) within 10 % of FE as graphs went 49 → 56 %, graph error
#: median 0.102 → 0.091 (p90 0.316 → 0.325); tried beside it: the signal GP alone (weight
#: 1: 54 %, p90 0.358), a stronger ridge on the linear means (ridge 1: 48 % without the
#: signal GP, 54 % with it).
SIGNAL_KINDS = ("bending", "twisting")
SIGNAL_T_FROM = 1.2
SIGNAL_MIN_REACH = 0.3
#: The run-time signal: this weight on the signal GP's prediction, the rest on the path
#: GP's. The average of the two kernels (t from 1.2): bending mirror 0.075 / 0.280, narrow
#: 0.090 / 0.347 (either alone 0.104-0.111 / 0.377-0.524), grid 0.040 / 0.051 (either alone
#: 0.037-0.042 / 0.069-0.078), one-elastomer sets 0.134 / 1.165 and 0.189 / 0.515 (path
#: GP 0.196 / 1.123, 0.223 / 0.574).
SIGNAL_WEIGHT = 0.5
#: Kinds with a third estimate of their signal (stop 55): a GP of log(y_t) at every grid
#: volume (:func:`fit_log_signal`, y_t floored at :data:`LOG_SIGNAL_FLOOR`), its kernel
#: fitted past the snap as the signal GP's. The run time averages the three, the path GP's,
#: the signal GP's and exp of this one, with equal weights (:data:`LOG_SIGNAL_WEIGHT`
#: each). Tilted cells: their strip shear is positive in the sense of the tilt (93 % of
#: the grid values of the 446 tilted FE cells; the rest small, γ/t −0.004 median, γ at
#: least −0.02 where it reaches 1.9) and its
#: error is mostly an amplitude per design (on the grid, FE's shear with the model's
#: pressures puts 78–79 % of the held-out curves within 10 % as graphs, a factor per
#: design chosen on FE 79–81 %, the model 52–53 %). On the grid (`calibrated-fast`, the
#: model's pressures, held-out fifths 53 / `twisting3` 107 within 10 % as graphs) the
#: average of two (stop 53) 53 / 52 %, either alone 45–49 %, the log GP alone 51 / 42 %,
#: the three 57 / 61 %; through the whole chain (`validate`) the fifths 51 → 62 %, with
#: `twisting3` 57 → 64 %; 5-fold cross-validation on the training designs (chosen after)
#: gains less, 50.0–52.5 → 51.7–52.5 % (docs/validation.md §4 stop 55). Bending cells'
#: signal changes sign (a cell bends either way): not for them.
LOG_SIGNAL_KINDS = ("twisting",)
LOG_SIGNAL_FLOOR = 1e-3
LOG_SIGNAL_WEIGHT = 1.0 / 3.0


def signal_weight(kind: str) -> float:
    """The run-time weight of a kind's signal GP (:data:`SIGNAL_WEIGHT`, or
    :data:`LOG_SIGNAL_WEIGHT` beside a log signal GP)."""
    return LOG_SIGNAL_WEIGHT if kind in LOG_SIGNAL_KINDS else SIGNAL_WEIGHT


def fit_signal(data: TrainingData, box: Box, fmean: np.ndarray, fstd: np.ndarray, *,
               train: np.ndarray | None = None, restarts: int = 2) -> MultiOutputGP:
    """The signal GP of one kind: the signal over t (``y_t``) at every grid volume, with a
    kernel of its own fitted past the snap (stop 40; :data:`SIGNAL_T_FROM`): the error
    behind the curves that miss after their snap (docs/validation.md §3). The run time
    averages it with the path GP's signal (:data:`SIGNAL_WEIGHT`)."""
    return _fit_quantity(data, box, fmean, fstd, 1, SIGNAL_T_FROM, SIGNAL_MIN_REACH,
                         SIGNAL_KERNEL_POINTS, train=train, restarts=restarts)


def fit_log_signal(data: TrainingData, box: Box, fmean: np.ndarray, fstd: np.ndarray, *,
                   train: np.ndarray | None = None, restarts: int = 2) -> MultiOutputGP:
    """The log signal GP of a kind in :data:`LOG_SIGNAL_KINDS`: log(max(y_t,
    :data:`LOG_SIGNAL_FLOOR`)) at every grid volume, its kernel fitted as the signal GP's
    (:func:`fit_signal`)."""
    if data.kind not in LOG_SIGNAL_KINDS:
        raise ValueError(f"fit log-signal: the {data.kind} kind's signal changes sign; a log "
                         f"signal GP is for {list(LOG_SIGNAL_KINDS)}")
    y = data.y.copy()
    y[:, :, 1] = np.log(np.maximum(y[:, :, 1], LOG_SIGNAL_FLOOR))
    return _fit_quantity(replace(data, y=y), box, fmean, fstd, 1, SIGNAL_T_FROM,
                         SIGNAL_MIN_REACH, SIGNAL_KERNEL_POINTS, train=train,
                         restarts=restarts)


def _signal_info(n_train: int, sgp: MultiOutputGP, kind: str,
                 log: bool = False) -> dict[str, Any]:
    """The manifest entry of a kind's signal GP (``log``: its log signal GP)."""
    out = {"training_designs": int(n_train), "length_scales": sgp.length.round(4).tolist(),
           "noise": sgp.noise, "t_from": SIGNAL_T_FROM, "min_reach": SIGNAL_MIN_REACH,
           "kernel_points": SIGNAL_KERNEL_POINTS,
           "weight": LOG_SIGNAL_WEIGHT if log else signal_weight(kind)}
    if log:
        out["floor"] = LOG_SIGNAL_FLOOR
    return out


def add_signal(kinds: tuple[str, ...] = ("bending",)) -> dict[str, Any]:
    """Fit the signal GP (:func:`fit_signal`) of ``kinds`` into the shipped model
    (:func:`add_part`)."""
    return add_part("signal", kinds)


_GP_KEYS = ("x", "length", "noise", "mask", "weights", "coef", "scale", "chol")


def _fit_part(part: str, data: TrainingData, box: Box, fmean: np.ndarray, fstd: np.ndarray,
              train: np.ndarray) -> dict[str, Any]:
    """One :data:`PARTS` fit as :func:`resumable` keeps it: the anchors' dict of GPs, or
    ``{"gp": gp}``."""
    gp = PARTS[part](data, box, fmean, fstd, train=train)
    return dict(gp) if part == "anchors" else {"gp": gp}


def add_part(part: str, kinds: tuple[str, ...] = ("bending",), *,
             straight_of: StraightOf | None = None) -> dict[str, Any]:
    """Fit one GP of ``kinds`` (``part``: "signal", "pressure", "path" or "anchors" (the Pc
    and Ph GPs), :data:`PARTS`) into the shipped model, both variants, on every current
    training design of the kind, on the shipped kinds' boxes and feature scaling, keeping
    every other GP as it is; returns the manifest entries written (``<kind>.<part>``).
    ``straight_of`` gives a twisting kind its straight-cell features (as
    :func:`fit_and_save`)."""
    from multimorph._provenance import code_version

    if part not in PARTS:
        raise ValueError(f"fit: unknown part {part!r}; expected one of {sorted(PARTS)}")
    t0 = time.monotonic()
    sets = load_reference()
    resume_keys: set[str] = set()    # the GPs kept for a resume (:func:`resumable`)
    with np.load(MODEL_FILE, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    manifest = json.loads(MODEL_MANIFEST.read_text())
    emus = {family: (MultiOutputGP.from_arrays(arrays, f"emulator/{family}/"),
                     Box.from_spec(family, reference_spec(family)))
            for family in manifest.get("emulators", {})}
    out: dict[str, Any] = {}
    for kind in kinds:
        if kind not in manifest.get("kinds", {}):
            raise ValueError(f"fit {part}: the shipped model has no {kind!r} kind")
        data = fe_training_data(kind, sets)
        variants = [("", "kinds", data)]
        if kind in manifest.get("fast_kinds", {}) and FAMILY[kind] in emus:
            variants.append(("fast/", "fast_kinds", replace(data, features=emulated_features(
                *emus[FAMILY[kind]], data.cells, data.features))))
        for prefix, key, d in variants:
            if kind == "twisting" and straight_of is not None:
                d = replace(d, straight=straight_of(arrays, manifest, d, bool(prefix)))
            p = f"{prefix}{kind}/"
            info = manifest[key][kind]
            box = Box(kind, tuple(info["groups"]), np.asarray(arrays[f"{p}box_low"]),
                      np.asarray(arrays[f"{p}box_high"]),
                      tuple(info.get("derived_inputs", ())))
            kf = data_features(d)
            train = ~d.holdout & np.all(np.isfinite(kf), axis=1)
            fmean = np.asarray(arrays[f"{p}feature_mean"])
            fstd = np.asarray(arrays[f"{p}feature_std"])
            # kept as soon as it is fitted, like fit_and_save's (a bending anchor refit
            # runs half an hour and more): the key adds the shipped feature scaling
            rkey = fit_fingerprint(d, box, prefix, (fmean, fstd))
            resume_keys.add(rkey)
            got = resumable(fit_resume_folder(), rkey, f"add-{part}",
                            partial(_fit_part, part, d, box, fmean, fstd, train))
            gp = got if part == "anchors" else got["gp"]
            gps = got if part == "anchors" else {"": gp}
            if part == "anchors":  # all of them: a kind may have had more (ANCHOR_CV)
                arrays = {k: v for k, v in arrays.items() if not k.startswith(f"{p}anchor_")}
            for name, g in gps.items():
                where = (p if part == "path" else f"{p}anchor_{name}/" if part == "anchors"
                         else f"{p}{part}/")
                arrays = {k: v for k, v in arrays.items() if not (
                    k.startswith(where) and (part != "path" or k[len(p):] in _GP_KEYS))}
                arrays.update(g.to_arrays(where))
            if part == "anchors":
                info["anchors"] = _anchor_info(gps, d.kind)
            elif part in ("signal", "log_signal"):
                info[part] = _signal_info(int(train.sum()), gp, kind, part == "log_signal")
                if part == "log_signal" and "signal" in info:  # now one of three
                    info["signal"]["weight"] = signal_weight(kind)
            elif part == "pressure":
                info["pressure_length_scales"] = gp.length.round(4).tolist()
                info["pressure"] = _pressure_info(d, train, gp)
            else:
                info["length_scales"] = gp.length.round(4).tolist()
                info["noise"] = gp.noise
                info["path"] = {"training_designs": int(train.sum())}
            # the sets the model has now seen, for the twin rule of the held-out checks
            # (validate.unseen_designs): a part fitted on a set the kind's fit had not
            # (bending3_mirror, stop 47) adds it
            info["sets"] = list(dict.fromkeys([*info.get("sets", ()),
                                               *map(str, d.set_name[train])]))
            out[f"{prefix}{kind}"] = info[part]
            _log(f"{kind}{' (fast)' if prefix else ''}: {part} GP on {int(train.sum())} "
                 "designs")
    manifest["code_version"] = code_version()
    tmp = MODEL_FILE.with_name(f".{MODEL_FILE.stem}.tmp.npz")
    np.savez_compressed(tmp, **arrays)
    os.replace(tmp, MODEL_FILE)
    MODEL_MANIFEST.write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    _log(f"wrote {MODEL_FILE} ({part} GPs) in {time.monotonic() - t0:.1f} s")
    for rkey in resume_keys:        # the model holds them now
        for kept in fit_resume_folder().glob(f"{rkey}-*.npz"):
            kept.unlink(missing_ok=True)
    return out


def _anchor_info(anchors: dict[str, MultiOutputGP], kind: str) -> dict[str, Any]:
    """The manifest entry of a kind's anchors: per anchor its training designs, kernel and,
    with a robust likelihood (:data:`ANCHOR_ROBUST`), its limit and how many designs it
    weighs down."""
    out: dict[str, Any] = {}
    for name, agp in anchors.items():
        entry: dict[str, Any] = {"training_designs": len(agp.x),
                                 "length_scales": agp.length.round(4).tolist(),
                                 "noise": agp.noise}
        if name.endswith("_cv"):
            entry["kernel"] = "leave-one-out cross-validation (ANCHOR_CV)"
        if name.endswith("_ratio"):
            entry["output"] = "log(Ph / Pc) (ANCHOR_RATIO)"
        if kind in ANCHOR_ROBUST:
            own = np.sum(agp.chol ** 2, axis=1) - 1.0 - agp.noise  # diag(L Lᵀ) = 1 + noise + own
            entry["robust_limit"] = ANCHOR_ROBUST[kind]
            entry["weighed_down"] = int(np.sum(own > 1e-9))
        out[name] = entry
    return out


def _pressure_info(data: TrainingData, train: np.ndarray, gp: MultiOutputGP) -> dict[str, Any]:
    """The manifest entry of a kind's pressure GP."""
    censored = (np.zeros(len(train), bool) if data.censor is None
                else np.isfinite(data.censor) & train)
    return {"training_designs": int(train.sum()), "length_scales": gp.length.round(4).tolist(),
            "noise": gp.noise, "t_from": PRESSURE_T_FROM,
            "kernel_points": PRESSURE_KERNEL_POINTS,
            "censored_designs": int(np.sum(censored)),
            "imputed_outputs": int(np.sum(gp.mask & ~data.mask[train]))}


#: The anchors: FE pressures predicted on their own (see the module docstring).
ANCHORS = ("pc", "ph")
#: The anchors' robust likelihood (``_gp.fit_gp``'s ``robust``, per kind: the limit in
#: leave-one-out standard deviations; a kind not named here fits a Gaussian one). Pc and Ph
#: are read on each FE path by the shared definitions, and a reading can jump between
#: neighbouring designs (a limit point against the steepest rise of a gradual knee, the
#: first excursion of a cell that bends one way and back against its second): such a label
#: lies far from its neighbours, and a Gaussian likelihood lets it pull them. Measured in
#: stop 46 (docs/validation.md §2 item 5).
ANCHOR_ROBUST: dict[str, float] = {"bending": 3.0}
#: The anchors that are two GPs, per kind: the likelihood's (:func:`~._gp.fit_gp`) and one
#: with its kernel chosen by leave-one-out cross-validation (:func:`~._gp.fit_gp_cv`,
#: stored as ``<name>_cv``), the prediction their mean (``_model._anchor_prediction``).
#: Tilted Pc (stop 55): on its 236 training designs the likelihood picks a
#: near-interpolating kernel (noise 1e-6, length scales 0.1–0.2 in hb/d, μb/μ, Jm and the
#: tilt), cross-validation a smooth one (noise 0.04–0.08, length scales 0.6–1.3). 5-fold
#: cross-validation on the training designs (median / p90 of |ΔPc|/Pc): 8.6 / 22.7 %
#: (likelihood), 7.4 / 23.7 % (CV), 8.1 / 21.2 % (mean); Ph 7.3 / 18.6, 7.5 / 23.0, 6.3 /
#: 19.8 %, but on the held-out designs the mean's Ph was no better (docs/validation.md §4,
#: stop 55): Ph keeps the likelihood's GP alone. Stop 57 checked an average of the
#: likelihood's local optima weighted by their evidence instead: for Pc its modes lie 5–8
#: nats apart (the average is the best mode), for Ph it did not carry to the held-out
#: designs (docs/validation.md §3 Stop 57).
ANCHOR_CV: dict[str, tuple[str, ...]] = {"twisting": ("pc",)}
#: The kinds whose Ph anchor has a ratio member: a GP of log(Ph / Pc) of FE on the training
#: designs with both (stored as ``ph_ratio``), whose member of Ph is the Pc anchor's
#: prediction plus its own; the Ph anchor predicts the mean of that member and the direct
#: GP's (``_model._anchor_prediction``). Tilted cells (stop 59): the direct GP of log Ph
#: reads the knee of each design on its own, and a tilted Ph is read on a gradual knee
#: (docs/validation.md §4 stop 55); past the snap the ratio Ph / Pc varies more smoothly
#: over the inputs than Ph itself, and Pc is the better-predicted anchor. 5-fold
#: cross-validation on the 268 training designs (163 with Ph; median / p90 of |ΔPh|/Ph,
#: the anchors alone on the fast variant's inputs): direct 7.6 / 21.5 %, ratio member 6.7 /
#: 19.2 %, their mean 6.3 / 20.9 % (the choice, on the median the issue's target asks
#: for); docs/validation.md §4 stop 59 has the held-out figures.
ANCHOR_RATIO: dict[str, tuple[str, ...]] = {"twisting": ("ph",)}


def fit_anchors(data: TrainingData, box: Box, fmean: np.ndarray, fstd: np.ndarray, *,
                train: np.ndarray | None = None, restarts: int = 3,
                ) -> dict[str, MultiOutputGP]:
    """One scalar GP per anchor (log Pc/μ, log Ph/μ of FE), each with its own kernel, on
    the rows ``train`` (default: not held out) that have the anchor and finite features;
    robust where :data:`ANCHOR_ROBUST` names the kind; with a second, cross-validated GP
    each (``<name>_cv``) where :data:`ANCHOR_CV` does, and a GP of log(Ph / Pc)
    (``ph_ratio``) where :data:`ANCHOR_RATIO` does."""
    assert data.anchors is not None
    kf = data_features(data)
    ok = np.all(np.isfinite(kf), axis=1)
    sel = (~data.holdout if train is None else train) & ok
    out = {}
    end = end_column(data)
    for j, name in enumerate(ANCHORS):
        rows = sel & np.isfinite(data.anchors[:, j])
        x = model_inputs(box, data.groups[rows], kf[rows], fmean, fstd,
                         None if end is None else end[rows])
        y = data.anchors[rows, j:j + 1]
        out[name] = fit_gp(x, y, np.ones_like(y, bool), restarts=restarts,
                           robust=ANCHOR_ROBUST.get(data.kind))
        if name in ANCHOR_CV.get(data.kind, ()):
            out[f"{name}_cv"] = fit_gp_cv(x, y)
    if "ph" in ANCHOR_RATIO.get(data.kind, ()):
        rows = sel & np.all(np.isfinite(data.anchors[:, :2]), axis=1)
        x = model_inputs(box, data.groups[rows], kf[rows], fmean, fstd,
                         None if end is None else end[rows])
        y = data.anchors[rows, 1:2] - data.anchors[rows, 0:1]
        out["ph_ratio"] = fit_gp(x, y, np.ones_like(y, bool), restarts=restarts,
                                 robust=ANCHOR_ROBUST.get(data.kind))
    return out


#: The GPs :func:`add_part` refits, and the fitting function of each (the path GP's arrays
#: sit at the kind's own prefix, the anchors' under ``anchor_<name>/``, the others' under
#: ``<part>/``).
PARTS: dict[str, Callable[..., Any]] = {"signal": fit_signal, "pressure": fit_pressure,
                                        "path": fit_path, "anchors": fit_anchors,
                                        "log_signal": fit_log_signal}


#: Outputs of a Ritz emulator: the four :data:`~._ritz.FEATURE_NAMES` and log(Pc/μ).
EMULATOR_OUTPUTS = ("log_p_ritz_t025", "log_p_ritz_t075", "signal_per_t_ritz_t025",
                    "mid_strain_per_t_ritz_t025", "log_pc_ritz")


def emulator_targets(table: np.ndarray) -> np.ndarray:
    """:data:`EMULATOR_OUTPUTS` of Ritz table rows (n, 5); NaN where the path has none."""
    from multimorph.calibrated._ritz import features_from_table, log_pc_from_table

    return np.column_stack([features_from_table(table), log_pc_from_table(table)])


def fit_emulator(family: str, table: dict[str, np.ndarray], box: Box,
                 max_points: int = 2048, test_fraction: float = 0.1,
                 ) -> tuple[MultiOutputGP, dict[str, Any]]:
    """The Ritz emulator of one box: a GP over the scaled groups to
    :data:`EMULATOR_OUTPUTS`, and its accuracy on a tenth of the table it was not fitted
    on (absolute errors per output: log P and log Pc are relative errors)."""
    g, f = table["groups"], emulator_targets(table["table"])
    ok = np.all(np.isfinite(f[:, :4]), axis=1)
    g, f = g[ok][:max_points], f[ok][:max_points]
    x = box.scaled(g)
    mask = np.isfinite(f)
    f = np.where(mask, f, 0.0)
    n_test = round(test_fraction * len(x))
    test = np.zeros(len(x), bool)
    test[np.random.default_rng(0).choice(len(x), n_test, replace=False)] = True
    fit_rows = np.flatnonzero(~test)[:600]
    gp_sub = fit_gp(x[fit_rows], f[fit_rows], mask[fit_rows], restarts=1)
    # accuracy: the kernel found on the subset, weights on every point but the test tenth
    held = refit_weights(gp_sub, x[~test], f[~test], mask[~test])
    err = np.abs(held.predict(x[test]) - f[test])
    accuracy = {}
    for j, name in enumerate(EMULATOR_OUTPUTS):
        e = err[mask[test][:, j], j]
        accuracy[name] = ({"n": int(e.size), "median": float(np.median(e)),
                           "p90": float(np.percentile(e, 90)), "max": float(e.max())}
                          if e.size else {"n": 0})
    # the shipped emulator: weights on all points
    return refit_weights(gp_sub, x, f, mask), accuracy


def refit_weights(gp: MultiOutputGP, x: np.ndarray, y: np.ndarray, mask: np.ndarray, *,
                  keep_factor: bool = False) -> MultiOutputGP:
    """The same kernel and linear means solved on new data (without the Cholesky factor
    of the predictive variance unless ``keep_factor``: an emulator needs its mean only,
    and the factor of 2,000 designs would be 30 MB in the package)."""
    from scipy.linalg import cho_factor, cho_solve

    from multimorph.calibrated._gp import matern52

    n, m = y.shape
    A = np.column_stack([np.ones(n), x])
    resid = (y - A @ gp.coef) / gp.scale
    K = matern52(x, x, gp.length) + gp.noise * np.eye(n)
    c = cho_factor(K, lower=True)
    weights = np.zeros((n, m))
    for j in range(m):
        weights[:, j] = cho_solve(c, np.where(mask[:, j], resid[:, j], 0.0))
    return MultiOutputGP(x=x, length=gp.length, noise=gp.noise, mask=mask, weights=weights,
                         coef=gp.coef, scale=gp.scale,
                         chol=np.linalg.cholesky(K) if keep_factor else np.zeros((0, 0)))


#: Wall laws the Ritz emulators stand for (cells of other laws trace the Ritz model).
EMULATED_LAWS = ("gent",)


def emulable(cell: Any) -> bool:
    """Whether the Ritz emulator stands for ``cell`` (wall and bottom in :data:`EMULATED_LAWS`)."""
    c = cell.cell if hasattr(cell, "tilt") else cell
    return (c.material.model in EMULATED_LAWS and c.bottom_material is not None
            and c.bottom_material.model in EMULATED_LAWS)


def emulated_features(emu: MultiOutputGP, box: Box, cells: list[Any],
                      exact: np.ndarray) -> np.ndarray:
    """The emulator's Ritz features for the cells it stands for (the exact ones for others),
    one prediction for the batch."""
    out = np.array(exact, float)
    rows = [i for i, cell in enumerate(cells) if emulable(cell)]
    if rows:
        groups = np.array([[cell_groups(cells[i])[n] for n in box.names] for i in rows])
        out[rows] = emu.predict(box.scaled(groups))[:, :4]
    return out


#: Where :func:`fit_and_save` keeps each GP of a kind as soon as it is fitted, so that an
#: interrupted refit (a bending refit runs 1.5-2 h on 2 cores) resumes from the GPs it had:
#: ``$MULTIMORPH_FIT_RESUME``, default ``~/.cache/multimorph/fit-resume``. A file is re-used
#: only for the same training data, box, variant and fitting code (:func:`fit_fingerprint`);
#: the files of a fit are removed once its model is written.
FIT_RESUME_ENV = "MULTIMORPH_FIT_RESUME"


def fit_resume_folder() -> Path:
    """The folder of :data:`FIT_RESUME_ENV`."""
    value = os.environ.get(FIT_RESUME_ENV, "")
    return Path(value) if value else Path.home() / ".cache" / "multimorph" / "fit-resume"


def fit_fingerprint(data: TrainingData, box: Box, prefix: str,
                    extra: tuple[np.ndarray, ...] = ()) -> str:
    """A key of what a kind's GPs are fitted from: its training data (groups, features,
    grid values and masks, split, anchors, end levels, censoring, straight features), its
    box, the variant (``prefix``), any ``extra`` arrays they read (a one-part refit: the
    shipped feature scaling) and the source of the fitting code (this module, :mod:`._gp`
    and :mod:`._box`, whose derived inputs the GPs read)."""
    import inspect

    h = hashlib.sha256(repr((data.kind, prefix, box.names, box.derived)).encode())
    for a in (data.groups, data.features, data.y, data.mask, data.holdout, data.anchors,
              data.end, data.censor, data.straight, box.low, box.high, *extra):
        if a is None:
            h.update(b"-")
            continue
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype}{a.shape}".encode())
        h.update(a.tobytes())
    for module_file in (__file__, inspect.getsourcefile(fit_gp), inspect.getsourcefile(Box)):
        h.update(Path(str(module_file)).read_bytes())
    return h.hexdigest()[:20]


def resumable(folder: Path, key: str, part: str, fit: Callable[[], dict[str, Any]],
              ) -> dict[str, Any]:
    """``fit()`` (a dict of :class:`MultiOutputGP` and arrays), or what an earlier call
    with the same ``key`` and ``part`` saved in ``folder``; saved there (atomically) after
    fitting. A file that cannot be read is fitted again."""
    path = folder / f"{key}-{part}.npz"
    if path.exists():
        try:
            with np.load(path, allow_pickle=False) as z:
                stored = {k: z[k] for k in z.files}
            names = json.loads(str(stored.pop("__names__")))
            out: dict[str, Any] = {}
            for name, what in names.items():
                out[name] = (MultiOutputGP.from_arrays(stored, f"{name}/") if what == "gp"
                             else stored[name])
            _log(f"{part} GP(s) re-used from an interrupted fit ({path.name})")
            return out
        except (OSError, ValueError, KeyError) as exc:
            _log(f"{part}: {path.name} unreadable ({exc}); fitting it again")
    out = fit()
    flat: dict[str, np.ndarray] = {}
    names = {}
    for name, value in out.items():
        if isinstance(value, MultiOutputGP):
            flat.update(value.to_arrays(f"{name}/"))
            names[name] = "gp"
        else:
            flat[name] = np.asarray(value)
            names[name] = "array"
    flat["__names__"] = np.array(json.dumps(names))
    folder.mkdir(parents=True, exist_ok=True)
    tmp = folder / f".{key}-{part}.tmp.npz"
    np.savez(tmp, **flat)
    os.replace(tmp, path)
    return out


def _fit_one(kind: str, data: TrainingData, prefix: str, arrays: dict[str, np.ndarray],
             manifest: dict[str, Any], resume_keys: set[str] | None = None) -> None:
    """Fit one kind's GP on ``data`` and store it under ``prefix`` (unless too few designs)."""
    kf = data_features(data)
    train = ~data.holdout & np.all(np.isfinite(kf), axis=1)
    n_inputs = (len(GROUP_NAMES[kind]) + len(DERIVED_INPUTS.get(kind, ())) + kf.shape[1]
                + (end_column(data) is not None))
    if train.sum() < MIN_DESIGNS_PER_INPUT * n_inputs:
        _log(f"{kind}: only {int(train.sum())} training designs for {n_inputs} inputs "
             f"(at least {MIN_DESIGNS_PER_INPUT * n_inputs}); not fitted")
        return
    box = replace(Box.from_spec(kind, reference_spec(KIND_SETS[kind][0])),
                  derived=DERIVED_INPUTS.get(kind, ()))
    label = f"{kind}{' (fast)' if prefix else ''}"
    t0 = time.monotonic()

    def done(part: str) -> None:
        # a refit of the bending kind takes 1.5-2 h: say where it is (stop 57)
        _log(f"{label}: {part} fitted on {int(train.sum())} designs, "
             f"{(time.monotonic() - t0) / 60:.1f} min")

    folder = fit_resume_folder()
    key = fit_fingerprint(data, box, prefix)
    if resume_keys is not None:
        resume_keys.add(key)

    def path_gp() -> dict[str, Any]:
        gp, fmean, fstd = fit_kind(data, box)
        return {"gp": gp, "fmean": fmean, "fstd": fstd}

    got = resumable(folder, key, "path", path_gp)
    gp, fmean, fstd = got["gp"], got["fmean"], got["fstd"]
    done("path GP")
    pgp = resumable(folder, key, "pressure", lambda: {
        "gp": fit_pressure(data, box, fmean, fstd, train=train)})["gp"]
    done("pressure GP")
    p = f"{prefix}{kind}/"
    arrays.update(gp.to_arrays(p))
    arrays.update(pgp.to_arrays(f"{p}pressure/"))
    sgp = (resumable(folder, key, "signal", lambda: {
        "gp": fit_signal(data, box, fmean, fstd, train=train)})["gp"]
        if kind in SIGNAL_KINDS else None)
    if sgp is not None:
        arrays.update(sgp.to_arrays(f"{p}signal/"))
        done("signal GP")
    lgp = (resumable(folder, key, "log_signal", lambda: {
        "gp": fit_log_signal(data, box, fmean, fstd, train=train)})["gp"]
        if kind in LOG_SIGNAL_KINDS else None)
    if lgp is not None:
        arrays.update(lgp.to_arrays(f"{p}log_signal/"))
        done("log signal GP")
    anchors = resumable(folder, key, "anchors",
                        lambda: dict(fit_anchors(data, box, fmean, fstd, train=train)))
    done("anchor GPs")
    for name, agp in anchors.items():
        arrays.update(agp.to_arrays(f"{p}anchor_{name}/"))
    arrays[f"{p}feature_mean"] = fmean
    arrays[f"{p}feature_std"] = fstd
    if end_column(data) is not None:
        arrays[f"{p}end_input"] = np.array([1.0])   # predict as mirror ends
    if data.straight is not None:
        arrays[f"{p}straight_end"] = np.array([0.0])  # plate: as the tilted FE cells
    arrays[f"{p}box_low"] = box.low
    arrays[f"{p}box_high"] = box.high
    manifest[kind] = {
        "sets": list(KIND_SETS[kind]), "training_designs": int(train.sum()),
        "held_out": int(data.holdout.sum()), "length_scales": gp.length.round(4).tolist(),
        "pressure_length_scales": pgp.length.round(4).tolist(),
        "pressure": _pressure_info(data, train, pgp),
        **({"signal": _signal_info(int(train.sum()), sgp, kind)} if sgp is not None else {}),
        **({"log_signal": _signal_info(int(train.sum()), lgp, kind, True)}
           if lgp is not None else {}),
        "noise": gp.noise, "groups": list(GROUP_NAMES[kind]),
        **({"derived_inputs": list(box.derived)} if box.derived else {}),
        **({"straight_features": list(data.straight_names)} if data.straight is not None
           else {}),
        "features": ("emulated" if prefix else "ritz") if data.straight is None else (
            "the straight cell's calibrated " + ", ".join(STRAIGHT_FEATURES)
            + " (plate level) and the "
            + ("emulated" if prefix else "Ritz") + " strip-shear rule"),
        "end_input": ("plate 0, mirror 1; predicted at 1" if end_column(data) is not None
                      else None),
        "anchors": _anchor_info(anchors, kind),
        "box": {n: [float(lo), float(hi)] for n, lo, hi in
                zip(box.names, box.low, box.high, strict=True)}}
    _log(f"{kind}{' (fast)' if prefix else ''}: fitted on {int(train.sum())} designs")


#: ``straight_of(arrays, manifest, data, fast)``: the tilted training cells'
#: :data:`STRAIGHT_FEATURES` from the bending kind fitted so far (``_model.straight_of``)
StraightOf = Callable[[dict[str, np.ndarray], dict[str, Any], "TrainingData", bool], np.ndarray]


def fit_and_save(*, emulators: bool = False, kinds: tuple[str, ...] | None = None,
                 straight_of: StraightOf | None = None) -> None:
    """Fit every kind from the shipped data; write model.npz and model.json.

    The model ("calibrated") computes every cell's Ritz features with the Ritz model at run
    time (one batched Ritz trace per batch of cells: the cost of the Ritz model itself).
    With ``emulators``, the Ritz-feature emulators are fitted on the Ritz table and every
    kind is fitted a second time on emulated features: the fast variant
    ("calibrated-fast": no Ritz trace, less accurate where the emulator is off).

    ``kinds``: refit only these kinds into the shipped model, keeping the others and its
    emulators (a twisting kind reads the bending kind: refitting bending refits one the
    model has). Without it, the :data:`DEFAULT_KINDS` into a new model. ``straight_of``
    gives a twisting kind its straight-cell features (without it: Ritz features).
    """
    from multimorph._provenance import code_version

    t0 = time.monotonic()
    sets = load_reference()
    resume_keys: set[str] = set()    # the GPs kept for a resume (:func:`resumable`)
    arrays: dict[str, np.ndarray] = {"t_grid": T_GRID}
    manifest: dict[str, Any] = {"format": "multimorph-calibrated-model/1",
                                "code_version": code_version(), "kinds": {},
                                "emulators": {}, "fast_kinds": {}}
    emus: dict[str, tuple[MultiOutputGP, Box]] = {}
    todo = DEFAULT_KINDS
    if kinds is not None:
        unknown = sorted(set(kinds) - set(KIND_SETS))
        if unknown:
            raise ValueError(f"fit model --kinds: unknown kind(s) {unknown}; expected some "
                             f"of {list(KIND_SETS)}")
        had = json.loads(MODEL_MANIFEST.read_text()).get("kinds", {})
        todo = tuple(k for k in KIND_SETS if k in kinds
                     or (k == "twisting" and "bending" in kinds and k in had))
        with np.load(MODEL_FILE, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files
                      if not any(k.startswith((f"{kd}/", f"fast/{kd}/")) for kd in todo)}
        manifest = json.loads(MODEL_MANIFEST.read_text())
        manifest["code_version"] = code_version()
        for key in ("kinds", "fast_kinds"):
            manifest[key] = {k: v for k, v in manifest.get(key, {}).items() if k not in todo}
        for family in manifest.get("emulators", {}):
            emus[family] = (MultiOutputGP.from_arrays(arrays, f"emulator/{family}/"),
                            Box.from_spec(family, reference_spec(family)))
    elif emulators:
        from multimorph.calibrated._ritz_table import load_ritz_table

        for family, tab in load_ritz_table().items():
            box = Box.from_spec(family, reference_spec(family))
            emu, accuracy = fit_emulator(family, tab, box)
            emus[family] = (emu, box)
            arrays.update(emu.to_arrays(f"emulator/{family}/"))
            manifest["emulators"][family] = {
                "designs": len(emu.x), "outputs": list(EMULATOR_OUTPUTS),
                "length_scales": emu.length.round(4).tolist(), "test_error": accuracy}
            _log(f"emulator {family}: {len(emu.x)} Ritz designs; test error (median, p90): "
                 + ", ".join(f"{k} {v['median']:.3g} {v['p90']:.3g}"
                             for k, v in accuracy.items() if v.get("n")))
    for kind in todo:
        if not any(s in sets for s in KIND_SETS[kind]):
            continue
        data = fe_training_data(kind, sets)
        variants = [("", data)]
        if FAMILY[kind] in emus:
            # the fast variant learns on the features it will be given at run time: the
            # emulator's (exact ones only for the cells of other laws, which it traces)
            variants.append(("fast/", replace(data, features=emulated_features(
                *emus[FAMILY[kind]], data.cells, data.features))))
        for prefix, d in variants:
            if (kind == "twisting" and straight_of is not None
                    and "bending" in manifest["fast_kinds" if prefix else "kinds"]):
                d = replace(d, straight=straight_of(arrays, manifest, d, bool(prefix)))
            _fit_one(kind, d, prefix, arrays,
                     manifest["fast_kinds" if prefix else "kinds"], resume_keys)
    manifest["fit_time_s"] = round(time.monotonic() - t0, 1)
    tmp = MODEL_FILE.with_name(f".{MODEL_FILE.stem}.tmp.npz")
    np.savez_compressed(tmp, **arrays)
    os.replace(tmp, MODEL_FILE)
    MODEL_MANIFEST.write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    _log(f"wrote {MODEL_FILE} in {manifest['fit_time_s']} s")
    folder = fit_resume_folder()
    for key in resume_keys:         # the model holds them now
        for done in folder.glob(f"{key}-*.npz"):
            done.unlink(missing_ok=True)


def finite_log(x: float) -> float:
    return math.log(x) if x > 0 else -math.inf
