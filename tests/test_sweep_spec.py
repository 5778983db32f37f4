"""Sweep specs: parsing, design tables, and precise errors for bad specs."""

from __future__ import annotations

import copy
import math
import tomllib

import numpy as np
import pytest

from multimorph.errors import SpecError
from multimorph.sweep import parse_sweep_spec

BASE = """
[cell]
length = "20 mm"
width = "10 mm"
height = "8 mm"
top_wall = "1 mm"
bottom_wall = "2 mm"
side_wall = "2 mm"
end_wall = "2 mm"

[cell.material]
model = "gent"
mu = "245 kPa"
jm = 20

[sweep]
backend = "rom"
outputs = ["characteristic", "curves"]
pmax = "60 kPa"
"""


def spec(extra: str) -> dict:
    return tomllib.loads(BASE + extra)


def test_grid_of_list_and_linear_range_with_units() -> None:
    s = parse_sweep_spec(spec("""
[[sweep.parameter]]
name = "cell.top_wall"
values = ["0.5 mm", "1 mm"]
[[sweep.parameter]]
name = "df/d"
start = 0.05
stop = 0.15
num = 3
"""))
    assert s.pmax == 60e3 and s.n_designs == 6
    t = s.design_table()
    assert t.names == ("cell.top_wall", "df/d")
    np.testing.assert_allclose(t.values[:, 0], [5e-4] * 3 + [1e-3] * 3)
    np.testing.assert_allclose(t.values[:, 1], [0.05, 0.1, 0.15] * 2)
    # df/d sets the end wall to ratio × d; the top wall is the swept absolute value
    cell = t.cells[5]
    assert cell is not None
    assert cell.end_wall == pytest.approx(0.15 * 20e-3)
    assert cell.top_wall == pytest.approx(1e-3)
    assert not t.invalid


def test_table_form_log_range_and_zip() -> None:
    s = parse_sweep_spec(spec("""
combine = "zip"
[sweep.parameters]
"mu" = {start = "100 kPa", stop = "1 MPa", num = 3, scale = "log"}
"cell.material.jm" = [10, 20, 40]
"""))
    t = s.design_table()
    assert len(t) == 3
    np.testing.assert_allclose(t.values[:, 0], [1e5, math.sqrt(1e5 * 1e6), 1e6])
    for i, c in enumerate(t.cells):
        assert c is not None
        assert c.mu == pytest.approx(t.values[i, 0])  # mu scales the wall material
        assert c.material.jm == t.values[i, 1]
        assert c.bottom_material.shear_modulus == pytest.approx(245e3)  # bottom unchanged


def test_modulus_ratio_uses_the_final_wall_modulus() -> None:
    s = parse_sweep_spec(spec("""
[sweep.parameters]
"mu_b/mu" = [2.0, 4.0]
"mu" = ["100 kPa"]
"""))
    for c, r in zip(s.design_table().cells, [2.0, 4.0], strict=True):
        assert c is not None
        assert c.bottom_material.shear_modulus == pytest.approx(r * 100e3)


def test_random_sampling_is_seeded_and_inside_the_ranges() -> None:
    extra = """
combine = "random"
samples = 200
seed = 7
[sweep.parameters]
"ht/d" = {start = 0.02, stop = 0.08}
"mu" = {start = "100 kPa", stop = "1 MPa", scale = "log"}
"cell.side_wall" = ["1 mm", "2 mm"]
"""
    a = parse_sweep_spec(spec(extra)).point_values()
    b = parse_sweep_spec(spec(extra)).point_values()
    np.testing.assert_array_equal(a, b)
    assert a.shape == (200, 3)
    assert a[:, 0].min() >= 0.02 and a[:, 0].max() <= 0.08
    assert a[:, 1].min() >= 1e5 and a[:, 1].max() <= 1e6
    assert set(np.round(a[:, 2], 6)) == {0.001, 0.002}
    c = parse_sweep_spec(spec(extra.replace("seed = 7", "seed = 8"))).point_values()
    assert not np.array_equal(a, c)


def test_spec_hash_ignores_formatting_but_not_content() -> None:
    extra = '\n[sweep.parameters]\n"ht/d" = [0.05, 0.1]\n'
    raw = spec(extra)
    h = parse_sweep_spec(raw).spec_hash
    assert parse_sweep_spec(copy.deepcopy(raw)).spec_hash == h
    assert parse_sweep_spec(spec("# a comment\n" + extra)).spec_hash == h
    assert parse_sweep_spec(spec(extra.replace("0.1]", "0.11]"))).spec_hash != h


