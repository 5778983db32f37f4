"""The calibrated cell model at run time: groups → Ritz features → FE-trained GP → path.

:class:`CalibratedModel` loads ``data/model.npz`` (written by
``python -m multimorph.calibrated.fit model``) and predicts, for any valid cell, the whole
equilibrium path that the project's 3D FE would give — pressure, signal (κd, axial stretch
or strip shear), largest stretch and axial strain against the chamber volume — and from it
the shared :class:`~multimorph.response.Response` (observed curves, Pc, Ph, failure) with
``backend = "calibrated"``.

It knows its support: a cell whose groups lie outside the calibrated box, or whose wall is
not in the data set's law family in a way it cannot place (see ``_law`` and
``equivalent_jm``), is
answered by the Ritz model with ``meta["calibration"]["inside"] = False`` and the groups
that are outside, and a warning (:class:`CalibrationWarning`). Every prediction carries an
uncertainty: the GP's predictive standard deviation of log P, turned into a range of Pc.
"""

from __future__ import annotations

import copy
import json
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from multimorph.calibrated._anchor import (
    MAX_FACTOR,
    PATH_WEIGHT,
    anchored_characteristic,
    max_factor,
)
from multimorph.calibrated._box import Box, cell_groups, equivalent_jm
from multimorph.calibrated._fit import (
    ANCHORS,
    FAMILY,
    MODEL_FILE,
    MODEL_MANIFEST,
    STRAIGHT_FEATURES,
    STRAIGHT_FEATURES_V1,
    kind_features,
    model_inputs,
)
from multimorph.calibrated._fit import (
    emulable as is_emulable,
)
from multimorph.calibrated._gp import MultiOutputGP, lower_solve, matern52
from multimorph.calibrated._law import (
    KNEELESS_KINDS,
    law_shape,
    membrane_limit_point,
    wall_activates,
)
from multimorph.calibrated._representation import QUANTITIES, T_GRID, kind_of, paths_from_grid
from multimorph.errors import MultimorphError, OutsideSupportError, SpecError
from multimorph.geometry import CellGeometry, TiltedCell
from multimorph.response import EquilibriumPath, Response, build_response

__all__ = ["ANCHOR_RANGE_FACTOR", "SUPPORT_CORRELATION", "CalibratedModel", "CalibrationWarning",
           "load_model"]

#: A grid volume is supported for a design when some training design that reached it is
#: this correlated with it (kernel value); beyond the last supported volume the predicted
#: path ends (the FE data set does not say what happens there for such a cell).
SUPPORT_CORRELATION = 0.3
#: The FE reference data were traced to this multiple of each design's Ritz Pc (the data
#: set specs' ``pmax_factor``): the calibrated path ends there too (beyond it the model
#: would extrapolate in pressure).
DATA_PMAX_FACTOR = 0.85
#: The fast variant estimates that data range from the *emulated* Ritz Pc, which on a few
#: cells is far below the Ritz model's own (stop 48: `bending_softbottom_mirror` #28, 8.7
#: against 42.1 kPa; `bending_lowjm_mirror` #45, 20.0 against 76.7 kPa), cutting the path
#: before its activation (its anchors beyond the path, unused; the path's reading a wrong
#: early one). The FE data reach 0.85 × the Ritz Pc, which is 1.7–2.9 × FE's Pc on the
#: data set (the Ritz model is 2–3.4 × as stiff), so the fast path's data range is at
#: least this multiple of the cell's Pc anchor.
ANCHOR_RANGE_FACTOR = 1.7


class CalibrationWarning(UserWarning):
    """A cell outside the calibrated model's support: answered by the Ritz model."""


def _anchor_prediction(gps: dict[str, MultiOutputGP], name: str, x: np.ndarray,
                       pc: tuple[np.ndarray, np.ndarray] | None = None, std: bool = True,
                       ) -> tuple[np.ndarray, np.ndarray]:
    """An anchor's predicted log(P/μ) and its std at inputs ``x``: its GP's, or the mean of
    its members, with the std of their equal mixture (each one's variance and their
    spread about the mean). The members: its GP; a cross-validated twin (``<name>_cv``,
    ``_fit.ANCHOR_CV``); for Ph, the Pc anchor's prediction plus a GP of log(Ph / Pc)
    (``ph_ratio``, ``_fit.ANCHOR_RATIO``; its variance the sum of the two), the Pc
    prediction ``pc`` where the caller has it already (else predicted here). Without
    ``std`` the mean alone (the same to the bit; the std NaN): no variance solves."""

    def predict(gp: MultiOutputGP) -> tuple[np.ndarray, np.ndarray]:
        if std:
            m, sd = gp.predict(x, std=True)
            return m[:, 0], sd[:, 0]
        return gp.predict(x)[:, 0], np.full(len(x), np.nan)

    members = [predict(gps[name])]
    twin = gps.get(f"{name}_cv")
    if twin is not None:
        members.append(predict(twin))
    ratio = gps.get(f"{name}_ratio")
    if ratio is not None and name == "ph" and "pc" in gps:
        pc_m, pc_sd = pc if pc is not None else _anchor_prediction(gps, "pc", x, std=std)
        r, r_sd = predict(ratio)
        members.append((pc_m + r, np.sqrt(pc_sd ** 2 + r_sd ** 2)))
    if len(members) == 1:
        return members[0]
    means = np.array([mm for mm, _ in members])
    mean = means.mean(axis=0)
    var = (np.mean([ss ** 2 for _, ss in members], axis=0)
           + np.mean((means - mean) ** 2, axis=0))
    return mean, np.sqrt(var)


