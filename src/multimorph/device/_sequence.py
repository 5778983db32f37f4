"""Sequence analysis of modules sharing one pressure line.

Definitions (all pressures in Pa):

- *activation window* of a module: [Pc, Ph] from its characteristic pressures;
- *stage order*: modules sorted by Pc; modules whose Pc agree within 2 % (identical cells,
  e.g. the upper and lower chambers of the double-curvature device) form one *stage*;
- *dominance*: at pressure P the dominant module is the one whose normalised motion
  m(P)/m(Pmax) rises fastest (largest d/dP of the normalised measure); bands are the
  contiguous pressure ranges with the same dominant module;
- *separation margin* between each module A of a stage and each module B of the next stage:
  ``Pc_B − Ph_A``; relative to
  Pc_B it is ``matched`` within ``tolerance`` (default 10 %), a ``gap`` above, an ``overlap``
  below (A still moving when B starts);
- *failure order*: modules sorted by the pressure at which their peak stretch reaches the
  break stretch (``None``: not reached within the path);
- *unloading order*: modules sorted by decreasing *release pressure*, the pressure on the
  pressure-controlled unloading curve at which the module's motion falls back to half its
  maximum.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from multimorph.errors import MultimorphError

__all__ = ["ModuleCurve", "SequenceReport", "analyse_sequence"]


@dataclass(frozen=True, eq=False)
class ModuleCurve:
    """One module's motion along the pressure line, as the sequence analysis needs it.

    Parameters
    ----------
    name : str
    mode : str
        ``"bend"``, ``"twist"``, ``"stretch"`` …
    pressure : ndarray (n,)
        Increasing pressures of the observed loading curve (Pa).
    measure : ndarray (n,)
        Magnitude of the module's motion (bend angle rad, twist angle rad, stretch − 1 …).
    critical, hardening, failure : float or None
        Pc, Ph and failure pressure (Pa).
    unloading_pressure, unloading_measure : ndarray, optional
        The observed unloading curve (decreasing pressure).
    """

    name: str
    mode: str
    pressure: np.ndarray
    measure: np.ndarray
    critical: float | None
    hardening: float | None
    failure: float | None = None
    unloading_pressure: np.ndarray | None = None
    unloading_measure: np.ndarray | None = None


@dataclass(frozen=True)
class SequenceReport:
    """Result of :func:`analyse_sequence` (JSON via :meth:`to_dict`)."""

    order: list[str]
    stages: list[list[str]]
    windows: dict[str, tuple[float | None, float | None]]
    bands: list[dict[str, Any]]
    margins: list[dict[str, Any]]
    failure_order: list[str]
    first_to_fail: str | None
    unloading_order: list[str]
    release_pressure: dict[str, float | None] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "order": self.order,
            "stages": self.stages,
            "windows": {k: {"critical_pressure": v[0], "hardening_pressure": v[1]}
                        for k, v in self.windows.items()},
            "bands": self.bands,
            "margins": self.margins,
            "failure_order": self.failure_order,
            "first_to_fail": self.first_to_fail,
            "unloading_order": self.unloading_order,
            "release_pressure": self.release_pressure,
        }


def _normalised_rate(p: np.ndarray, magnitude: np.ndarray, grid: np.ndarray) -> np.ndarray:
    order = np.argsort(p, kind="stable")
    p, magnitude = p[order], np.abs(magnitude[order])
    p, idx = np.unique(p, return_index=True)
    magnitude = magnitude[idx]
    span = float(np.max(magnitude) - np.min(magnitude)) if magnitude.size else 0.0
    if magnitude.size < 2 or span <= 0:
        return np.zeros_like(grid)
    mg = np.interp(grid, p, magnitude, left=magnitude[0], right=magnitude[-1]) / span
    return np.gradient(mg, grid)


def _release_pressure(c: ModuleCurve) -> float | None:
    if c.unloading_pressure is None or c.unloading_measure is None:
        return None
    pu = np.asarray(c.unloading_pressure, float)
    mu = np.abs(np.asarray(c.unloading_measure, float))
    if pu.size < 2:
        return None
    half = 0.5 * float(np.max(np.abs(c.measure)))
    below = np.flatnonzero(mu <= half)
    if below.size == 0:
        return None
    i = int(below[0])
    if i == 0:
        return float(pu[0])
    # linear interpolation between the last point above and the first below half
    m0, m1, p0, p1 = mu[i - 1], mu[i], pu[i - 1], pu[i]
    t = 0.0 if m0 == m1 else (m0 - half) / (m0 - m1)
    return float(p0 + t * (p1 - p0))


def analyse_sequence(curves: Sequence[ModuleCurve], *, tolerance: float = 0.10,
                     n_grid: int = 400) -> SequenceReport:
    """Stage order, dominance bands, separation margins, failure and unloading order.

    Parameters
    ----------
    curves : sequence of ModuleCurve
        One per module on the pressure line (at least one).
    tolerance : float
        Relative tolerance for a ``matched`` hand-over (fraction of the later Pc).
    n_grid : int
        Pressure grid size for the dominance bands.
    """
    if not curves:
        raise MultimorphError("sequence analysis needs at least one module")
    names = [c.name for c in curves]
    if len(set(names)) != len(names):
        raise MultimorphError(f"module names must be unique, got {names}")
    big = float("inf")
    order = sorted(curves, key=lambda c: (c.critical if c.critical is not None else big))
    windows = {c.name: (c.critical, c.hardening) for c in order}

    pmax = min(float(np.max(c.pressure)) for c in curves)
    grid = np.linspace(0.0, pmax, n_grid)
    rates = np.array([_normalised_rate(np.asarray(c.pressure, float),
                                       np.asarray(c.measure, float), grid) for c in curves])
    dom = np.argmax(rates, axis=0)
    bands: list[dict[str, Any]] = []
    start = 0
    for i in range(1, n_grid + 1):
        if i == n_grid or dom[i] != dom[start]:
            bands.append({"module": curves[int(dom[start])].name,
                          "mode": curves[int(dom[start])].mode,
                          "from_pressure": float(grid[start]),
                          "to_pressure": float(grid[i - 1])})
            start = i
    # merge bands narrower than 2 % of the range into a neighbour (noise at hand-overs and
    # at P = 0, where every rate is near zero)
    merged: list[dict[str, Any]] = []
    for b in bands:
        if merged and (b["to_pressure"] - b["from_pressure"] < 0.02 * pmax
                       or b["module"] == merged[-1]["module"]):
            merged[-1]["to_pressure"] = b["to_pressure"]
        else:
            merged.append(dict(b))
    if len(merged) > 1 and merged[0]["to_pressure"] - merged[0]["from_pressure"] < 0.02 * pmax:
        merged[1]["from_pressure"] = merged[0]["from_pressure"]
        merged.pop(0)

    stages: list[list[ModuleCurve]] = []
    for c in order:
        if (stages and c.critical is not None and stages[-1][0].critical is not None
                and abs(c.critical - stages[-1][0].critical) <= 0.02 * abs(c.critical)):
            stages[-1].append(c)
        else:
            stages.append([c])
    # same-stage modules (identical windows) share their bands
    stage_of = {c.name: i for i, stage in enumerate(stages) for c in stage}
    for b in merged:
        b["stage"] = stage_of[b["module"]]
    margins: list[dict[str, Any]] = []
    for sa, sb in itertools.pairwise(stages):
        for a in sa:
            for b in sb:
                if a.hardening is None or b.critical is None:
                    margins.append({"earlier": a.name, "later": b.name, "margin": None,
                                    "relative_margin": None, "verdict": "undetermined"})
                    continue
                margin = b.critical - a.hardening
                rel = margin / b.critical if b.critical else float("nan")
                verdict = ("matched" if abs(rel) <= tolerance
                           else ("gap" if rel > 0 else "overlap"))
                margins.append({"earlier": a.name, "later": b.name, "margin": margin,
                                "relative_margin": rel, "verdict": verdict})

    failing = sorted((c for c in curves if c.failure is not None),
                     key=lambda c: c.failure)  # type: ignore[arg-type, return-value]
    release = {c.name: _release_pressure(c) for c in curves}
    unloading = sorted((c.name for c in curves if release[c.name] is not None),
                       key=lambda n: -release[n])  # type: ignore[operator]
    return SequenceReport(
        order=[c.name for c in order],
        stages=[[c.name for c in stage] for stage in stages],
        windows=windows,
        bands=merged,
        margins=margins,
        failure_order=[c.name for c in failing],
        first_to_fail=failing[0].name if failing else None,
        unloading_order=unloading,
        release_pressure=release,
    )
