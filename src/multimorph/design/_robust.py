"""Robustness: Monte Carlo over material uncertainty and fabrication tolerances.

For a design, each sample draws

- every material's parameters from independent normal distributions around the nominal
  values with the fit's standard errors (the library provenance, ``stats.stderr``), or, where
  none is known (inline materials, models without errors), a coefficient of variation
  ``default_cv`` on every parameter; one draw per material and sample (one batch of
  silicone serves every module made of it); draws are clipped to at least 20 % of nominal;
- every wall thickness (top, bottom, side, end) of every module independently and uniformly
  within ± ``wall_tolerance`` (clipped to keep walls ≥ 0.1 mm and chambers open; the two
  walls of a stretching cell move together, as the module is symmetric).

The module layout (cells, tilt) stays as designed. Each sample is traced with the cell model
and scored like the nominal design; the report gives the probability that the stage order
holds (Pc strictly increasing in target order), the probability that every target is met,
and the mean, standard deviation and 5–95 % range of every stage's start and completion
pressure and magnitude. Same seed, same samples.

A sample the model cannot answer because a perturbed cell lies outside its support (the
calibrated model without its Ritz fallback, as the designer runs it: a design at the edge of
the calibrated box, with its walls ±0.1 mm, puts many samples past it) is not a sample whose
order fails: it is counted apart (``outside_support``), and the two probabilities are also
given over the samples the model answered (``p_order_supported``, ``p_meets_supported``).
``p_order`` and ``p_meets`` stay over all samples, an unanswered one counted as failing (the
``--robust`` ranking's conservative reading).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from multimorph.design._evaluate import Evaluation, evaluate_one
from multimorph.design._models import BatchModel, CountingModel, rom_batch_model
from multimorph.design._space import Candidate
from multimorph.design._target import TargetSpec
from multimorph.errors import OutsideSupportError, SpecError
from multimorph.geometry import CellGeometry
from multimorph.materials import Material

__all__ = ["RobustnessReport", "material_stderr", "robustness"]


def material_stderr(material: Material) -> dict[str, float] | None:
    """Standard errors of a library material's fitted parameters (SI), or ``None``."""
    from multimorph.materials.library import library_entry

    try:
        entry = library_entry(material.name)
    except Exception:
        return None
    model = entry.get("models", {}).get(material.model, {})
    se = model.get("stats", {}).get("stderr")
    if not se:
        return None
    if any(abs(float(model["params"].get(k, math.nan)) - float(v)) > 1e-9 * max(1.0, abs(v))
           for k, v in material.params.items()):
        return None  # not the library parameters (e.g. scaled): errors do not apply
    return {k: float(v) for k, v in se.items() if math.isfinite(float(v))}


@dataclass(frozen=True)
class RobustnessReport:
    """Monte Carlo robustness of one design (pressures in Pa).

    Attributes
    ----------
    n_samples, seed : int
    p_order : float
        Probability that the stages start in the target order (a sample the model did not
        answer counts as failing).
    p_meets : float
        Probability that every target and constraint is met (the same).
    stages : dict
        Stage → {"start_pressure" | "end_pressure" | "magnitude": {mean, std, p05, p95,
        missing, outside_support}}: ``missing`` the samples without the value, of them
        ``outside_support`` those the model gave no prediction for.
    outside_support, p_order_supported, p_meets_supported
        See the module docstring.
    mean_objective : float
    uncertainty : dict
        The uncertainty model used (per material: source and standard deviations).
    """

    n_samples: int
    seed: int
    p_order: float
    p_meets: float
    stages: dict[str, dict[str, dict[str, float | int | None]]]
    mean_objective: float
    uncertainty: dict[str, Any]
    wall_tolerance: float
    samples: dict[str, dict[str, np.ndarray]] = field(default_factory=dict, repr=False)
    #: samples with a cell outside the model's support (no prediction; the module docstring)
    outside_support: int = 0
    #: p_order and p_meets over the samples the model answered (None: it answered none)
    p_order_supported: float | None = None
    p_meets_supported: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"n_samples": self.n_samples, "seed": self.seed, "p_order": self.p_order,
                "p_meets": self.p_meets, "stages": self.stages,
                "mean_objective": self.mean_objective, "uncertainty": self.uncertainty,
                "wall_tolerance": self.wall_tolerance,
                "outside_support": self.outside_support,
                "p_order_supported": self.p_order_supported,
                "p_meets_supported": self.p_meets_supported}


def _perturb_cell(cell: CellGeometry, mats: dict[str, Material], rng: np.random.Generator,
                  tol: float, symmetric: bool) -> CellGeometry:
    d = rng.uniform(-tol, tol, size=4)
    ht = max(cell.top_wall + d[0], 1e-4)
    hb = ht if symmetric else max(cell.bottom_wall + d[1], 1e-4)
    ws = max(cell.side_wall + d[2], 1e-4)
    df = max(cell.end_wall + d[3], 1e-4)
    ws = min(ws, 0.5 * cell.width - 1e-4)
    df = min(df, 0.5 * cell.length - 1e-4)
    room = cell.height - 1e-4
    if ht + hb > room:
        f = room / (ht + hb)
        ht, hb = ht * f, hb * f
    assert cell.bottom_material is not None
    return replace(cell, top_wall=ht, bottom_wall=hb, side_wall=ws, end_wall=df,
                   material=mats[cell.material.name],
                   bottom_material=mats[cell.bottom_material.name])


