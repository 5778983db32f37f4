"""Device simulation wiring with an injected cell model of known response (issue 4).

The cell model here is a closed-form stand-in (a smooth step in curvature), injected
through the same interface the ROM and FE backends fill, so the device-level kinematics
and bookkeeping are checked against exact answers independently of any cell model.
"""

import math
import tomllib

import numpy as np
import pytest

from multimorph.device import device_from_spec, simulate_device
from multimorph.response import CharacteristicPressures, EquilibriumPath, Response

SPEC = """
[device]
name = "two-stage"
pmax = "60 kPa"

[materials.soft]
model = "gent"
mu = "50 kPa"
jm = 15

[materials.hard]
model = "gent"
mu = "150 kPa"
jm = 15

[cells.soft]
length = "5 mm"
width = "10 mm"
height = "8 mm"
top_wall = "1 mm"
bottom_wall = "2 mm"
side_wall = "1.5 mm"
end_wall = "1 mm"
material = "soft"

[cells.hard]
length = "5 mm"
width = "10 mm"
height = "8 mm"
top_wall = "1 mm"
bottom_wall = "2 mm"
side_wall = "1.5 mm"
end_wall = "1 mm"
material = "hard"

[[module]]
name = "base"
kind = "bending"
cell = "soft"
cells = 4

[[module]]
name = "tip"
kind = "bending"
cell = "hard"
cells = 4
orientation = "180 deg"
"""


def step_model(cell, p_max):
    # curvature rises from 0 to K between Pc = 0.3 mu and Ph = 0.5 mu (mu of the walls)
    mu = cell.material.shear_modulus
    p = np.linspace(0.0, p_max, 301)
    x = np.clip((p / mu - 0.3) / 0.2, 0.0, 1.0)
    kappa = 40.0 * (3 * x**2 - 2 * x**3)
    ones = np.ones_like(p)
    path = EquilibriumPath(p, kappa, 0 * p, ones, 1e-7 * (1 + kappa / 40), 1 + kappa / 100,
                           ones.astype(bool))
    pc, ph = 0.3 * mu, 0.5 * mu
    ch = CharacteristicPressures(pc if pc < p_max else None, "max_slope",
                                 ph if ph < p_max else None, None)
    unload = path.take(slice(None, None, -1))
    return Response(path, path, unload, ch, cell.length, mu, "test")


@pytest.fixture(scope="module")
def result():
    return simulate_device(device_from_spec(tomllib.loads(SPEC)), cell_model=step_model)


def test_sequence_follows_the_moduli(result):
    seq = result.sequence
    assert seq.order == ["base", "tip"]
    # base: Pc 15 kPa, Ph 25 kPa; tip: Pc 45 kPa -> a gap of 20 kPa
    assert seq.margins[0]["margin"] == pytest.approx(20e3)
    assert seq.margins[0]["verdict"] == "gap"
    assert [b["module"] for b in seq.bands] == ["base", "tip"]
    assert seq.unloading_order == ["tip", "base"]


def test_shape_at_zero_pressure_is_straight_along_y(result):
    lines = result.shape(0.0)
    pts = np.concatenate([lines["base"], lines["tip"]])
    np.testing.assert_allclose(pts[:, [0, 2]], 0.0, atol=1e-15)
    assert pts[:, 1].max() == pytest.approx(0.04)


def test_opposite_orientation_bends_the_other_way(result):
    # at 30 kPa the base is fully bent (kappa = 40 1/m over 20 mm), the tip not yet
    lines = result.shape(30e3)
    base = lines["base"]
    theta = 40.0 * 0.02
    # circular arc toward -z of radius 1/40
    assert base[-1, 1] == pytest.approx(math.sin(theta) / 40.0, rel=1e-9)
    assert base[-1, 2] == pytest.approx(-(1 - math.cos(theta)) / 40.0, rel=1e-9)
    # at 60 kPa the tip (mu = 150 kPa) is half-way: kappa = 20 1/m bending the other way,
    # so the end tangent has turned by -0.8 + 0.4 = -0.4 rad about x
    tip = result.shape(60e3)["tip"]
    chord = tip[-1] - tip[-2]
    angle = math.atan2(chord[2], chord[1])
    step = 0.4 / 16  # the last chord lags the end tangent by half an angle step
    assert angle == pytest.approx(-0.4 - 0.5 * step, abs=1e-9)
    assert abs(chord[0]) < 1e-15


def test_summary_is_json_ready(result):
    d = result.to_dict()
    assert d["modules"]["base"]["critical_pressure"] == pytest.approx(15e3)
    assert d["modules"]["tip"]["hardening_pressure"] is None  # 75 kPa is beyond pmax
    assert d["sequence"]["order"] == ["base", "tip"]