@dataclass(frozen=True, eq=False)
class _Kind:
    kind: str
    gp: MultiOutputGP
    box: Box
    fmean: np.ndarray
    fstd: np.ndarray
    #: the anchor GPs (log Pc/μ, log Ph/μ of FE) by name (and a cross-validated twin,
    #: ``<name>_cv``, where ``_fit.ANCHOR_CV`` names the kind, and ``ph_ratio`` where
    #: ``_fit.ANCHOR_RATIO`` does); empty in an older model file
    anchors: dict[str, MultiOutputGP]
    #: log(P/μ) on the grid with a kernel of its own (``_fit.fit_pressure``); None in an
    #: older model file (the path GP's pressure then)
    pressure: MultiOutputGP | None = None
    #: the GPs take the end condition as an input (``_fit.end_column``): the value the
    #: model predicts at (1.0, mirror ends: the cell as inside a module); None: no such input
    end_input: float | None = None
    #: tilted cells on their straight cell's features (``_fit.STRAIGHT_FEATURES``): the end
    #: level the straight cell is read at (0.0: plate, as the tilted FE); None: Ritz features
    straight_end: float | None = None
    #: the signal over t on the grid with a kernel of its own fitted past the snap
    #: (``_fit.fit_signal``, stop 40); None: the path GP's signal
    signal: MultiOutputGP | None = None
    #: its weight in the run-time signal (the rest: the path GP's and the log signal GP's)
    signal_weight: float = 1.0
    #: log(y_t) on the grid with the signal GP's kernel form (``_fit.fit_log_signal``,
    #: stop 55; tilted cells), and its weight in the run-time signal (exp of it); None: none
    log_signal: MultiOutputGP | None = None
    log_signal_weight: float = 0.0
    #: the straight features it reads (``_fit.STRAIGHT_FEATURES``, named in the manifest
    #: since stop 62; a model fitted before reads ``_fit.STRAIGHT_FEATURES_V1``)
    straight_names: tuple[str, ...] = ()


@dataclass(frozen=True, eq=False)
class GridPrediction:
    """Grid predictions of a batch of same-kind cells (see :meth:`CalibratedModel.grid`)."""

    kind: str
    values: np.ndarray        # (n, J, Q)
    std_log_p: np.ndarray     # (n, J): predictive std of log(P/μ)
    t_end: np.ndarray         # (n,): the last supported log volume ratio
    p_end: np.ndarray         # (n,): the last supported pressure (Pa; inf: no bound)
    inside: np.ndarray        # (n,) bool
    outside: list[dict[str, tuple[float, float, float]]]
    #: anchors: predicted log(Pc/μ), log(Ph/μ) (n, 2) and their predictive std (NaN: none)
    anchors: np.ndarray | None = None
    anchor_std: np.ndarray | None = None
    #: the path GP's predictive std of the signal over t, ``values[:, :, 1]`` (n, J)
    std_signal: np.ndarray | None = None