def robustness(target: TargetSpec, design: Evaluation, *, n_samples: int = 64, seed: int = 0,
               model: BatchModel | None = None, wall_tolerance: float = 0.1e-3,
               default_cv: float = 0.05) -> RobustnessReport:
    """Monte Carlo robustness of ``design`` (see the module docstring).

    Parameters
    ----------
    target : TargetSpec
    design : Evaluation
        A design from :func:`multimorph.design.design`.
    n_samples : int
    seed : int
    model : BatchModel, optional
        Default: the reduced model.
    wall_tolerance : float
        Fabrication tolerance on every wall thickness, ± (m).
    default_cv : float
        Coefficient of variation of parameters without a known standard error (-).
    """
    if n_samples < 1:
        raise SpecError(f"robustness: n_samples must be positive, got {n_samples}")
    if not (wall_tolerance >= 0 and default_cv >= 0):
        raise SpecError("robustness: wall_tolerance and default_cv must be non-negative")
    counting = model if model is not None else CountingModel(rom_batch_model(), pad_to=None)
    rng = np.random.default_rng(seed)
    cand = design.candidate
    materials: dict[str, Material] = {}
    for c in cand.cells:
        for mm in (c.material, c.bottom_material):
            assert mm is not None
            materials.setdefault(mm.name, mm)
    sigma: dict[str, dict[str, float]] = {}
    uncertainty: dict[str, Any] = {}
    for name, mm in sorted(materials.items()):
        se = material_stderr(mm)
        source = "fit standard errors (library provenance)" if se else \
            f"default coefficient of variation {default_cv:.0%}"
        sd = {k: (se[k] if se and k in se else default_cv * abs(v))
              for k, v in mm.params.items()}
        sigma[name] = sd
        uncertainty[name] = {"source": source, "std": sd, "nominal": dict(mm.params)}
    n_cells = [found.n_cells for found in design.stages]
    cands: list[Candidate] = []
    for _ in range(n_samples):
        drawn = {}
        for name, mm in sorted(materials.items()):
            p = {k: max(v + sigma[name][k] * rng.standard_normal(), 0.2 * v) if v > 0 else v
                 for k, v in mm.params.items()}
            drawn[name] = replace(mm, params=p)
        cells = tuple(_perturb_cell(c, drawn, rng, wall_tolerance,
                                    target.stages[i].kind == "stretch")
                      for i, c in enumerate(cand.cells))
        cands.append(Candidate(x=cand.x, cells=cells, tilts=cand.tilts,
                               material_index=cand.material_index, twisting=cand.twisting))
    flat = [c for cd in cands for c in cd.model_cells(counting)]
    out = counting(flat, target.constraints.max_pressure)
    S = len(target.stages)
    evs = [evaluate_one(target, cd, out[k * S:(k + 1) * S], fixed_cells=n_cells)
           for k, cd in enumerate(cands)]
    # per sample and stage: the model gave no prediction (a cell outside its support)
    unsupported = np.array([[isinstance(out[k * S + i], OutsideSupportError)
                             for i in range(S)] for k in range(len(cands))], bool)
    answered = ~unsupported.any(axis=1)
    order = np.zeros(len(evs), bool)
    for k, e in enumerate(evs):
        starts = [found.start for found in e.stages]
        order[k] = all(found is not None for found in starts) and all(
            a < b for a, b in itertools.pairwise(starts))
    meets = np.array([e.meets for e in evs], bool)
    stats: dict[str, dict[str, dict[str, float | int | None]]] = {}
    samples: dict[str, dict[str, np.ndarray]] = {}
    for i, stage in enumerate(target.stages):
        stats[stage.name] = {}
        for key in ("start", "end", "magnitude"):
            # a stage the model did not answer has no value (not a zero motion)
            vals = [None if unsupported[k, i] else getattr(e.stages[i], key)
                    for k, e in enumerate(evs)]
            arr = np.array([v for v in vals if v is not None], float)
            label = {"start": "start_pressure", "end": "end_pressure"}.get(key, key)
            samples.setdefault(stage.name, {})[label] = np.array(
                [np.nan if v is None else v for v in vals], float)
            outside = int(unsupported[:, i].sum())
            if arr.size:
                stats[stage.name][label] = {
                    "mean": float(arr.mean()), "std": float(arr.std(ddof=1)) if arr.size > 1
                    else 0.0, "p05": float(np.percentile(arr, 5)),
                    "p95": float(np.percentile(arr, 95)), "missing": len(vals) - int(arr.size),
                    "outside_support": outside}
            else:
                stats[stage.name][label] = {"mean": None, "std": None, "p05": None, "p95": None,
                                         "missing": len(vals), "outside_support": outside}
    n_ans = int(answered.sum())
    return RobustnessReport(
        n_samples=n_samples, seed=seed, p_order=float(order.mean()),
        p_meets=float(meets.mean()), stages=stats,
        mean_objective=float(np.mean([min(e.objective, 1e6) for e in evs])),
        uncertainty=uncertainty, wall_tolerance=wall_tolerance, samples=samples,
        outside_support=n_samples - n_ans,
        p_order_supported=float(order[answered].mean()) if n_ans else None,
        p_meets_supported=float(meets[answered].mean()) if n_ans else None)
