"""FE in the loop (issue 19): one correction round of a small two-stage device in 3D FE,
by both routes (each stage's module on its own, the default, and the whole device).

The FE is kept small (one element through each wall, a few dozen continuation
steps: stiffer than the converged FE, which does not matter here). Checked: the rounds'
bookkeeping (the FE values are the device FE's, the correction of round 1 is round 0's
FE/model ratio), that the corrected design moves the FE result toward the targets, and
that a second run re-uses the finished FE rounds instead of recomputing them.
"""

import json
import tomllib

import pytest

from multimorph.design import DesignSettings, run_design, target_from_spec
from multimorph.design._fe_check import FE_CHECK_FORMAT

pytestmark = pytest.mark.slow
pytest.importorskip("felupe")

#: re-tuned at stop 33 (the bending model answers as the cell inside a module, softer for
#: one-elastomer cells): 20 kPa / 20–26 kPa / 32 kPa became infeasible on it (the stiffest
#: Dragon Skin 10 stalk in this box completes by 23 kPa)
TARGET = """
[target]
name = "small two-stage"

[[stage]]
name = "seal"
kind = "stretch"
stretch = "60 %"
pressure = "16 kPa"

[[stage]]
name = "stalk"
kind = "bend"
angle = "30 deg"
band = ["16 kPa", "18.5 kPa"]

[constraints]
max_pressure = "26 kPa"
materials = ["dragon-skin-10"]
min_wall = "1 mm"
max_length = "40 mm"
max_width = "10 mm"
max_height = "8 mm"
min_separation = "-10 %"
min_safety_factor = 1.2
"""

FE = dict(fe_wall_elements=1, fe_max_steps=40)


def _run(folder, route):
    from multimorph.models import batch_model

    target = target_from_spec(tomllib.loads(TARGET))
    return run_design(target, DesignSettings(budget=1200, population=24, seed=3),
                      model=batch_model("calibrated-fast", fallback=False),
                      robustness_samples=0, fe_rounds=1, fe_folder=folder, fe_route=route,
                      **FE)


def _miss(ev, target):
    """Σ over stages of |FE − wanted| / wanted for Ph (1 where FE has none)."""
    out = 0.0
    for stage, sr in zip(target.stages, ev.stages, strict=True):
        out += 1.0 if sr.end is None else abs(sr.end / stage.end_pressure - 1)
    return out


@pytest.mark.parametrize("route", ["modules", "device"])
def test_one_fe_round(tmp_path, monkeypatch, route):
    # the modules route's own mesh (the data set's, edges d/20) and its three cells a
    # module are what a design check needs, not what its bookkeeping needs: here each
    # module by one cell on edges d/10 (3.5 min -> well under one on this machine)
    monkeypatch.setattr("multimorph.design._fe_check.MODULE_LENGTH_FRACTION", 0.1)
    monkeypatch.setattr("multimorph.design._fe_check.MODULE_FE_MAX_CELLS", 1)
    folder = tmp_path / "fe"
    run = _run(folder, route)
    r = run.result
    assert r.fe_rounds, "no FE round ran"
    assert [rd.index for rd in r.fe_rounds] == list(range(len(r.fe_rounds)))
    assert r.fe_rounds[0].correction is None
    files = sorted(folder.glob("*.json"))
    assert len(files) == len(r.fe_rounds)
    saved = [json.loads(f.read_text()) for f in files]
    assert all(s["format"] == FE_CHECK_FORMAT and s["route"] == route for s in saved)
    if route == "modules":
        # one FE run per stage's module, each kept on its own (resumable module by module),
        # keyed by the module as written (a module two designs share runs once)
        parts = [json.loads(p.read_text()) for p in (folder / "modules").glob("*.json")]
        assert len(parts) <= 2 * len(saved)
        # the seal is joined to the stalk (its end held by a plate), the stalk's tip free
        assert {(p["module"], p["description"]["end"]) for p in parts} == {
            ("seal", "plate"), ("stalk", "free")}
        assert {p["device_key"] for p in parts} <= {s["key"] for s in saved}
        for s in saved:
            assert set(s["stats"]) == {"seal", "stalk"}
        # the measured motions have the stages' sense: the seal lengthens, the stalk bends
        for rd in r.fe_rounds:
            seal, stalk = rd.check.stages
            assert seal.magnitude > 0 and stalk.magnitude > 0
    # each round's FE values are those the device FE measured
    by_key = {tuple((row["name"], row["end"]) for row in s["stages"]) for s in saved}
    for rd in r.fe_rounds:
        assert tuple((st.name, st.end) for st in rd.check.stages) in by_key
        assert set(rd.factors) == {f"{st.name}.{q}" for st in rd.wanted.stages
                                   for q in ("start_pressure", "end_pressure", "magnitude")}
    assert r.fe_verified == r.fe_best.meets
    d = r.to_dict()
    assert d["fe_verified"] == r.fe_verified and len(d["fe_rounds"]) == len(r.fe_rounds)
    if len(r.fe_rounds) == 2:
        first, second = r.fe_rounds
        # round 1 searched on the model corrected by round 0's FE/model ratios
        for st, corr in zip(first.wanted.stages, second.correction, strict=True):
            for q in ("start_pressure", "end_pressure", "magnitude"):
                assert corr[q] == pytest.approx(first.factors[f"{st.name}.{q}"])
        t = first.wanted
        if route == "device":
            # and moved the FE result toward the targets
            assert (_miss(second.check, t) < _miss(first.check, t)
                    or second.check.objective < first.check.objective)
        # the design kept is the best FE-checked one: a round that moves away from the
        # targets (on the modules route here the stalk's FE bend is 0.73 of the model's
        # and round 1 overshoots it: objective 3.9 -> 10.9; the device route improves,
        # 3.4 -> 1.4, stop 33) does not replace it
        assert r.fe_best.objective == min(rd.check.objective for rd in r.fe_rounds)
    # a second run re-uses the finished FE rounds (no new FE file, same FE values)
    again = _run(folder, route).result
    assert sorted(folder.glob("*.json")) == files
    assert [[s.end for s in rd.check.stages] for rd in again.fe_rounds] == \
        [[s.end for s in rd.check.stages] for rd in r.fe_rounds]