class CalibratedModel:
    """The fitted calibrated cell model (see the module docstring)."""

    def __init__(self, arrays: Any, manifest: dict[str, Any]) -> None:
        self.manifest = manifest
        self.t_grid = np.asarray(arrays["t_grid"], float)
        if not np.allclose(self.t_grid, T_GRID):
            raise MultimorphError("calibrated model: its volume grid is not this code's; refit "
                                  "it (python -m multimorph.calibrated.fit model)")
        self.kinds: dict[str, _Kind] = {}
        self.fast_kinds: dict[str, _Kind] = {}
        for key, into, prefix in (("kinds", self.kinds, ""),
                                  ("fast_kinds", self.fast_kinds, "fast/")):
            for kind, info in manifest.get(key, {}).items():
                p = f"{prefix}{kind}/"
                box = Box(kind, tuple(info["groups"]), np.asarray(arrays[f"{p}box_low"]),
                          np.asarray(arrays[f"{p}box_high"]),
                          tuple(info.get("derived_inputs", ())))
                anchors = {name: MultiOutputGP.from_arrays(arrays, f"{p}anchor_{name}/")
                           for a in ANCHORS for name in (a, f"{a}_cv", f"{a}_ratio")
                           if f"{p}anchor_{name}/x" in arrays}
                pressure = (MultiOutputGP.from_arrays(arrays, f"{p}pressure/")
                            if f"{p}pressure/x" in arrays else None)
                signal, log_signal = (MultiOutputGP.from_arrays(arrays, f"{p}{name}/")
                                      if f"{p}{name}/x" in arrays else None
                                      for name in ("signal", "log_signal"))
                end, straight_end = (float(np.asarray(arrays[f"{p}{name}"])[0])
                                     if f"{p}{name}" in arrays else None
                                     for name in ("end_input", "straight_end"))
                into[kind] = _Kind(kind, MultiOutputGP.from_arrays(arrays, p), box,
                                   np.asarray(arrays[f"{p}feature_mean"]),
                                   np.asarray(arrays[f"{p}feature_std"]), anchors, pressure,
                                   end, straight_end, signal,
                                   float(info.get("signal", {}).get("weight", 1.0)),
                                   log_signal,
                                   float(info.get("log_signal", {}).get("weight", 0.0)),
                                   tuple(info.get("straight_features", STRAIGHT_FEATURES_V1))
                                   if straight_end is not None else ())
        #: the tilted cells' calibrated strip-shear factor on the Ritz rule (``_shear``)
        self.twisting_shear: dict[str, Any] | None = manifest.get("twisting_shear")
        #: how a wall of another law is placed (``_law``; None: the closest Gent wall)
        self.law_map: dict[str, Any] | None = manifest.get("law_map")
        self.emulators = {fam: MultiOutputGP.from_arrays(arrays, f"emulator/{fam}/")
                          for fam in manifest.get("emulators", {})}
        self.emulator_boxes = {}
        for fam in self.emulators:
            from multimorph.calibrated._dataset import reference_spec

            self.emulator_boxes[fam] = Box.from_spec(fam, reference_spec(fam))

    # ------------------------------------------------------------------ laws
    def placed(self, cell: CellGeometry | TiltedCell
               ) -> tuple[CellGeometry | TiltedCell, dict[str, Any] | None]:
        """``cell`` as the model answers it — each non-Gent elastomer replaced by its
        effective Gent wall where the law map places it (``_law``) — and how each
        non-Gent elastomer was placed (None for Gent walls)."""
        from multimorph.calibrated._law import effective_cell

        out, info = effective_cell(cell, self.law_map)
        c = out.cell if isinstance(out, TiltedCell) else out
        if c.material.model != "gent":    # not placed by the map: its closest Gent Jm
            info = {**(info or {}), "wall": {
                "model": c.material.model, "rule": "closest Gent wall (uniaxial, λ ≤ 3)",
                "mu_factor": 1.0, "effective_jm": equivalent_jm(c.material)}}
        return out, info

    # ------------------------------------------------------------------ support
    def support(self, cell: CellGeometry | TiltedCell) -> dict[str, Any]:
        """``{"inside": bool, "kind": ..., "outside": {group: [value, low, high]}, "reason"}``."""
        kind = kind_of(cell)
        if kind not in self.kinds:
            return {"inside": False, "kind": kind, "outside": {},
                    "reason": f"no calibration for {kind} cells yet"}
        placed, law = self.placed(cell)
        groups = cell_groups(placed)
        out = self.kinds[kind].box.outside(groups)
        wall = (law or {}).get("wall") or {}
        # a wall of another law enters as an effective Gent wall: say whose Jm that is
        via = {"jm": f"the Jm of the Gent wall closest to its {wall['model']} wall; "} if (
            wall.get("model") and wall.get("rule", "").startswith("closest Gent")) else {}
        return {"inside": not out, "kind": kind,
                "outside": {k: list(v) for k, v in out.items()},
                "reason": "" if not out else "groups outside the calibrated box: " + ", ".join(
                    f"{k} = {v[0]:.4g} ({via.get(k, '')}calibrated {v[1]:.4g} … {v[2]:.4g})"
                    for k, v in out.items())}

    # ------------------------------------------------------------------ features
    def _features(self, kind: str, cells: Sequence[CellGeometry | TiltedCell],
                  groups: np.ndarray, fast: bool = False,
                  gdicts: Sequence[dict[str, float]] | None = None,
                  ) -> tuple[np.ndarray, np.ndarray]:
        fam = FAMILY[kind]
        if gdicts is None:
            gdicts = [cell_groups(c) for c in cells]
        straight = [c.cell if isinstance(c, TiltedCell) else c for c in cells]
        emulable = np.array([is_emulable(c) for c in straight])
        feats = np.full((len(cells), 4), np.nan)
        p_end = np.full(len(cells), np.inf)
        if not fast or fam not in self.emulators:
            emulable[:] = False
        if emulable.any():
            ebox = self.emulator_boxes[fam]
            fam_groups = np.array([[g[n] for n in ebox.names]
                                   for g, e in zip(gdicts, emulable, strict=True) if e])
            pred = self.emulators[fam].predict(ebox.scaled(fam_groups))
            feats[emulable] = pred[:, :4]
            if pred.shape[1] > 4:  # the emulated Ritz Pc bounds the data, as the exact one
                mus = np.array([c.mu for c, e in zip(straight, emulable, strict=True) if e])
                p_end[emulable] = DATA_PMAX_FACTOR * np.exp(pred[:, 4]) * mus
        if (~emulable).any():
            from multimorph.calibrated._ritz import ritz_features_and_pc

            exact, pcs = ritz_features_and_pc([c for c, e in zip(cells, emulable, strict=True)
                                               if not e])
            feats[~emulable] = exact
            p_end[~emulable] = np.where(np.isfinite(pcs), DATA_PMAX_FACTOR * pcs, np.inf)
        tilts = (np.array([abs(c.tilt) for c in cells]) if kind == "twisting" else None)
        straight = None
        k = (self.fast_kinds if fast else self.kinds).get(kind)
        if k is not None and k.straight_end is not None:
            straight = self.straight_features(cells, k.straight_end, fast, k.straight_names)
        return kind_features(kind, feats, tilts, straight), p_end

    def straight_features(self, cells: Sequence[CellGeometry | TiltedCell], end: float,
                          fast: bool = False,
                          names: Sequence[str] = STRAIGHT_FEATURES) -> np.ndarray:
        """The tilted cells' straight features ``names`` (n, len(names);
        :data:`~._fit.STRAIGHT_FEATURES`): their straight cells' bending-kind prediction at
        the end level ``end`` (NaN outside its box)."""
        from multimorph.calibrated._fit import straight_features

        straight = [c.cell if isinstance(c, TiltedCell) else c for c in cells]
        return straight_features(self.bending_at(end).grid(straight, fast=fast, full=False),
                                 names)

    def _straight_names(self) -> tuple[str, ...]:
        """The straight features the twisting kind reads (its manifest's names)."""
        k = self.kinds.get("twisting") or self.fast_kinds.get("twisting")
        return k.straight_names if k is not None else ()

    def bending_at(self, end: float) -> CalibratedModel:
        """This model with its bending kind (both variants) answering at the end level
        ``end`` (0 plate, 1 mirror); itself where the kind has no end input or is there."""
        out = self
        for attr in ("kinds", "fast_kinds"):
            kinds = getattr(self, attr)
            b = kinds.get("bending")
            if b is not None and b.end_input is not None and b.end_input != end:
                if out is self:
                    out = copy.copy(self)
                setattr(out, attr, {**kinds, "bending": replace(b, end_input=float(end))})
        return out

    # ------------------------------------------------------------------ grid
    def grid(self, cells: Sequence[CellGeometry | TiltedCell], *,
             fast: bool = False, full: bool = True) -> GridPrediction:
        """Grid predictions for cells of one kind (inside or not: see ``inside``); ``fast``:
        the variant on emulated Ritz features (no Ritz trace). ``full=False``: only what a
        tilted cell reads of its straight cell (:func:`~._fit.straight_features`): the grid
        values and the Pc anchor, the same to the bit; no predictive std, support or Ph
        (NaN there; ``anchor_std`` None). A tilted cell's straight features took 3.5 of
        its 7.5 ms with the variance solves computed and thrown away (docs/validation.md
        §4 stop 62)."""
        kinds = {kind_of(c) for c in cells}
        if len(kinds) != 1:
            raise MultimorphError("calibrated model: grid() takes cells of one kind")
        kind = kinds.pop()
        k = (self.fast_kinds if fast else self.kinds)[kind]
        cells = [self.placed(c)[0] for c in cells]
        gdicts = [cell_groups(c) for c in cells]
        groups = np.array([k.box.values_of(g) for g in gdicts])
        outside = [k.box.outside(g) for g in gdicts]
        inside = np.array([not o for o in outside])
        # Ritz features (a Ritz trace each) only for the cells inside the box: the others
        # are answered by the fallback and their features would be thrown away
        kf = np.full((len(cells), len(k.fmean)), np.nan)
        p_end = np.full(len(cells), np.inf)
        rows = np.flatnonzero(inside)
        if rows.size:
            kf[rows], p_end[rows] = self._features(kind, [cells[i] for i in rows],
                                                   groups[rows], fast,
                                                   [gdicts[i] for i in rows])
        # a cell whose Ritz path does not reach the feature volumes has no inputs: it is
        # answered like a cell outside the box (see responses)
        inside &= np.all(np.isfinite(kf), axis=1)
        kf = np.where(np.isfinite(kf), kf, k.fmean)
        x = model_inputs(k.box, groups, kf, k.fmean, k.fstd, k.end_input)
        nq = len(QUANTITIES[kind])
        J = len(T_GRID)
        ks = matern52(x, k.gp.x, k.gp.length)
        lin = np.column_stack([np.ones(len(x)), x]) @ k.gp.coef
        mean = lin + (ks @ k.gp.weights) * k.gp.scale
        values = mean.reshape(len(x), J, nq)
        std_log_p = std_signal = np.full((len(x), J), np.nan)
        if full:
            v = lower_solve(k.gp.chol, ks.T)
            rel = np.sqrt(np.maximum(1.0 + k.gp.noise - np.sum(v * v, axis=0), k.gp.noise))
            std_log_p = rel[:, None] * k.gp.scale.reshape(J, nq)[None, :, 0]
            std_signal = rel[:, None] * k.gp.scale.reshape(J, nq)[None, :, 1]
        if k.pressure is not None:
            if full:
                values[:, :, 0], std_log_p = k.pressure.predict(x, std=True)
            else:
                values[:, :, 0] = k.pressure.predict(x)
        if k.signal is not None or k.log_signal is not None:
            # the run-time signal: the path GP's, the signal GP's and exp of the log signal
            # GP's, weighted (``_fit.SIGNAL_WEIGHT``, ``_fit.LOG_SIGNAL_WEIGHT``)
            w = float(k.signal_weight) if k.signal is not None else 0.0
            wl = float(k.log_signal_weight) if k.log_signal is not None else 0.0
            sig = (1.0 - w - wl) * values[:, :, 1]
            if k.signal is not None:
                sig += w * k.signal.predict(x)
            if k.log_signal is not None:
                sig += wl * np.exp(k.log_signal.predict(x))
            values[:, :, 1] = sig
        t_end = np.full(len(x), np.nan)
        if full:
            # support: the largest grid volume whose training designs include a close one
            best = _best_reaching(ks, k.gp.mask.reshape(len(k.gp.x), J, nq)[:, :, 0])
            ok = best >= SUPPORT_CORRELATION
            last = np.where(ok.any(axis=1), J - 1 - np.argmax(ok[:, ::-1], axis=1), 0)
            t_end = T_GRID[last]
        anchors = anchor_std = None
        if k.anchors:
            anchors = np.full((len(x), len(ANCHORS)), np.nan)
            anchor_std = np.full_like(anchors, np.nan) if full else None
            done: dict[str, tuple[np.ndarray, np.ndarray]] = {}
            for j, name in enumerate(ANCHORS if full else ("pc",)):
                # Pc first: Ph's ratio member reads it
                if name in k.anchors:
                    done[name] = _anchor_prediction(k.anchors, name, x, done.get("pc"),
                                                    std=full)
                    anchors[:, j] = done[name][0]
                    if anchor_std is not None:
                        anchor_std[:, j] = done[name][1]
        return GridPrediction(kind, values, std_log_p, t_end, p_end, inside, outside,
                              anchors, anchor_std, std_signal)

    # ------------------------------------------------------------------ responses
    def responses(self, cells: Sequence[CellGeometry | TiltedCell], p_max: float, *,
                  fallback: bool = True, fast: bool = False) -> list[Response | Exception]:
        """A :class:`Response` per cell (Ritz fallback with a warning outside the support;
        an exception instance for a cell that could not be answered). ``fast``: the variant
        on emulated Ritz features ("calibrated-fast"; :class:`MultimorphError` when the
        shipped model has none)."""
        if fast and not self.fast_kinds:
            raise MultimorphError("calibrated model: the shipped model has no fast variant "
                                  "(fit it with python -m multimorph.calibrated.fit model "
                                  "--emulators)")
        kinds = self.fast_kinds if fast else self.kinds
        p_max = float(p_max)
        if not (math.isfinite(p_max) and p_max > 0):
            raise SpecError(f"p_max must be a positive pressure, got {p_max!r} Pa")
        given = list(cells)
        placed = [self.placed(c) for c in given]
        cells = [c for c, _ in placed]
        out: list[Response | Exception] = [MultimorphError("not evaluated")] * len(cells)
        by_kind: dict[str, list[int]] = {}
        for i, c in enumerate(cells):
            by_kind.setdefault(kind_of(c), []).append(i)
        for kind, idx in by_kind.items():
            if kind == "twisting" and kind not in kinds:
                for i, r in zip(idx, self.tilted_by_straight(
                        [given[i] for i in idx], p_max,  # type: ignore[misc]
                        fallback=fallback, fast=fast), strict=True):
                    out[i] = r
                continue
            if kind not in kinds:
                for i in idx:
                    out[i] = self._fallback(given[i], p_max, {
                        "inside": False, "kind": kind, "outside": {},
                        "reason": f"no calibration for {kind} cells"}, fallback)
                continue
            pred = self.grid([cells[i] for i in idx], fast=fast)
            rows = [r for r in range(len(idx)) if pred.inside[r]]
            paths = dict(zip(rows, paths_from_grid(pred.values[rows], [cells[idx[r]]
                                                                        for r in rows],
                                                   pred.t_end[rows]), strict=True))
            if kind == "twisting":
                # a tilted cell outside the twisting kind's support: its straight cell's
                # calibrated answer (itself the Ritz model's outside the bending kind's)
                rest = [i for r, i in enumerate(idx) if not pred.inside[r]]
                for i, res in zip(rest, self.tilted_by_straight(
                        [given[i] for i in rest], p_max,  # type: ignore[misc]
                        fallback=fallback, fast=fast), strict=True):
                    out[i] = res
            for r, i in enumerate(idx):
                if not pred.inside[r] and kind == "twisting":
                    continue
                if not pred.inside[r]:
                    sup = self.support(given[i])
                    if sup["inside"]:  # in the box, but without Ritz features
                        sup = {**sup, "inside": False, "reason": (
                            "its Ritz path does not reach the volumes the model's features "
                            "are read at")}
                    out[i] = self._fallback(given[i], p_max, sup, fallback)
                    continue
                try:
                    res = self._response(cells[i], pred, r, p_max, paths[r], fast)
                except Exception as exc:  # kept per design, as other batch models do
                    out[i] = exc
                    continue
                law = placed[i][1]
                if law is not None:       # reported against the wall's own μ
                    g = given[i].cell if isinstance(given[i], TiltedCell) else given[i]
                    res = replace(res, shear_modulus=g.mu).with_meta(
                        calibration=self._law_bands(res, law))
                    shift = (self.law_map or {}).get("ph_shift") or {}
                    if (kind in shift.get("kinds", ()) and shift.get("log_factor")
                            and (law.get("wall") or {}).get("rule") == "yeoh-shape map"
                            and membrane_limit_point(g.material) is False):
                        res = _shifted_hardening(res, float(shift["log_factor"]))
                out[i] = res
        # a stretching or tilted cell of a wall whose membrane does not snap (``_law``)
        for i, res in enumerate(out):
            if (isinstance(res, Response) and kind_of(given[i]) in KNEELESS_KINDS
                    and str(res.meta.get("model", "")).startswith("calibrated")):
                g = given[i].cell if isinstance(given[i], TiltedCell) else given[i]
                if not wall_activates(g.material):
                    out[i] = _without_activation(res, g.material)
        _mark_unstable_laws(given, out)
        return out

    def _law_bands(self, res: Response, law: dict[str, Any]) -> dict[str, Any]:
        """``res``'s calibration record with how its walls were placed (``law``) and, for
        a wall the law map placed, its Pc and Ph bands widened by the map's own spread
        (``law_map["spread"]``: the GP's σ knows Gent walls only)."""
        from multimorph.calibrated._law import widen_band

        cal = {**res.meta["calibration"], "law": law}
        spread = (self.law_map or {}).get("spread") or {}
        mapped = any(w.get("rule") == "yeoh-shape map" for w in law.values())
        if mapped:
            ch = res.characteristic
            for key, value, name in (("critical_pressure_range", ch.critical, "pc"),
                                     ("hardening_pressure_range", ch.hardening, "ph")):
                sigma = float(spread.get(f"sigma_log_{name}", math.nan))
                if math.isfinite(sigma) and cal.get(key):
                    cal[key] = widen_band(value, list(cal[key]), sigma)
        return cal

    def tilted_by_straight(self, cells: Sequence[TiltedCell], p_max: float, *,
                           fallback: bool = True, fast: bool = False,
                           ) -> list[Response | Exception]:
        """Tilted cells answered by their straight cell (a model without a twisting kind,
        and with one the tilted cells outside its box; inside it a tilted cell is its own
        calibrated path since stop 41, :meth:`_tilted_shear`): the straight
        cell's calibrated response, read on the strip shear of
        the Ritz rule γ = ε sin 2β times the factor calibrated on the tilted FE cells
        (``_shear``). The straight cell is read at the plate level (since stop 34;
        :func:`._shear.plate_level`): a tilted cell is calibrated, and checked in the device
        FE, as one cell with its far end tied to a plate."""
        from multimorph.calibrated._shear import plate_level

        straight = plate_level(self).responses([c.cell for c in cells], p_max,
                                               fallback=fallback, fast=fast)
        return [r if isinstance(r, Exception) else _straight_for_tilted(
                    r, c, self.twisting_shear, cell_groups(self.placed(c)[0]))
                for c, r in zip(cells, straight, strict=True)]

    def response(self, cell: CellGeometry | TiltedCell, p_max: float) -> Response:
        """One cell's :class:`Response` (raises where it has none)."""
        r = self.responses([cell], p_max)[0]
        if isinstance(r, Exception):
            raise r
        return r

    def _fallback(self, cell: CellGeometry | TiltedCell, p_max: float, sup: dict[str, Any],
                  fallback: bool) -> Response | Exception:
        msg = (f"calibrated model: {sup['reason']}; "
               + ("answering with the Ritz model (about twice as stiff as FE)"
                  if fallback else "no prediction"))
        warnings.warn(msg, CalibrationWarning, stacklevel=3)
        if not fallback:
            return OutsideSupportError(msg)
        from multimorph.rom import solve_cell

        straight = cell.cell if isinstance(cell, TiltedCell) else cell
        try:
            r = solve_cell(straight, p_max)
        except Exception as exc:
            return exc
        cal = {"inside": False, "kind": sup["kind"], "outside": sup["outside"],
               "reason": sup["reason"], "fallback": "ritz"}
        return r.with_meta(model="ritz", calibration=cal)

    def _response(self, cell: CellGeometry | TiltedCell, pred: GridPrediction, r: int,
                  p_max: float, path: EquilibriumPath, fast: bool = False) -> Response:
        c = cell.cell if isinstance(cell, TiltedCell) else cell
        t_end = float(pred.t_end[r])
        p_data = float(pred.p_end[r])
        if fast and pred.anchors is not None and math.isfinite(pred.anchors[r, 0]):
            p_data = max(p_data, ANCHOR_RANGE_FACTOR * math.exp(pred.anchors[r, 0]) * c.mu)
        signal = {"bending": "curvature", "stretching": "axial_stretch",
                  "twisting": "twist_rate"}[pred.kind]
        shear: dict[str, Any] = {}
        if pred.kind == "twisting":
            path, shear = self._tilted_shear(cell, path, pred, r)  # type: ignore[arg-type]
        path, reached = _truncate(path, min(p_max, p_data))
        reached = reached and p_max <= p_data
        resp = build_response(path, length=c.length, shear_modulus=c.mu, backend="calibrated",
                              break_stretch=c.material.break_stretch, signal=signal)
        # Pc and Ph: the anchors where the path reaches them (see ._anchor)
        anchors: dict[str, Any] | None = None
        if pred.anchors is not None:
            pc_a, ph_a = (math.exp(v) * c.mu if math.isfinite(v) else None
                          for v in pred.anchors[r])
            sd = (None if pred.anchor_std is None
                  else (float(pred.anchor_std[r, 0]), float(pred.anchor_std[r, 1])))
            char, anchors = anchored_characteristic(resp, pc_a, ph_a, sd,
                                                    PATH_WEIGHT.get(pred.kind, 0.0),
                                                    max_factor(pred.kind))
            resp = replace(resp, characteristic=char)
        ch = resp.characteristic
        tt = path.extra["log_volume_ratio"]
        std = pred.std_log_p[r]

        # the band: the anchor's predictive std, or (the path's own reading) the std of
        # log P at the activation volume, which moves the whole κ(P) curve's pressures;
        # an anchor left unused because it disagrees with the path's reading by more
        # than its kind's factor (_anchor.max_factor) widens it to cover its own ±1σ
        def band(pc: float | None, j: int) -> list[float | None]:
            if pc is None:
                return [None, None]
            which = ("critical", "hardening")[j]
            used = anchors["used"] if anchors else []
            a_std = None if pred.anchor_std is None else float(pred.anchor_std[r, j])
            if which in used and a_std is not None:
                return [pc * math.exp(-a_std), pc * math.exp(a_std)]
            tc = float(np.interp(pc, np.maximum.accumulate(path.pressure), tt))
            s = float(np.interp(tc, T_GRID, std))
            anchor = anchors.get(f"{which}_pressure") if anchors else None
            return unused_anchor_band(pc, s, anchor, a_std, max_factor(pred.kind))

        meta = {"model": "calibrated-fast" if fast else "calibrated", "points": len(path),
                "calibration": {
                    "inside": True, "kind": pred.kind, "outside": {},
                    "features": "emulated" if fast else "ritz",
                    "log_pressure_std": float(np.interp(min(1.0, t_end), T_GRID, std)),
                    "critical_pressure_range": band(ch.critical, 0),
                    "hardening_pressure_range": band(ch.hardening, 1),
                    "anchors": anchors,
                    "volume_ratio_end": math.exp(float(tt[-1])),
                    "data_pressure_end": p_data if math.isfinite(p_data) else None,
                    "reached_p_max": reached,
                    "model_version": self.manifest.get("code_version", "")}}
        if shear:
            sd = shear.pop("std")
            g = np.abs(np.asarray(path.twist_rate, float))
            at = (int(np.argmin(np.abs(np.asarray(path.pressure) - ch.critical)))
                  if ch.critical is not None else len(path) - 1)
            rel = float(sd[min(at, len(sd) - 1)] / max(float(g[at]), 1e-12))
            # a shear near zero at Pc has no relative band: capped at a factor of e^10
            # (no information) rather than overflowing (twisting #45 on the factor form)
            rel = min(rel, SHEAR_BAND_CAP) if math.isfinite(rel) else SHEAR_BAND_CAP
            meta["calibration"].update(shear, shear_range=[math.exp(-rel), math.exp(rel)])
        return resp.with_meta(**meta)

    def _tilted_shear(self, cell: TiltedCell, path: EquilibriumPath, pred: GridPrediction,
                      r: int) -> tuple[EquilibriumPath, dict[str, Any]]:
        """A tilted cell's strip shear along its calibrated path (since stop 41): the
        twisting kind's GP of the shear over t and the volume law of the chamber volume
        (:mod:`._shear`), weighted by the inverse of their variances (:func:`_weighted_shear`);
        the GP alone where the model has no volume law. Returns the path (``twist_rate``
        and ``extra["shear"]``) and the calibration record (with the shear's std ``std``
        along the path, popped by the caller)."""
        from multimorph.calibrated._shear import shear_of_volume

        fit = self.twisting_shear or {}
        law = fit.get("volume_law") if fit.get("form") == "volume" else None
        v = np.asarray(path.volume, float)
        if law is not None:
            rule, inside = shear_of_volume(law, cell_groups(cell), v / v[0])
            sigma = float(law["sigma_log"])
            how = ("the twisting kind's GP of the strip shear over the chamber volume and "
                   "the volume law (ln(γ / sin 2β) linear in ln(V/V0 − 1), the tilt, ln Jm "
                   f"and the log groups, {law['training_designs']} tilted FE cells"
                   + ("" if inside else "; its groups held at the edges of the data")
                   + "), weighted by the inverse of their variances")
        else:
            rule, sigma = np.zeros_like(v), math.inf
            how = "the twisting kind's GP of the strip shear over the chamber volume"
        path = replace(path, extra={**(path.extra or {}), "shear": rule})
        assert pred.std_signal is not None
        path, sd = _weighted_shear(path, sigma, pred.values[r, :, 1], pred.std_signal[r])
        return path, {"twisting": ("the tilted cell's own calibrated path: its pressure at "
                                   "each chamber volume from the tilted FE cells' GP "
                                   "(inputs: the groups, the tilt and the straight cell's "
                                   "calibrated features at the plate level: "
                                   + ", ".join(self._straight_names()) + "); " + how),
                      "shear_law": "volume+gp" if law is not None else "gp", "std": sd}


