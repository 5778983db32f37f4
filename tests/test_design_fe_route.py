"""The ``modules`` route of the design's FE check (issue 19), without FE: how each module's
far end is held when it is inflated on its own, and what is measured on its response."""

from pathlib import Path

import numpy as np
import pytest

from multimorph.design import FE_ROUTES, fe_checker, module_measure
from multimorph.design._fe_check import module_end
from multimorph.device import device_from_spec
from multimorph.errors import MultimorphError
from multimorph.io import load_toml
from multimorph.response import EquilibriumPath, build_response

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_a_module_joined_at_its_end_has_a_plate_there_and_a_tip_is_free() -> None:
    # jar lifter (the FE-verified design, stop 33): the sealer at the base carries the
    # lifter; the lifter's end is the tip
    jar = device_from_spec(load_toml(EXAMPLES / "jar_lifter.toml"))
    assert [m.name for m in jar.modules] == ["sealer", "lifter"]
    assert module_end(jar, "sealer") == "plate"
    assert module_end(jar, "lifter") == "free"
    # gripper: the fingers' hub sits at the twister's end; each finger's tip is free
    gripper = device_from_spec(load_toml(EXAMPLES / "gripper.toml"))
    assert module_end(gripper, "twister") == "plate"
    assert module_end(gripper, "fingers") == "free"


def _bending(p_max: float, pc: float, width: float, kappa_max: float, length: float):
    """A κ(P) that rises steepest at ``pc`` (tanh) and saturates at ``kappa_max``."""
    P = np.linspace(0.0, p_max, 201)
    z = np.zeros_like(P)
    kappa = 0.5 * kappa_max * (1 + np.tanh((P - pc) / width))
    path = EquilibriumPath(P, kappa, z, z + 1, 1 + P, z + 1.5, np.ones_like(P, bool))
    return build_response(path, length=length, shear_modulus=1e5, backend="fe")


def test_module_measure_reads_pc_ph_and_the_bend_at_ph() -> None:
    L = 0.03
    r = _bending(60e3, 20e3, 3e3, 50.0, L)
    pc, ph, mag, peak = module_measure("bend", r, L, 60e3)
    ch = r.characteristic
    assert pc == pytest.approx(ch.critical) and ph == pytest.approx(ch.hardening)
    assert pc == pytest.approx(20e3, rel=0.02) and pc < ph < 60e3
    # the motion is the bend angle κ(Ph)·L of the module
    P, k = r.loading.pressure, r.loading.curvature
    assert mag == pytest.approx(float(np.interp(ph, P, k)) * L, rel=1e-9)
    assert peak == pytest.approx(1.5)
    # pressures above the target's maximum do not count: nothing reached, the motion at the
    # top of the stable loading curve
    pc2, ph2, mag2, _ = module_measure("bend", r, L, 15e3)
    assert pc2 is None and ph2 is None
    assert mag2 == pytest.approx(float(k[-1]) * L)


def test_an_unknown_route_is_refused_before_any_fe(tmp_path) -> None:
    assert FE_ROUTES[0] == "modules"
    with pytest.raises(MultimorphError, match="--fe-route"):
        fe_checker(tmp_path, route="whole")
    assert not any(tmp_path.iterdir())


def test_designed_twist_strips_fit_on_their_shaft() -> None:
    """A twist stage's cells are at most as wide as a face of its shaft (three strips on a
    triangular shaft: 2 r tan 60°), so the designed module can be built and meshed — the
    gripper designed before this rule had 19.4 mm strips on 17.3 mm faces."""
    import math

    from multimorph.design import SearchSpace, build_device, target_from_spec
    from multimorph.fe.mesh import twisting_module_mesh
    from multimorph.models import batch_model

    target = target_from_spec(load_toml(EXAMPLES / "target_gripper.toml"))
    twist = next(s for s in target.stages if s.kind == "twist")
    face = 2.0 * twist.shaft_radius * math.tan(math.pi / 3)
    for boxes in (None, batch_model("calibrated-fast", fallback=False).support_boxes()):
        space = SearchSpace(target, boxes=boxes)
        rng = np.random.default_rng(1)
        xs = rng.random((64, space.dim))
        xs[0], xs[1] = 1.0, 0.0                     # the widest and narrowest corners
        widths = [space.decode(x).cells[target.stages.index(twist)].width for x in xs]
        assert max(widths) <= face * (1 + 1e-9)
        assert max(widths) > 0.8 * face             # the bound is reached, not over-tight
    cand = space.decode(xs[0])
    device = build_device(target, cand, [4] * len(target.stages))
    module = device.module(twist.name)
    assert module.strips == 3
    twisting_module_mesh(module, "coarse")        # no "strips do not fit" refusal


def test_twist_tilts_stay_where_the_strip_shear_was_calibrated() -> None:
    """With the calibrated model the designer's tilts keep to the tilts its strip shear was
    fitted on (its FE data: a factor held at its edge beyond them is an extrapolation);
    without a calibrated range, the whole meshable range."""
    from multimorph.design import SearchSpace, target_from_spec
    from multimorph.design._space import TILT_RANGE
    from multimorph.models import batch_model

    target = target_from_spec(load_toml(EXAMPLES / "target_gripper.toml"))
    i = next(k for k, s in enumerate(target.stages) if s.kind == "twist")
    boxes = batch_model("calibrated-fast", fallback=False).support_boxes()
    lo, hi = boxes["tilt"]
    assert TILT_RANGE[0] <= lo < hi <= TILT_RANGE[1]
    xs = np.random.default_rng(2).random((64, SearchSpace(target).dim))
    xs[0], xs[1] = 0.0, 1.0
    for bx, (a, b) in ((boxes, (lo, hi)), (None, TILT_RANGE)):
        tilts = [SearchSpace(target, boxes=bx).decode(x).tilts[i] for x in xs]
        assert min(tilts) == pytest.approx(a) and max(tilts) == pytest.approx(b)


