"""Infeasible targets end with an explanation of the binding constraint (issue 6)."""

import tomllib

from multimorph.design import DesignSettings, design, target_from_spec
from test_design_helpers import STANDIN

SETTINGS = DesignSettings(budget=400, population=8, seed=0)

BASE = """
[[stage]]
name = "a"
kind = "bend"
angle = "{angle}"
pressure = "{p1}"

[[stage]]
name = "b"
kind = "bend"
angle = "-45 deg"
band = ["{p1}", "{p2}"]

[constraints]
max_pressure = "{pmax}"
materials = {materials}
{extra}
"""


def target(p1="30 kPa", p2="50 kPa", pmax="60 kPa", materials='["ecoflex-00-30"]', extra="",
           angle="90 deg"):
    return target_from_spec(tomllib.loads(BASE.format(p1=p1, p2=p2, pmax=pmax, angle=angle,
                                                      materials=materials, extra=extra)))


def test_stage_beyond_max_pressure():
    r = design(target(p2="80 kPa"), model=STANDIN, settings=SETTINGS)
    assert not r.feasible and r.designs == [] and r.evaluations == 0
    assert any("max_pressure binds" in e and "'b'" in e and "80 kPa" in e
               for e in r.explanation)


def test_walls_cannot_fit_the_cell():
    r = design(target(extra='min_wall = "5 mm"\nmax_width = "8 mm"'), model=STANDIN,
               settings=SETTINGS)
    assert not r.feasible and r.evaluations == 0
    assert any("max_width 8 mm" in e and "min_wall 5 mm" in e for e in r.explanation)


def test_pressure_beyond_the_stiffest_material():
    # ecoflex-00-30 (μ ≈ 15 kPa): even its stiffest cell completes far below 150 kPa
    r = design(target(p1="120 kPa", p2="150 kPa", pmax="200 kPa"), model=STANDIN,
               settings=SETTINGS)
    assert not r.feasible and r.designs == []
    text = " ".join(r.explanation)
    assert "stiffest allowed design" in text and "ecoflex-00-30" in text
    assert "stiffer material" in text
    assert r.reachable["a"]["stiffest_end_pressure"]["ecoflex-00-30"] < 120e3


def test_pressure_below_the_softest_design():
    # sortaclear-40 (μ ≈ 300 kPa) with 3 mm walls cannot start moving by 5 kPa
    r = design(target(p1="3 kPa", p2="5 kPa", materials='["sortaclear-40"]',
                      extra='min_wall = "3 mm"'), model=STANDIN, settings=SETTINGS)
    assert not r.feasible
    text = " ".join(r.explanation)
    assert "softest allowed design" in text and "min_wall = 3 mm" in text


def test_unmet_target_is_reported_not_silent():
    # reachable pressures but a magnitude far beyond what max_length allows
    r = design(target(materials='["dragon-skin-10"]', extra='max_length = "12 mm"',
                      angle="600 deg"),
               model=STANDIN,
               settings=SETTINGS)
    assert not r.feasible and r.best is not None and not r.best.meets
    text = " ".join(r.explanation)
    assert "magnitude" in text and "max_length" in text


def test_a_stretch_stage_of_a_wall_that_does_not_snap_says_so():
    """The jar lifter's target with a strongly hardening Yeoh elastomer (c20/c10 0.08):
    its stretching cells have no knee (the membrane rule, FE: `yeoh_stretching_mirror`),
    so the stretch stage cannot activate in it, whatever the walls — said as such, not
    as "too stiff" (the calibrated model; reachability alone, no search)."""
    from pathlib import Path

    from multimorph.models import batch_model

    spec = tomllib.loads((Path(__file__).parents[1] / "examples" / "target_jar_lifter.toml")
                         .read_text())
    spec["constraints"]["materials"] = [{"name": "yeoh-rubber", "model": "yeoh",
                                         "c10": "122.5 kPa", "c20": "10 kPa",
                                         "c30": "0 kPa", "break_stretch": 8.0}]
    r = design(target_from_spec(spec), model=batch_model("calibrated-fast"),
               settings=DesignSettings(budget=8, population=4, seed=0))
    assert not r.feasible
    text = " ".join(r.explanation)
    assert "'sealer' (stretch) cannot activate" in text and "limit point" in text
    assert "softest allowed design" not in text