def _mark_unstable_laws(cells: Sequence[CellGeometry | TiltedCell],
                        out: list[Response | Exception]) -> None:
    """Say where a cell's elastomer law loses Drucker stability where a chamber wall is
    stretched (``_law.unstable_laws``: every library Mooney–Rivlin fit), whatever answered
    it: one warning per law, and ``calibration.unstable_law`` on its responses. Before
    stop 61 such a wall was answered silently (Dragon Skin 30's Mooney–Rivlin fit: a Ritz
    Pc of 8.5 kPa, where its Gent fit gives 55 kPa)."""
    from multimorph.calibrated._law import unstable_laws

    said: set[str] = set()
    for i, cell in enumerate(cells):
        bad = unstable_laws(cell)
        if not bad:
            continue
        laws: dict[tuple[Any, ...], list[str]] = {}
        for which, b in bad.items():       # a wall and bottom of one law: said once
            laws.setdefault((b["model"], b["name"], b["equibiaxial_stretch"]), []).append(which)
        msg = ("calibrated model: " + "; ".join(
            f"the {' and '.join(whiches)} law ({model}{', ' + name if name else ''}) loses "
            f"Drucker stability in equibiaxial tension at λ = {lam:.3g}"
            for (model, name, lam), whiches in laws.items())
            + ": a chamber wall of it has no physical ballooning to predict, and any "
              "model's answer describes the fit, not the elastomer (use its gent or yeoh "
              "fit)")
        if msg not in said:
            warnings.warn(msg, CalibrationWarning, stacklevel=3)
            said.add(msg)
        res = out[i]
        if isinstance(res, Response):
            out[i] = res.with_meta(calibration={**(res.meta.get("calibration") or {}),
                                                "unstable_law": bad})