def test_invalid_geometry_points_are_listed_with_reasons_not_dropped() -> None:
    # width 10 mm: ws/d = 0.25 gives ws = 5 mm, which leaves no chamber
    s = parse_sweep_spec(spec("""
[[sweep.parameter]]
name = "ws/d"
values = [0.1, 0.25, 0.2, 0.3]
"""))
    t = s.design_table()
    assert len(t) == 4
    assert [p.index for p in t.invalid] == [1, 3]
    assert t.cells[1] is None and t.cells[0] is not None
    assert "side_wall 5 mm leaves no chamber in width 10 mm" in t.invalid[0].reason
    assert t.invalid[0].values == {"ws/d": 0.25}
    np.testing.assert_array_equal(t.valid_indices, [0, 2])


def test_invalid_material_points_are_listed() -> None:
    t = parse_sweep_spec(spec('[sweep.parameters]\n"cell.material.jm" = [20, -1]\n')
                         ).design_table()
    assert [p.index for p in t.invalid] == [1]
    assert "jm" in t.invalid[0].reason


@pytest.mark.parametrize(("extra", "message"), [
    ('[sweep.parameters]\n"cell.top_thickness" = [1]\n',
     "unknown parameter path 'cell.top_thickness'; known: cell.length"),
    ('[sweep.parameters]\n"ht/w" = [1]\n', "unknown parameter path 'ht/w'"),
    ('[sweep.parameters]\n"cell.material.c10" = [1]\n',
     "material model gent has parameters mu, jm"),
    ('[sweep.parameters]\n"ht/d" = []\n', "empty list"),
    ('[sweep.parameters]\n"ht/d" = {start = 0.01, stop = 0.1, num = 0}\n',
     "empty range (num = 0)"),
    ('combine = "random"\nsamples = 0\n[sweep.parameters]\n"ht/d" = {start = 0, stop = 1}\n',
     "empty sample"),
    ('[sweep.parameters]\n"ht/d" = {start = 0.01, num = 3}\n', "range needs stop"),
    ('[sweep.parameters]\n"mu" = {start = 0, stop = "1 MPa", num = 3, scale = "log"}\n',
     "log range needs start > 0"),
    ('[sweep.parameters]\n"cell.top_wall" = ["1 kPa"]\n', "expected a quantity in m"),
    ('[sweep.parameters]\n"ht/d" = {start = 0.01, stop = 0.1, num = 3, step = 1}\n',
     "unknown key(s) step"),
    ('[sweep.parameters]\n"ht/d" = [0.1]\n"cell.top_wall" = ["1 mm"]\n',
     "'ht/d' and 'cell.top_wall' both set top_wall"),
    ('combine = "zip"\n[sweep.parameters]\n"ht/d" = [0.1, 0.2]\n"ws/d" = [0.1]\n',
     "same number of values"),
    ('combine = "cartesian"\n[sweep.parameters]\n"ht/d" = [0.1]\n', "sweep.combine"),
    ('[sweep.parameters]\n"ht/d" = {start = 0.01, stop = 0.1}\n', "needs 'num'"),
    ("", "no parameters"),
    ('colour = "red"\n[sweep.parameters]\n"ht/d" = [0.1]\n', "unknown key(s) colour"),
])
def test_malformed_specs_are_rejected_with_precise_messages(extra: str, message: str) -> None:
    with pytest.raises(SpecError) as err:
        parse_sweep_spec(spec(extra))
    assert message in str(err.value)


def test_missing_tables_and_pmax() -> None:
    raw = spec('[sweep.parameters]\n"ht/d" = [0.1]\n')
    del raw["sweep"]["pmax"]
    with pytest.raises(SpecError, match=r"sweep\.pmax: missing"):
        parse_sweep_spec(raw)
    with pytest.raises(SpecError, match=r"missing the base design table \[cell\]"):
        parse_sweep_spec({"sweep": {}})
    with pytest.raises(SpecError, match="unknown table"):
        parse_sweep_spec({**spec(""), "device": {}})


def test_outputs_are_checked() -> None:
    raw = spec('[sweep.parameters]\n"ht/d" = [0.1]\n')
    raw["sweep"]["outputs"] = ["characteristic", "movies"]
    with pytest.raises(SpecError, match="unknown output 'movies'"):
        parse_sweep_spec(raw)