def _tilted_fe_response(module, p_max: float, pc: float, width: float, gamma_max: float):
    """A tilted cell's FE response: its strip shear γ(P) (tanh, steepest at ``pc``) as the FE
    records it (``extra["shear"]``, of the opposite sign to the tilt), no bend."""
    P = np.linspace(0.0, p_max, 201)
    z = np.zeros_like(P)
    gamma = 0.5 * gamma_max * (1 + np.tanh((P - pc) / width))
    fe_sign = -np.sign(module.tilt)
    path = EquilibriumPath(P, z, z, z + 1, 1 + P, z + 1.5, np.ones_like(P, bool),
                           extra={"shear": fe_sign * gamma})
    return build_response(path, length=module.cell.length, shear_modulus=1e5, backend="fe"), \
        gamma


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_the_strip_twist_route_twists_the_module_by_its_shaft_kinematics(sign) -> None:
    from dataclasses import replace

    from multimorph.design import TWIST_ROUTES, strip_twist_response
    from multimorph.device import module_strains

    gripper = device_from_spec(load_toml(EXAMPLES / "gripper.toml"))
    module = gripper.module("twister")
    module = replace(module, tilt=sign * abs(module.tilt))
    cell_resp, gamma = _tilted_fe_response(module, 60e3, 30e3, 3e3, 0.4)
    r = strip_twist_response(module, cell_resp)
    # τ = γ / R, R the shaft radius plus half the strip's height, in the tilt's sense
    R = module.shaft_radius + 0.5 * module.cell.height
    assert np.allclose(r.path.twist_rate, gamma / R)
    assert r.length == pytest.approx(module.length)
    # Pc and Ph are those of the strip shear; the motion is the twist angle τ(Ph)·L
    pc, ph, mag, _ = module_measure("twist", r, module.length, 60e3)
    assert pc == pytest.approx(30e3, rel=0.02) and pc < ph < 60e3
    assert mag == pytest.approx(float(np.interp(ph, r.loading.pressure, gamma / R))
                                * module.length, rel=1e-6)
    # the same twist as the cell models' module reads from a tilted cell's shear
    sensed = replace(cell_resp.path, extra={"shear": gamma})
    model_side = module_strains(module, build_response(
        sensed, length=module.cell.length, shear_modulus=1e5, backend="fe"))
    assert np.allclose(np.abs(model_side.twist), np.interp(
        model_side.pressure, r.path.pressure, r.path.twist_rate))
    assert TWIST_ROUTES[0] == "strip"
    with pytest.raises(MultimorphError, match="--fe-twist"):
        fe_checker(Path("."), twist="spiral")


def test_a_long_module_is_checked_by_a_few_of_its_cells(tmp_path, monkeypatch) -> None:
    """The ``modules`` route inflates a bending module of more than MODULE_FE_MAX_CELLS
    cells as that many of its cells with the module's end, and reads the motion per length
    on the module's own length (FE is replaced by a recorder: what is asked of it)."""
    import multimorph.fe as fe
    from multimorph.design import SearchSpace, build_device, evaluate_one, target_from_spec
    from multimorph.design._fe_check import MODULE_FE_MAX_CELLS
    from test_design_helpers import STANDIN

    target = target_from_spec(load_toml(EXAMPLES / "target_jar_lifter.toml"))
    space = SearchSpace(target)
    cand = space.decode(np.full(space.dim, 0.5))
    n = [1, MODULE_FE_MAX_CELLS + 4]                     # sealer 1 cell, lifter 7 cells
    resps = STANDIN(list(cand.cells), target.constraints.max_pressure)
    ev = evaluate_one(target, cand, resps, fixed_cells=n)
    assert build_device(target, cand, n).module("lifter").n_cells == n[1]
    asked = {}

    class Result:
        def __init__(self, response):
            self.response = response
            self.stats = {"points": 3, "nfree": 1}

    def fake(cell, settings, n_cells=1, progress=None, checkpoint=None, end="plate", **kw):
        asked[cell.symmetric] = (n_cells, end)
        return Result(_bending(target.constraints.max_pressure, 100e3, 5e3, 40.0,
                               n_cells * cell.length))

    monkeypatch.setattr(fe, "simulate_cell", fake)
    out = fe_checker(tmp_path)(target, [ev])[0]
    assert asked[False] == (MODULE_FE_MAX_CELLS, "free")   # the lifter: 3 of its 7 cells
    assert asked[True] == (1, "plate")                      # the sealer: all of it
    lifter = next(s for s in out.stages if s.name == "lifter")
    cell = cand.cells[1]
    # the motion: the recorded curvature at Ph over the whole module's length
    r = _bending(target.constraints.max_pressure, 100e3, 5e3, 40.0, 1.0)
    k_ph = float(np.interp(lifter.end, r.loading.pressure, r.loading.curvature))
    assert lifter.magnitude == pytest.approx(k_ph * n[1] * cell.length, rel=1e-6)
    import json

    # each module's FE is kept under its own key (stop 39), with what it was run on
    saved = [json.loads(f.read_text()) for f in (tmp_path / "modules").glob("*.json")]
    lifter_run = next(d for d in saved if d["module"] == "lifter")
    stats = lifter_run["stats"]
    assert stats["fe_cells"] == MODULE_FE_MAX_CELLS and stats["module_cells"] == n[1]
    assert lifter_run["description"]["cells"] == n[1]
    assert lifter_run["description"]["end"] == "free"