#: The largest relative half-width (in log) of a tilted cell's shear band at its Pc.
SHEAR_BAND_CAP = 10.0


def _weighted_shear(path: EquilibriumPath, sigma_rule: float, y_t: np.ndarray,
                    sd_y_t: np.ndarray) -> tuple[EquilibriumPath, np.ndarray]:
    """The strip shear along ``path`` (which carries the straight cell's rule as
    ``extra["shear"]``) combined with the twisting kind's GP of the shear over t at each
    chamber volume (``y_t`` on the grid, its predictive std ``sd_y_t``), each weighted by
    the inverse of its variance: the rule's (γ σ)², σ the std of its log; the GP's
    (sd · t)². On the held-out tilted cells the GP is the better estimate in the median
    (its largest shear error over its FE range 15 % against the volume law's 28 %) and
    the law in the tail (p90 50 % against the GP's 70 %, on cells that barely shear); the
    weighted shear has both (15 % / 51 %; docs/validation.md §2). Returns the path with
    the combined shear (``twist_rate`` and ``extra["shear"]``) and its std."""
    v = np.asarray(path.volume, float)
    t = np.log(v / v[0])
    rule = np.asarray((path.extra or {}).get("shear", path.twist_rate), float)
    g_kind = np.interp(t, T_GRID, y_t) * t
    var_kind = (np.interp(t, T_GRID, sd_y_t) * np.abs(t)) ** 2
    var_rule = ((rule * sigma_rule) ** 2 if math.isfinite(sigma_rule)
                else np.full_like(t, np.inf))
    # the weight of the GP, var_rule / (var_rule + var_kind): 1 without a rule, ½ where
    # both are exact (t = 0: no shear either way)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(np.isinf(var_rule), 1.0, var_rule / (var_rule + var_kind))
        var = np.where(np.isinf(var_rule), var_kind,
                       var_rule * var_kind / (var_rule + var_kind))
    both_exact = (var_rule == 0.0) & (var_kind == 0.0)
    w = np.where(both_exact, 0.5, w)
    var = np.where(both_exact, 0.0, var)
    gamma = w * g_kind + (1.0 - w) * rule
    sd = np.sqrt(var)
    return (replace(path, twist_rate=gamma, extra={**(path.extra or {}), "shear": gamma}),
            sd)


