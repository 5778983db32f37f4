"""Monte Carlo robustness: seeded, reproducible, consistent with its uncertainty model."""

import tomllib
from pathlib import Path

import numpy as np
import pytest

from multimorph.design import (
    DesignSettings,
    design,
    material_stderr,
    robustness,
    target_from_spec,
)
from multimorph.materials import get_material
from test_design_helpers import STANDIN

EXAMPLES = Path(__file__).parents[1] / "examples"


@pytest.fixture(scope="module")
def gripper():
    t = target_from_spec(tomllib.loads((EXAMPLES / "target_gripper.toml").read_text()))
    settings = DesignSettings(budget=900, population=16, seed=3, graded=False)
    r = design(t, model=STANDIN, settings=settings)
    assert r.feasible
    return t, r.best


def test_library_standard_errors_are_used():
    se = material_stderr(get_material("dragon-skin-30"))
    assert se is not None and se["mu"] > 0 and se["jm"] > 0
    assert material_stderr(get_material("dragon-skin-30").scaled(2.0)) is None


def test_reproducible_with_seed(gripper):
    t, best = gripper
    a = robustness(t, best, n_samples=40, seed=7, model=STANDIN)
    b = robustness(t, best, n_samples=40, seed=7, model=STANDIN)
    c = robustness(t, best, n_samples=40, seed=8, model=STANDIN)
    assert a.to_dict() == b.to_dict()
    assert a.stages != c.stages
    assert 0.0 <= a.p_order <= 1.0 and 0.0 <= a.p_meets <= a.p_order + 1e-12
    for st in t.stages:
        s = a.stages[st.name]["end_pressure"]
        assert s["p05"] <= s["mean"] <= s["p95"] and s["std"] > 0


def test_library_materials_carry_fit_errors(gripper):
    t, best = gripper
    r = robustness(t, best, n_samples=5, seed=0, model=STANDIN, wall_tolerance=0.0,
                   default_cv=0.0)
    for name, u in r.uncertainty.items():
        assert "fit standard errors" in u["source"]
        assert u["std"] == material_stderr(get_material(name))
    # only the fit errors act: the spread is small but not zero
    s = r.stages[t.stages[0].name]["end_pressure"]
    assert 0 < s["std"] < 0.2 * s["mean"]


def test_spread_grows_with_tolerance(gripper):
    t, best = gripper
    lo = robustness(t, best, n_samples=60, seed=1, model=STANDIN, wall_tolerance=0.02e-3)
    hi = robustness(t, best, n_samples=60, seed=1, model=STANDIN, wall_tolerance=0.4e-3)
    for st in t.stages:
        assert hi.stages[st.name]["end_pressure"]["std"] > lo.stages[st.name]["end_pressure"]["std"]
    assert hi.p_meets <= lo.p_meets + 1e-12


def test_inline_material_uses_default_cv():
    t = target_from_spec(tomllib.loads((EXAMPLES / "target_jar_lifter.toml").read_text()))
    r = design(t, model=STANDIN, settings=DesignSettings(budget=600, population=12, seed=0))
    rep = robustness(t, r.best, n_samples=30, seed=0, model=STANDIN, wall_tolerance=0.0,
                     default_cv=0.0)
    u = rep.uncertainty["elastomer-III"]
    assert "default coefficient of variation" in u["source"]
    # no uncertainty at all: every sample is the nominal design
    for sr in r.best.stages:
        s = rep.stages[sr.name]["end_pressure"]
        assert s["std"] == pytest.approx(0.0, abs=1e-6) and s["mean"] == pytest.approx(sr.end)
    assert rep.p_order == 1.0
    np.testing.assert_allclose(rep.samples["sealer"]["end_pressure"], r.best.stages[0].end)


def test_samples_outside_the_model_support_are_counted_apart():
    """A design whose tolerance scatter leaves the model's support: the samples the model
    cannot answer are counted (``outside_support``), never passed off as stages that do not
    activate, and the probabilities are also given over the answered samples."""
    from multimorph.errors import OutsideSupportError

    t = target_from_spec(tomllib.loads((EXAMPLES / "target_jar_lifter.toml").read_text()))
    r = design(t, model=STANDIN, settings=DesignSettings(budget=600, population=12, seed=0))
    nominal = [c.top_wall for c in r.best.candidate.cells]
    S = len(t.stages)
    refused: list[int] = []

    def bounded(cells, p_max):
        # the first stage's support ends at its nominal top wall (the design at its edge)
        out = STANDIN(cells, p_max)
        for k, c in enumerate(cells):
            if k % S == 0 and c.top_wall > nominal[0]:
                out[k] = OutsideSupportError("outside the calibrated box; no prediction")
                refused.append(k // S)
        return out

    free = robustness(t, r.best, n_samples=40, seed=2, model=STANDIN)
    rep = robustness(t, r.best, n_samples=40, seed=2, model=bounded)
    n_out = len(set(refused))
    assert 5 < n_out < 35 and rep.outside_support == n_out
    assert free.outside_support == 0 and free.p_order_supported == free.p_order
    first = rep.stages[t.stages[0].name]
    assert first["start_pressure"]["outside_support"] == n_out
    assert first["start_pressure"]["missing"] >= n_out
    assert rep.stages[t.stages[1].name]["start_pressure"]["outside_support"] == 0
    # unanswered samples fail in p_order; over the answered ones the stand-in's own answer
    answered = 40 - n_out
    assert rep.p_order == pytest.approx(rep.p_order_supported * answered / 40)
    assert rep.p_meets == pytest.approx(rep.p_meets_supported * answered / 40)
    assert rep.p_order_supported >= rep.p_order
    d = rep.to_dict()
    assert d["outside_support"] == n_out and d["p_order_supported"] == rep.p_order_supported
    # the stage statistics are over the answered samples: no zero motion stands in
    for key in ("start_pressure", "end_pressure", "magnitude"):
        assert first[key]["missing"] >= first[key]["outside_support"] == n_out
    assert np.isnan(rep.samples[t.stages[0].name]["magnitude"]).sum() >= n_out
