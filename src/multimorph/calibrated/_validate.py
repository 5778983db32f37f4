"""Model against FE on the held-out designs: errors of Pc, Ph, the curves, per cell kind.

Used by ``python -m multimorph.calibrated.validate`` (docs/validation.md and its figures)
and the tests. Definitions (the same for every model compared):

* Pc, Ph: the shared definitions of :mod:`multimorph.response`, applied to the FE path as
  stored in the data set and to the model's path; relative error |model − FE| / FE; a value
  one side has and the other not counts as a miss (one-sided) where the other's path
  reached that pressure, and as not known where it stopped below it (an FE path that
  ended at its snap says nothing of a knee above it). The model is traced to the pressure
  its FE run was asked for (``validate.requested_pressure``), under the same volume limit.
* curve error: on the observed loading curves, at every FE loading pressure up to 1.5 Pc
  (FE), |y_model(P) − y_FE(P)| divided by the FE signal's range over [0, 1.5 Pc]; the
  largest over the pressures is the design's curve error (the criterion: ≤ 10 %).
* graph error (the curve as a graph): on the same FE points, the distance from each point
  to the model's loading curve (its points joined by straight segments, a jump at a limit
  point drawn as the segment across it, and a runaway — a limit point with nothing stable
  to land on further along the path, where the signal grows without bound at that
  pressure — as a vertical ray; since stop 41) in the plane of P / Pc (FE) and y / the FE
  range;
  the largest is the design's graph error. At a snap (κ jumps at Pc) the vertical error
  counts a shift of the jump by any pressure, however small, as the jump's height; the
  graph error counts it as that shift over Pc. ``benchmarks/fe_mesh_curves.py`` measures
  both between the data set's FE and a finer FE mesh.
* signal at 1.5 Pc: y on each model's loading curve at 1.5 × the FE Pc.
* the uncertainty (stop 42): |log(model / FE)| of Pc and Ph over the σ of log P that the
  model's own ±1σ band gives (``calibration.critical_pressure_range``); the share of
  designs within 1σ and 2σ (an honest Gaussian band: 68 % and 95 %).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from multimorph.response import EquilibriumPath, Response, build_response

__all__ = ["DesignComparison", "band_z", "compare", "fe_response", "graph_error",
           "signal_of_loading", "summary"]


def fe_response(path: dict[str, np.ndarray], cell: Any, kind: str, n_cells: int = 1,
                ) -> Response:
    """The Response of a stored FE path, read on the kind's signal (bending: the end
    rotation per cell as κd; stretching: the axial stretch; tilted: the strip shear)."""
    c = cell.cell if hasattr(cell, "tilt") else cell
    n = len(path["pressure"])
    curvature = np.asarray(path["curvature"], float)
    twist = np.zeros(n)
    if kind == "bending":
        curvature = np.asarray(path["bend_angle"], float) / (n_cells * c.length)
    elif kind == "twisting":
        twist = np.asarray(path["shear"], float)
    p = EquilibriumPath(pressure=np.asarray(path["pressure"], float), curvature=curvature,
                        twist_rate=twist, axial_stretch=np.asarray(path["axial_stretch"], float),
                        volume=np.asarray(path["volume"], float),
                        peak_stretch=np.asarray(path["peak_stretch"], float),
                        stable=np.asarray(path["stable"], bool))
    signal = {"bending": "curvature", "stretching": "axial_stretch", "twisting": "twist_rate"}
    return build_response(p, length=c.length, shear_modulus=c.mu, backend="fe",
                          signal=signal[kind])


def signal_of_loading(resp: Response, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """(P, y) of the loading curve: κd (bending), λ − 1 (stretching), γ (tilted)."""
    lo = resp.loading
    return np.asarray(lo.pressure, float), signal_of_path(lo, kind, resp.length)


def _rel(a: float | None, b: float | None) -> float:
    if a is None or b is None or not (math.isfinite(a) and math.isfinite(b)) or b == 0:
        return math.nan
    return abs(a - b) / abs(b)


def _interp(P: np.ndarray, y: np.ndarray, at: np.ndarray) -> np.ndarray:
    keep = np.concatenate([[True], np.diff(P) > 0])
    out = np.interp(at, P[keep], y[keep], right=np.nan)
    return out


def _distance_to_polyline(px: np.ndarray, py: np.ndarray, ax: np.ndarray,
                          ay: np.ndarray) -> np.ndarray:
    """Distance of each point (px, py) to the polyline through (ax, ay)."""
    if ax.size == 1:
        return np.hypot(px - ax[0], py - ay[0])
    x0, y0, dx, dy = ax[:-1], ay[:-1], np.diff(ax), np.diff(ay)
    L2 = np.maximum(dx * dx + dy * dy, 1e-300)
    t = np.clip(((px[:, None] - x0) * dx + (py[:, None] - y0) * dy) / L2, 0.0, 1.0)
    return np.hypot(px[:, None] - (x0 + t * dx), py[:, None] - (y0 + t * dy)).min(axis=1)


def graph_error(model: Response, fe: Response, kind: str) -> float:
    """The largest distance from FE's loading curve (P ≤ 1.5 Pc) to the model's, in the
    plane of P / Pc (FE) and y / FE's range over [0, 1.5 Pc] (the module docstring); NaN
    where FE has no Pc or no range, or the model no loading curve."""
    pcf = fe.characteristic.critical
    if pcf is None or not pcf > 0:
        return math.nan
    Pf, yf = signal_of_loading(fe, kind)
    Pm, ym = signal_of_loading(model, kind)
    sel = (Pf <= 1.5 * pcf) & np.isfinite(yf)
    okm = np.isfinite(Pm) & np.isfinite(ym)
    if sel.sum() < 2 or not okm.any():
        return math.nan
    rng = float(np.max(yf[sel]) - np.min(yf[sel]))
    if not rng > 0:
        return math.nan
    Pm, ym = Pm[okm], ym[okm]
    ray = _runaway_ray(model, kind)
    if ray is not None:
        # a loading curve that ends in a runaway: the signal grows without bound at that
        # pressure, a vertical ray (as far as FE's own range can reach)
        Pm = np.append(Pm, Pm[-1])
        ym = np.append(ym, ym[-1] + ray * 10.0 * (rng + float(np.max(np.abs(yf[sel])))))
    d = _distance_to_polyline(Pf[sel] / pcf, yf[sel] / rng, Pm / pcf, ym / rng)
    return float(d.max())


def _runaway_ray(resp: Response, kind: str) -> float | None:
    """The direction (±1) in which the signal runs away where ``resp``'s loading curve ends
    at a limit point with nothing stable to land on further along its path (a runaway under
    pressure control: :func:`multimorph.response.observed_positions`), read on the path past
    that point; None where the loading curve does not end so."""
    from multimorph.response import observed_positions

    path = resp.path
    pos, _snap, complete = observed_positions(np.asarray(path.pressure, float),
                                              np.asarray(path.stable, bool))
    if complete:
        return None
    y = signal_of_path(path, kind, resp.length)
    i = math.floor(float(pos[-1]))
    step = float(y[-1] - y[i])
    if step == 0.0 or not math.isfinite(step):
        return None
    return math.copysign(1.0, step)


def signal_of_path(path: EquilibriumPath, kind: str, length: float) -> np.ndarray:
    """The kind's signal along a path (a whole path, or a response's loading curve)."""
    if kind == "bending":
        return np.asarray(path.curvature, float) * length
    if kind == "stretching":
        return np.asarray(path.axial_stretch, float) - 1.0
    return np.asarray(path.twist_rate, float)


@dataclass(frozen=True)
class DesignComparison:
    """One design, model against FE."""

    set_name: str
    design: int
    kind: str
    pc_fe: float | None
    pc_model: float | None
    ph_fe: float | None
    ph_model: float | None
    pc_error: float
    ph_error: float
    curve_error: float
    y15_fe: float
    y15_model: float
    covered: float
    graph_error: float = math.nan
    #: the highest pressure of each path (a value the other lacks above it is not known)
    top_fe: float = math.nan
    top_model: float = math.nan
    #: |log(model / FE)| of Pc and Ph over the model's own σ of log P (its ±1σ band,
    #: ``calibration.critical_pressure_range`` / ``hardening_pressure_range``); NaN where
    #: either value or the band is missing (the Ritz model has none)
    pc_z: float = math.nan
    ph_z: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


def compare(model: Response, fe: Response, kind: str, set_name: str = "",
            design: int = -1) -> DesignComparison:
    """Compare a model's Response with FE's for one design (see the module docstring)."""
    pcf, pcm = fe.characteristic.critical, model.characteristic.critical
    phf, phm = fe.characteristic.hardening, model.characteristic.hardening
    Pf, yf = signal_of_loading(fe, kind)
    Pm, ym = signal_of_loading(model, kind)
    curve = math.nan
    y15f = y15m = math.nan
    covered = math.nan
    if pcf is not None:
        top = 1.5 * pcf
        sel = Pf <= top
        rng = float(np.nanmax(yf[sel]) - np.nanmin(yf[sel])) if sel.sum() > 1 else math.nan
        ym_at = _interp(Pm, ym, Pf[sel])
        ok = np.isfinite(ym_at)
        covered = float(ok.mean()) if sel.any() else math.nan
        if rng > 0 and ok.any():
            curve = float(np.max(np.abs(ym_at[ok] - yf[sel][ok])) / rng)
        if Pf[-1] >= top:
            y15f = float(_interp(Pf, yf, np.array([top]))[0])
        if Pm[-1] >= top:
            y15m = float(_interp(Pm, ym, np.array([top]))[0])
    return DesignComparison(set_name, int(design), kind, pcf, pcm, phf, phm, _rel(pcm, pcf),
                            _rel(phm, phf), curve, y15f, y15m, covered,
                            graph_error(model, fe, kind), _top(fe), _top(model),
                            band_z(model, pcf, "critical"), band_z(model, phf, "hardening"))


def band_z(model: Response, fe_value: float | None, which: str) -> float:
    """|log(model / FE)| of the model's ``which`` pressure ("critical", "hardening") over
    the σ of log P its ±1σ band gives on FE's side of it (a band that reaches over an
    unused anchor is wider on one side: ``_model.unused_anchor_band``; NaN without both
    values and a band)."""
    own = getattr(model.characteristic, which)
    band = ((model.meta.get("calibration") or {}).get(f"{which}_pressure_range")
            or (None, None))
    lo, hi = band
    if (own is None or fe_value is None or lo is None or hi is None
            or not (0 < lo < hi and own > 0 and fe_value > 0)):
        return math.nan
    if lo <= own <= hi:
        side = math.log(hi / own) if fe_value > own else math.log(own / lo)
    else:
        side = 0.5 * math.log(hi / lo)
    if not side > 0:
        side = 0.5 * math.log(hi / lo)
    return abs(math.log(own / fe_value)) / side


def _top(r: Response) -> float:
    P = np.asarray(r.path.pressure, float)
    return float(np.nanmax(P)) if P.size and np.isfinite(P).any() else math.nan


def one_sided(fe: float | None, model: float | None, top_fe: float, top_model: float,
              ) -> bool:
    """A value one side has and the other lacks although its path got there."""
    if (fe is None) == (model is None):
        return False
    if fe is None:
        return not top_fe < model           # NaN top: counted, as before stop 40
    return not top_model < fe


def summary(rows: list[DesignComparison]) -> dict[str, Any]:
    """Median, p90 and max of the errors, and the share of curves within 10 % (vertical,
    and as graphs)."""
    def stats(v: list[float]) -> dict[str, float | int]:
        a = np.array([x for x in v if math.isfinite(x)])
        if a.size == 0:
            return {"n": 0}
        return {"n": int(a.size), "median": float(np.median(a)),
                "p90": float(np.percentile(a, 90)), "max": float(a.max())}

    def within(z: list[float], k: float) -> float:
        a = np.array([x for x in z if math.isfinite(x)])
        return float(np.mean(a <= k)) if a.size else math.nan

    curves = [r.curve_error for r in rows]
    fin = [c for c in curves if math.isfinite(c)]
    graphs = [r.graph_error for r in rows if math.isfinite(r.graph_error)]
    return {"designs": len(rows), "pc": stats([r.pc_error for r in rows]),
            "ph": stats([r.ph_error for r in rows]), "curve": stats(curves),
            "curves_within_10pct": (float(np.mean(np.array(fin) <= 0.10)) if fin
                                    else math.nan),
            "graph": stats(graphs),
            "graphs_within_10pct": (float(np.mean(np.array(graphs) <= 0.10)) if graphs
                                    else math.nan),
            # the model's ±1σ and ±2σ bands: the share of FE values inside them (a Gaussian
            # error: 68 % and 95 %)
            "pc_within_1sigma": within([r.pc_z for r in rows], 1.0),
            "pc_within_2sigma": within([r.pc_z for r in rows], 2.0),
            "ph_within_1sigma": within([r.ph_z for r in rows], 1.0),
            "ph_within_2sigma": within([r.ph_z for r in rows], 2.0),
            "pc_missing": sum(one_sided(r.pc_fe, r.pc_model, r.top_fe, r.top_model)
                              for r in rows),
            "ph_missing": sum(one_sided(r.ph_fe, r.ph_model, r.top_fe, r.top_model)
                              for r in rows),
            "pc_unknown": sum((r.pc_fe is None) != (r.pc_model is None)
                              and not one_sided(r.pc_fe, r.pc_model, r.top_fe, r.top_model)
                              for r in rows),
            "ph_unknown": sum((r.ph_fe is None) != (r.ph_model is None)
                              and not one_sided(r.ph_fe, r.ph_model, r.top_fe, r.top_model)
                              for r in rows)}