def _straight_for_tilted(r: Response, cell: TiltedCell,
                         shear_fit: dict[str, Any] | None = None,
                         groups: dict[str, float] | None = None) -> Response:
    """A straight cell's response standing for its tilted cell (see :meth:`responses`):
    the same path, read on the strip shear — by the volume law of the path's chamber volume
    where the fit has it as its form (``shear_fit["form"] == "volume"``, :mod:`._shear`),
    else γ = c · ε sin 2|β| (ε the mid-height strain along the chamber; c the factor
    calibrated on the tilted FE cells, or 1 without one: the Ritz rule) — kept as
    ``extra["shear"]`` as a calibrated tilted cell would give it (the twisting module reads
    it the same way)."""
    if not str(r.meta.get("model", "")).startswith("calibrated"):
        return r  # the Ritz fallback of a straight cell outside the box: as the Ritz model
    from multimorph.calibrated._box import cell_groups
    from multimorph.calibrated._shear import shear_factor, shear_of_volume

    c = cell.cell
    path = r.path
    if groups is None:  # the cell's groups as the model places it (``placed``)
        groups = cell_groups(cell)
    cal = dict(r.meta.get("calibration") or {})
    law = (shear_fit or {}).get("volume_law") if (shear_fit or {}).get("form") == "volume" \
        else None
    if law is not None:
        v = np.asarray(path.volume, float)
        gamma, inside = shear_of_volume(law, groups, v / v[0])
        path = replace(path, twist_rate=gamma, extra={**(path.extra or {}), "shear": gamma})
        resp = build_response(path, length=c.length, shear_modulus=c.mu, backend=r.backend,
                              break_stretch=c.material.break_stretch, signal="twist_rate")
        sigma = float(law["sigma_log"])
        cal["twisting"] = ("the straight cell's calibrated response (plate level); the strip "
                           "shear by a law of its chamber volume, ln(γ / sin 2β) linear in "
                           "ln(V/V0 − 1), the tilt, ln Jm and the log groups, calibrated on "
                           f"{law['training_designs']} tilted FE cells"
                           + ("" if inside else " (its groups held at the edges of the data)"))
        cal["shear_law"] = "volume"
        cal["shear_range"] = [math.exp(-sigma), math.exp(sigma)]
        return resp.with_meta(**{**r.meta, "calibration": cal})
    factor, sigma, inside = shear_factor(shear_fit, abs(cell.tilt), groups["jm"])
    mid = np.asarray(path.axial_stretch) * (1.0 + np.asarray(path.curvature) * 0.5
                                            * c.height) - 1.0
    gamma = factor * mid * math.sin(2.0 * abs(cell.tilt))
    path = replace(path, twist_rate=gamma, extra={**(path.extra or {}), "shear": gamma})
    resp = build_response(path, length=c.length, shear_modulus=c.mu, backend=r.backend,
                          break_stretch=c.material.break_stretch, signal="twist_rate")
    if shear_fit:
        cal["shear_law"] = "factor"
        cal["twisting"] = ("the straight cell's calibrated response (plate level); the strip "
                           "shear by the Ritz rule γ = ε sin 2β times a factor calibrated on "
                           f"{shear_fit['training_designs']} tilted FE cells"
                           + ("" if inside else " (held at the edge of its tilts and Jm)"))
        cal["shear_factor"] = factor
        cal["shear_factor_range"] = [factor * math.exp(-sigma), factor * math.exp(sigma)]
    else:
        cal["twisting"] = ("no FE calibration of tilted cells: the straight cell's response "
                           "(plate level); the strip shear follows the Ritz rule "
                           "γ = ε sin 2β")
    return resp.with_meta(**{**r.meta, "calibration": cal})


