"""Gradient refinement of designs through the traced equilibrium (IFT), on the reduced model.

A one-stage target is built from a known design (its own completion pressure and twice its
motion per cell), so the optimum is known; the refinement must recover it from a
perturbed start without ever returning a worse design, and its Jacobian (no model re-run)
must agree with finite differences of the re-run model. Slow: the reduced model and the
sensitivity kernel compile once per process.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from multimorph.design import (
    CountingModel,
    DesignSettings,
    SearchSpace,
    evaluate_one,
    evaluate_population,
    rom_batch_model,
    target_from_spec,
)
from multimorph.design._gradient import (
    CONTINUOUS,
    gradient_refine,
    objective_jacobian,
    residuals,
)
from test_design_helpers import STANDIN

pytestmark = pytest.mark.slow

MATERIAL = {"name": "soft-gent", "model": "gent", "mu": "60 kPa", "jm": 25,
            "break_stretch": 8.0}
X0 = np.array([0.5, 0.5, 0.5, 0.1, 0.5, 0.1, 0.3, 0.5, 0.5, 0.5])


def spec(pressure_kpa: float, angle_deg: float) -> dict:
    return {"target": {"name": "one bend"},
            "stage": [{"name": "finger", "kind": "bend", "angle": f"{angle_deg} deg",
                       "pressure": f"{pressure_kpa} kPa"}],
            "constraints": {"max_pressure": "150 kPa", "materials": [MATERIAL],
                            "min_wall": "1 mm"}}


@pytest.fixture(scope="module")
def problem():
    model = CountingModel(rom_batch_model())
    probe = target_from_spec(spec(100.0, 90.0))
    space = SearchSpace(probe)
    cand = space.decode(X0)
    resp = model(list(cand.cells), probe.constraints.max_pressure)
    one = evaluate_one(probe, cand, resp, fixed_cells=[1]).stages[0]
    # the optimum has three cells of this one: at least the default min_cells
    target = target_from_spec(spec(one.end / 1e3, math.degrees(3 * one.magnitude)))
    return target, SearchSpace(target), model


def test_design_at_the_optimum_meets_its_own_target(problem):
    _, space, model = problem
    ev = evaluate_population(space, X0[None, :], model)[0]
    assert ev.meets and ev.objective < 1e-6
    best, _ = gradient_refine(space, ev, lambda X: evaluate_population(space, X, model),
                              lambda k: True, max_iter=2)
    assert best.objective <= ev.objective               # never returns a worse design


def test_jacobian_matches_rerun_model(problem):
    """J (IFT paths + post-processing, no model run) vs central differences of the re-run
    model at ±0.01 in the unit cube. Tolerance 10 % of the column's largest entry: the
    estimators' discretisation (re-traced paths have their own adaptive nodes, 1-4 % on Pc
    and Ph, tests/test_rom_sensitivity.py) and the curvature of r over the ±0.01 step."""
    target, space, model = problem
    x = X0.copy()
    x[3] += 0.1                                         # off the optimum: non-zero residuals
    ev = evaluate_population(space, x[None, :], model)[0]
    keys, _, J = objective_jacobian(space, ev, list(CONTINUOUS))
    tp = target.tolerance.pressure
    for j in (1, 3, 5):                 # width, top wall, side wall
        xs = np.array([x, x])
        xs[0, j] += 0.01
        xs[1, j] -= 0.01
        ep, em = evaluate_population(space, xs, model)
        assert [s.n_cells for s in ep.stages] == [s.n_cells for s in em.stages]
        rp, rm = residuals(ep, tp), residuals(em, tp)
        key = "finger.end_pressure"
        fd = (rp[key] - rm[key]) / 0.02
        jj = J[keys.index(key), list(CONTINUOUS).index(j)]
        assert abs(jj - fd) <= 0.1 * abs(fd), (j, jj, fd)


def test_refinement_recovers_the_optimum_from_a_perturbed_start(problem):
    _, space, model = problem
    x = X0.copy()
    x[[1, 3, 5]] += [-0.1, 0.15, 0.1]                  # narrower cell, thicker walls
    ev = evaluate_population(space, x[None, :], model)[0]
    assert ev.objective > 4.0                           # a clear miss to start with
    budget = model.evaluations + 60

    def run(X):
        return evaluate_population(space, X, model)

    best, log = gradient_refine(space, ev, run,
                                lambda k: model.evaluations + k <= budget, max_iter=10)
    assert model.evaluations <= budget
    objs = [ev.objective] + [s.objective_after for s in log]
    assert all(b <= a for a, b in itertools.pairwise(objs))   # monotone
    assert best.objective < 0.1 * ev.objective
    assert best.objective == log[-1].objective_after


def test_skipped_without_sensitivities():
    """A cell model without generalised coordinates (closed-form stand-in) has no IFT
    sensitivities: the stage is skipped and costs no evaluation."""
    from multimorph.design import design

    t = target_from_spec(spec(30.0, 60.0))
    r = design(t, model=STANDIN, settings=DesignSettings(budget=200, population=8, seed=0))
    assert r.gradient_steps == ()
    assert DesignSettings().gradient
