"""Anchoring a predicted response on predicted characteristic pressures.

The calibrated model predicts two things for a cell: its whole path (grid values, read
back by monotone cubics) and, on their own, the FE's activation and hardening pressures
Pc and Ph (the anchors, :data:`~._fit.ANCHORS`: scalar GPs trained on the Pc and Ph that
the shared definitions of :mod:`multimorph.response` read on each FE path).

Pc and Ph are functionals of a curve — the inflection of κ(P) or its limit point, the
knee after it — and ill-conditioned ones: on a flat activation plateau two nearly equal
slope maxima, or a 1 % wiggle, move the reading by tens of per cent while the curve itself
stays within a few per cent of FE. Measured on held-out FE designs, the path's own reading
of Pc was off by 20–100 % on a fifth of the bending cells whose curves were within 10 % of
FE, while the anchor, a smooth function of the design, was within 5 % on most of them.
Scaling the path onto the anchor fixed Pc but moved those good curves by the same factor
(curves within 10 % of FE: 24 % → 5 %), and a pressure map that moves Ph as well bends
κ(P) hardest just above Pc and makes a new knee there.

So the path is kept as predicted, and the response reports the anchors as its Pc and Ph
where its path reaches them (:func:`anchored_characteristic`); κ at each is read on the
loading curve. The critical kind (limit point or steepest rise) is the path's own.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from multimorph.response import CharacteristicPressures, Response

__all__ = ["MAX_FACTOR", "MAX_FACTOR_BY_KIND", "PATH_WEIGHT", "anchored_characteristic",
           "max_factor", "readings_disagree"]

#: An anchor further than this factor from the path's own reading is not used (the anchor
#: and the path disagree about what the cell does; the path's reading is kept and the
#: disagreement reported). The default of the kinds :data:`MAX_FACTOR_BY_KIND` leaves out.
MAX_FACTOR = 2.0
#: The factor of a kind whose path's own reading weighs less than its anchor.
#:
#: Tilted cells (stop 62): their path's reading of Pc weighs a quarter (:data:`PATH_WEIGHT`)
#: and jumps along a gradual knee, where the anchor is a smooth function of the design; at
#: 2 the anchor was left out on cells whose path read an early, shallow knee (`twisting3`
#: #44: path 13.5 kPa, anchor 28.0, FE 34.2). 5-fold cross-validation on the 268 training
#: designs (``benchmarks/tilted_path_weight_cv.py --factors``, the kind refitted on each
#: fold's rest, the weights at 0.25; median / p90 of |ΔP|/P): Pc 5.4 / 18.7 % at 2, 5.4 /
#: 17.7 % at 3, 5 and without the rule; Ph 5.4 / 18.7 → 5.4 / 18.3 %. 3 keeps the rule for
#: a reading three times off its anchor (docs/validation.md §4 stop 62).
MAX_FACTOR_BY_KIND: dict[str, float] = {"twisting": 3.0}


def max_factor(kind: str | None) -> float:
    """How far (a factor) a kind's anchor may lie from its path's own reading and still be
    used (:data:`MAX_FACTOR_BY_KIND`, else :data:`MAX_FACTOR`)."""
    return MAX_FACTOR_BY_KIND.get(kind or "", MAX_FACTOR)


def _signal(resp: Response) -> tuple[np.ndarray, np.ndarray]:
    """(P, κ) of the loading curve, pressures strictly increasing (for interpolation)."""
    P = np.asarray(resp.loading.pressure, float)
    k = np.asarray(resp.loading.curvature, float)
    keep = np.concatenate([[True], np.diff(P) > 0])
    return P[keep], k[keep]


#: The weights of the path's own reading of Pc and of Ph (in log P) where it and the anchor
#: both give a value, per kind (the rest on the anchor; 0: the anchor alone).
#:
#: Stretching cells (stop 42): their signal, the axial stretch, rises smoothly, and their
#: path reads Pc better than their anchor does. 5-fold cross-validation on the 321 training
#: stretching designs (`calibrated-fast`, each fold's GPs fitted without it; median / p90 of
#: |ΔP|/P): Pc from the anchor 1.3 / 4.1 %, the path 0.9 / 3.3 %, the geometric mean (0.5)
#: 0.9 / 3.1 % (0.25: 1.0 / 3.2, 0.75: 0.9 / 2.9); Ph 1.1 / 4.4, 1.2 / 4.2, 1.1 / 3.6 %.
#:
#: Bending cells (stop 43): the weights the same cross-validation picks (3 folds grouping
#: each design's twins, 216 mirror cells with both readings of Pc, 144 of Ph): Pc 4.2 /
#: 10.5 % from the anchor, 3.4 / 10.3 % at 0.5 (0.25: 3.8 / 10.7, 0.75: 3.6 / 11.1); Ph
#: 4.9 / 14.8 %, 4.6 / 13.3 % at 0.25 (0.5: 4.1 / 15.5). Where both readings exist on the
#: held-out designs (never fitted on): the mirror sets' fifths (119 Pc, 84 Ph) Pc 3.4 /
#: 10.9 → 2.7 / 9.9 %, Ph 3.8 / 9.8 → 3.3 / 7.7 %; the two bending sets that never chose a
#: fit (114, 97) Pc 3.7 / 13.5 → 3.1 / 11.4 %, Ph 3.2 / 12.0 → 2.7 / 10.2 %. The path's
#: reading can jump between nearly equal slope maxima (module docstring): the anchor keeps
#: the larger weight on Ph, where the knee is the flatter.
#:
#: The path's reading moves the anchor by at most the anchor's own predictive std of log P
#: (about 0.05; the reported value stays inside the anchor's ±1σ band). Why: the reading
#: is discontinuous in the design where the path has two nearly equal slope maxima, and the
#: plain blend carried half of each flip into the reported pressure — over ±10 % sweeps of
#: the top or side wall of 30 `bending2_mirror` cells (41 points each) it added steps of
#: over 1 % between neighbouring designs in 5 of 60 sweeps for Pc (up to 18 %) and 7 for Ph
#: (up to 9 %), where the anchor alone is smooth. Capped, a step it adds is at most 2σ, and
#: the accuracy stays (cross-validation Pc 3.4 / 10.3 %, Ph 4.6 / 13.1 %; held out where
#: both readings exist: Pc 2.7 / 9.9 %, Ph 3.3 / 7.7 %; never chose a fit: Pc 3.0 /
#: 12.1 %, Ph 2.8 / 10.2 %). The same cap holds for stretching cells. Measured again at
#: stop 48 (bending, 872 training designs; docs/validation.md §4 stop 48): uncapped, the
#: 284 held-out mirror designs read Ph p90 8.7 % against 10.1 % (Pc 7.3 against 7.7 %),
#: but over 696 wall sweeps of 232 cells it steps by up to 43 % (Ph) and 39 % (Pc)
#: between designs 0.5 % apart, capped by up to 14 % and 6 %: kept.
#:
#: Bending cells (stop 45): 0.75 on both. The pressure and path GPs on every training design
#: (docs/validation.md §2 item 3) made the path's own readings better, and the same
#: cross-validation (3 folds grouping twins; each fold's pressure, path and signal GPs
#: refitted without the fold's designs and their twins, the anchors on stop 33's rows
#: without them; 216 mirror cells with both readings of Pc, 141 of Ph; capped as below)
#: now reads Pc 4.2 / 10.5 % from the anchor, 2.7 / 8.0 % at 0.5 (mean 3.8 %), 2.6 / 7.9 %
#: at 0.75 (3.5 %), 2.5 / 8.1 % at 1; Ph 4.9 / 14.3 %, 3.7 / 11.3 % at 0.25 (mean 5.4 %),
#: 3.6 / 9.8 % at 0.5, 2.8 / 8.6 % at 0.75 (4.2 %), 2.7 / 9.0 % at 1.
#:
#: Tilted cells: until stop 59 the anchors alone (stop 45's cross-validation, 5 folds, 236
#: cells: Pc 6.8 / 20.5 → 6.7 / 21.0 % at 0.5, Ph 8.1 / 19.2 → 6.2 / 19.3 %). Since stop
#: 59, 0.25 on both, with the Ph anchor's ratio member (``_fit.ANCHOR_RATIO``): 5-fold
#: cross-validation on the 268 training designs, the twisting kind (fast variant) refitted
#: on each fold's rest and the whole chain run on the fold (median / p90). Ph first, Pc at
#: 0 (158 designs with an FE Ph): 6.3 / 20.4 % with the anchor alone, 5.6 / 18.7 % at
#: 0.25, 6.2 / 19.1 % at 0.5, 6.9 / 19.4 % at 0.75, 7.2 / 20.0 % at 1. Then Pc, Ph at 0.25
#: (237 designs with an FE Pc): 6.0 / 19.8 %, 5.4 / 18.7 % at 0.25, 5.1 / 19.4 % at 0.5,
#: 4.7 / 19.7 % at 0.75, 5.3 / 20.4 % at 1: 0.25 is the one better on both figures (and
#: the smoothest across designs: a jump of the path's reading moves the value by a quarter
#: of it); docs/validation.md §4 stop 59.
PATH_WEIGHT: dict[str, tuple[float, float]] = {"stretching": (0.5, 0.5),
                                               "bending": (0.75, 0.75),
                                               "twisting": (0.25, 0.25)}


def _blend(anchor: float, own: float | None, w: float, cap: float = math.inf) -> float:
    """The anchor, or with ``w`` > 0 and a reading of the path's own, their weighted mean in
    log P, moved from the anchor by at most ``cap`` in log P."""
    if own is None or not w > 0 or not own > 0:
        return anchor
    shift = w * math.log(own / anchor)
    return anchor * math.exp(max(-cap, min(cap, shift)))


def _sigma(std: tuple[float, float] | None, j: int) -> float:
    """The anchor's predictive std of log P (inf where not known): how far the path's
    reading may move it."""
    if std is None or not (math.isfinite(std[j]) and std[j] > 0):
        return math.inf
    return float(std[j])


def readings_disagree(info: dict[str, Any] | None) -> bool:
    """Whether a response's record of its anchors (``calibration.anchors``) says the Pc
    anchor was left out because it is more than :data:`MAX_FACTOR` from the path's own
    reading: the model's two readings of Pc say different things about the cell (its
    band then spans both, ``_model.unused_anchor_band``; in FE either can be right, or
    neither: docs/validation.md §4, stop 44)."""
    if not info:
        return False
    own, anchor = info.get("path_critical_pressure"), info.get("critical_pressure")
    if not own or not anchor or own <= 0 or anchor <= 0 or "critical" in info.get("used", []):
        return False
    return abs(math.log(anchor / own)) > math.log(info.get("max_factor", MAX_FACTOR))


def _usable(anchor: float | None, own: float | None, top: float, factor: float) -> bool:
    if anchor is None or not math.isfinite(anchor) or anchor <= 0 or anchor > top:
        return False
    return own is None or abs(math.log(anchor / own)) <= math.log(factor)


def anchored_characteristic(resp: Response, pc: float | None, ph: float | None,
                            std: tuple[float, float] | None = None,
                            path_weight: float | tuple[float, float] = 0.0,
                            factor: float = MAX_FACTOR,
                            ) -> tuple[CharacteristicPressures, dict[str, Any]]:
    """The response's characteristic pressures with Pc and Ph replaced by the anchors
    ``pc``, ``ph`` (Pa; ``None``: no anchor) where the loading curve reaches them, and a
    record of what was done (JSON-able: the path's own readings and the anchors).
    ``path_weight`` (:data:`PATH_WEIGHT` of the cell's kind; one weight for both, or those
    of Pc and Ph): where the path has a reading of its own too, the value used is the
    weighted mean of the two in log P (0: the anchor), moved from the anchor by at most the
    anchor's own predictive std (``std``; :data:`PATH_WEIGHT`'s comment): the reported value
    stays inside the anchor's ±1σ band. The record says ``path_weight`` (Pc's) and
    ``path_weight_hardening`` where either is used. An anchor more than ``factor`` from
    the path's own reading is left out (:func:`max_factor` of the cell's kind; the record's
    ``max_factor``).

    Anchors that cross (``ph < pc``: a narrow knee, both within their scatter) are
    projected onto Pc ≤ Ph: both take the precision-weighted mean of their logs (weights
    1/σ² from ``std``, the anchors' predictive std of log P; equal without it) — the most
    likely pair that satisfies the order under the GPs' Gaussian errors."""
    ch = resp.characteristic
    P, k = _signal(resp)
    top = float(P[-1]) if P.size else 0.0
    w_pc, w_ph = ((float(path_weight), float(path_weight))
                  if isinstance(path_weight, int | float) else path_weight)
    info: dict[str, Any] = {"path_critical_pressure": ch.critical,
                            "path_hardening_pressure": ch.hardening,
                            "critical_pressure": pc, "hardening_pressure": ph,
                            "used": [], "max_factor": factor,
                            **({"path_weight": w_pc, "path_weight_hardening": w_ph}
                                           if w_pc > 0 or w_ph > 0 else {})}
    crit, hard = ch.critical, ch.hardening
    # a path whose own reading finds no activation below its end, but that reaches the
    # anchor, is taken at the anchor too: the reading failed, not the activation
    use_pc = _usable(pc, ch.critical, top, factor)
    if use_pc:
        assert pc is not None
        crit = _blend(pc, ch.critical, w_pc, _sigma(std, 0))
        info["used"].append("critical")
    if crit is not None and _usable(ph, ch.hardening, top, factor):
        assert ph is not None
        hard = _blend(ph, ch.hardening, w_ph, _sigma(std, 1))
        if hard < crit and use_pc:
            # the two anchors cross: both at their precision-weighted log mean
            w = (1.0, 1.0)
            if std is not None and all(math.isfinite(v) and v > 0 for v in std):
                w = (1.0 / std[0] ** 2, 1.0 / std[1] ** 2)
            crit = hard = _blend(crit, hard, w[1] / (w[0] + w[1]))
            info["crossed"] = True
        elif hard < crit:
            hard = crit
        info["used"].append("hardening")
    elif hard is not None and crit is not None and hard < crit:
        hard = crit
    if not info["used"]:
        return ch, info

    def kappa(p: float | None) -> float | None:
        return None if p is None or not P.size else float(np.interp(p, P, k))

    kind = ch.critical_kind or ("max_slope" if crit is not None else None)
    out = replace(ch, critical=crit, critical_kind=kind, hardening=hard,
                  curvature_at={**ch.curvature_at, "critical": kappa(crit),
                                "hardening": kappa(hard)})
    return out, info