def _shifted_hardening(res: Response, log_factor: float) -> Response:
    """``res`` with Ph × e^log_factor (``law_map["ph_shift"]``, fitted on FE: a bending cell
    of a mapped wall whose membrane does not snap hardens later than its effective Gent
    wall, which locks); κ there read on the loading curve, and no Ph where that lies past
    the curve's end. Its ±1σ band moves with it."""
    ch = res.characteristic
    if ch.hardening is None:
        return res
    P = np.asarray(res.loading.pressure, float)
    k = np.asarray(res.loading.curvature, float)
    ph: float | None = max(ch.hardening * math.exp(log_factor), ch.critical or 0.0)
    if not P.size or ph > float(np.nanmax(P)):
        ph = None
    at = {**ch.curvature_at, "hardening": None if ph is None else float(np.interp(ph, P, k))}
    cal = dict(res.meta["calibration"])
    lo, hi = cal.get("hardening_pressure_range") or (None, None)
    f = math.exp(log_factor)
    cal["hardening_pressure_range"] = ([None, None] if ph is None or lo is None or hi is None
                                       else [lo * f, hi * f])
    cal["ph_shift"] = log_factor
    return replace(res, characteristic=replace(ch, hardening=ph, curvature_at=at)
                   ).with_meta(calibration=cal)


def _without_activation(res: Response, material: Any) -> Response:
    """``res`` without Pc and Ph: a stretching or tilted cell whose wall's membrane has no
    limit point (``_law.wall_activates``; FE: ``yeoh_stretching_mirror``,
    ``yeoh_twisting``) stretches or twists without a knee, although its effective Gent
    wall, like the Gent walls the model learned, would activate. Its curve stays the
    effective wall's; the failure pressure is the wall's own."""
    ch = res.characteristic
    at = dict(ch.curvature_at)
    at.update(critical=None, hardening=None)
    char = replace(ch, critical=None, critical_kind=None, hardening=None, curvature_at=at)
    shape = law_shape(material)
    cal = {**res.meta["calibration"], "critical_pressure_range": [None, None],
           "hardening_pressure_range": [None, None],
           "activation": {
               "activates": False,
               "reason": (f"a {material.model} wall of c20/c10 {shape:.3g} has no membrane "
                          "limit point (Yeoh: above 0.0424); in FE such stretching and tilted "
                          "cells stretch or twist without a knee, so no Pc or Ph is reported "
                          "(a Gent fit of the same data may snap: docs/validation.md §2, "
                          "Other laws)")}}
    return replace(res, characteristic=char).with_meta(calibration=cal)


def _best_reaching(ks: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """(q, J): at each grid volume j, the largest correlation ``ks`` (q, n) of a query
    with a training design that reaches j (``reach`` (n, J)). A design's outputs stop
    where its FE path ended, so ``reach`` is a prefix per design: then one running
    maximum over the designs sorted by how far they reach gives every column (exactly
    the same maxima as one masked maximum per column, J of them over q × n)."""
    q, J = ks.shape[0], reach.shape[1]
    count = reach.sum(axis=1)
    if not np.array_equal(reach, np.arange(J)[None, :] < count[:, None]):
        return np.stack([np.where(reach[:, j][None, :], ks, 0.0).max(axis=1)
                         for j in range(J)], axis=1)
    order = np.argsort(-count, kind="stable")
    running = np.maximum.accumulate(ks[:, order], axis=1)
    # designs reaching grid volume j: those with count > j, the first n_j in that order
    n_j = np.sum(count[:, None] > np.arange(J)[None, :], axis=0)
    out = np.zeros((q, J))
    has = n_j > 0
    out[:, has] = np.maximum(running[:, n_j[has] - 1], 0.0)
    return out


def _truncate(path: EquilibriumPath, p_max: float) -> tuple[EquilibriumPath, bool]:
    """The path up to the first point where the pressure reaches ``p_max`` (the last point
    interpolated onto it), and whether it does."""
    P = np.asarray(path.pressure)
    over = np.flatnonzero(P >= p_max)
    if over.size == 0:
        return path, False
    j = int(over[0])
    if j == 0:
        return path.take(slice(0, 1)), True
    f = (p_max - P[j - 1]) / (P[j] - P[j - 1])
    keep = path.take(slice(0, j + 1))
    arrays = {}
    for name in ("pressure", "curvature", "twist_rate", "axial_stretch", "volume",
                 "peak_stretch"):
        a = np.array(getattr(keep, name), float)
        a[-1] = a[-2] + f * (a[-1] - a[-2])
        arrays[name] = a
    extra = {}
    for k, v in (keep.extra or {}).items():
        a = np.array(v, float)
        if a.ndim == 1 and len(a) == len(P[: j + 1]):
            a[-1] = a[-2] + f * (a[-1] - a[-2])
        extra[k] = a
    return replace(keep, **arrays, extra=extra), True


def unused_anchor_band(value: float, std: float, anchor: float | None,
                       anchor_std: float | None,
                       factor: float = MAX_FACTOR) -> list[float | None]:
    """The ±1σ band of a Pc or Ph read on the model's own path (``value``, ``std`` of its
    log): where the kind's anchor for it was left unused because it disagrees with the
    path's reading by more than ``factor`` (its kind's, :func:`~._anchor.max_factor`), the
    band reaches over the anchor's own ±1σ too. The model's two readings then say
    different things about the cell, and its band says so: on the held-out bending cells a
    one-elastomer cell that barely bends read Pc 5.9 kPa on its path, ±0.3 kPa, where its
    anchor said 38.8 and FE 35.3 (``bending_single_mirror`` #15). An anchor left unused
    because the path ends before it (a runaway at a limit point just below it: the path's
    reading is then within 1–3 % of FE on most held-out cells) does not widen the band."""
    lo, hi = value * math.exp(-std), value * math.exp(std)
    if (anchor is not None and math.isfinite(anchor) and anchor > 0 and value > 0
            and abs(math.log(anchor / value)) > math.log(factor)):
        s = anchor_std if anchor_std is not None and math.isfinite(anchor_std) else std
        lo, hi = min(lo, anchor * math.exp(-s)), max(hi, anchor * math.exp(s))
    return [lo, hi]


def straight_of(arrays: dict[str, np.ndarray], manifest: dict[str, Any], data: Any,
                fast: bool, names: Sequence[str] = STRAIGHT_FEATURES) -> np.ndarray:
    """The tilted training cells' straight features ``names`` (by default
    :data:`~._fit.STRAIGHT_FEATURES`, what a refit takes) from a model being fitted
    (``arrays``, ``manifest`` so far: its bending kind; ``fast``: that kind's fast
    variant), each at its own set's end level (``_fit.fit_and_save``'s ``straight_of``)."""
    model = CalibratedModel(arrays, {k: v for k, v in manifest.items()
                                     if k in ("kinds", "fast_kinds", "emulators")})
    ends = data.end if data.end is not None else np.zeros(len(data.cells))
    out = np.full((len(data.cells), len(names)), np.nan)
    for end in np.unique(ends):
        rows = np.flatnonzero(ends == end)
        out[rows] = model.straight_features([data.cells[i] for i in rows], float(end), fast,
                                            names)
    return out


@lru_cache(maxsize=2)
def load_model(path: str | None = None) -> CalibratedModel:
    """The shipped calibrated model (cached).

    Raises
    ------
    MultimorphError
        The model file is missing (fit it with ``python -m multimorph.calibrated.fit model``).
    """
    p = Path(path) if path is not None else MODEL_FILE
    m = p.with_name("model.json") if path is not None else MODEL_MANIFEST
    if not p.exists() or not m.exists():
        raise MultimorphError(f"{p}: the calibrated model is missing (fit it with python -m "
                              "multimorph.calibrated.fit model)")
    with np.load(p, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    return CalibratedModel(arrays, json.loads(m.read_text()))
