"""Target specs (issue 6): the shipped examples parse; malformed specs get precise errors."""

import math
import tomllib
from pathlib import Path

import pytest

from multimorph.design import target_from_spec
from multimorph.errors import SpecError

EXAMPLES = sorted((Path(__file__).parents[1] / "examples").glob("target_*.toml"))

BASE = """
[target]
name = "t"

[[stage]]
name = "a"
kind = "bend"
angle = "90 deg"
pressure = "30 kPa"

[[stage]]
name = "b"
kind = "twist"
angle = "45 deg"
band = ["30 kPa", "50 kPa"]

[constraints]
max_pressure = "60 kPa"
materials = ["ecoflex-00-30", "dragon-skin-10"]
"""


def parse(text):
    return target_from_spec(tomllib.loads(text))


def test_examples_parse():
    assert len(EXAMPLES) == 4
    for path in EXAMPLES:
        t = target_from_spec(tomllib.loads(path.read_text()))
        assert t.stages and t.constraints.max_pressure > 0


def test_units_and_defaults():
    t = parse(BASE)
    a, b = t.stages
    assert math.isclose(a.magnitude, math.pi / 2)
    assert a.end_pressure == 30e3 and a.start_pressure is None
    assert (b.start_pressure, b.end_pressure) == (30e3, 50e3)
    c = t.constraints
    assert c.min_wall == 1e-3                       # default 1 mm
    assert c.separation_relative and c.min_separation == -0.10
    assert t.tolerance.pressure == 0.10 and t.tolerance.magnitude == 0.15
    assert [m.name for m in c.materials] == ["ecoflex-00-30", "dragon-skin-10"]
    assert c.min_cells == 3                         # default: modules of 3 cells or more
    assert parse(BASE.replace('max_pressure = "60 kPa"',
                              'max_pressure = "60 kPa"\nmin_cells = 1')).constraints.min_cells == 1


def test_a_module_has_at_least_min_cells():
    """``cells_for``: the cells that give the wanted angle, but never fewer than
    ``min_cells`` (a module of one or two cells is mostly ends, which the cell models do not
    describe) nor more than ``max_length`` leaves; a stretch stage (its magnitude does not
    depend on the count) gets ``min_cells``."""
    from multimorph.design._space import cells_for

    a = parse(BASE).stages[0]                       # a 90° bend
    per = math.radians(45.0)
    assert cells_for(a, per, max_cells=10) == 2      # 90 / 45: the angle alone
    assert cells_for(a, per, max_cells=10, min_cells=3) == 3
    assert cells_for(a, math.radians(10.0), max_cells=10, min_cells=3) == 9
    assert cells_for(a, per, max_cells=2, min_cells=3) == 2     # what max_length leaves
    stretch = parse(BASE.replace('angle = "90 deg"', 'stretch = "50 %"', 1)
                    .replace('kind = "bend"', 'kind = "stretch"', 1)).stages[0]
    assert cells_for(stretch, 0.5, max_cells=10) == 1
    assert cells_for(stretch, 0.5, max_cells=10, min_cells=3) == 3


def test_separation_forms_and_inline_material():
    t = parse(BASE.replace('materials = ["ecoflex-00-30", "dragon-skin-10"]',
                           'materials = [{model = "gent", mu = "100 kPa", jm = 20}]\n'
                           'min_separation = "2 kPa"'))
    assert not t.constraints.separation_relative and t.constraints.min_separation == 2e3
    assert t.constraints.materials[0].shear_modulus == 1e5
    assert t.constraints.materials[0].name == "material1"


@pytest.mark.parametrize("old,new,message", [
    ('kind = "bend"', 'kind = "curl"', "stage[0] (a).kind: must be one of bend, twist, stretch"),
    ('angle = "90 deg"', 'angle = 90', "stage[0] (a).angle: give the unit"),
    ('angle = "90 deg"', 'stretch = "20 %"', "a bend stage takes 'angle'"),
    ('angle = "90 deg"\n', '', "stage[0] (a).angle: missing"),
    ('pressure = "30 kPa"', 'pressure = "30 kPa"\nband = ["1 kPa", "2 kPa"]',
     "give exactly one of 'pressure'"),
    ('band = ["30 kPa", "50 kPa"]', 'band = ["50 kPa", "30 kPa"]',
     "band: the end '30 kPa' must exceed the start"),
    ('band = ["30 kPa", "50 kPa"]', 'band = ["30 kPa"]', "band: expected two pressures"),
    ('pressure = "30 kPa"', 'pressure = "30 mm"', "stage[0] (a).pressure"),
    ('pressure = "30 kPa"', 'pressure = "-3 kPa"', "must be a positive pressure"),
    ('pressure = "30 kPa"', 'pressure = "70 kPa"', "stages are listed in the order"),
    ('name = "b"', 'name = "a"', "stage names must be unique; repeated: a"),
    ('max_pressure = "60 kPa"', '', "constraints.max_pressure: missing"),
    ('materials = ["ecoflex-00-30", "dragon-skin-10"]', 'materials = ["unobtainium"]',
     "unknown material 'unobtainium'"),
    ('materials = ["ecoflex-00-30", "dragon-skin-10"]', 'materials = []',
     "constraints.materials: missing"),
    ('max_pressure = "60 kPa"', 'max_pressure = "60 kPa"\nmin_wall = "-1 mm"',
     "constraints.min_wall: must be a positive length"),
    ('max_pressure = "60 kPa"', 'max_pressure = "60 kPa"\nmax_widht = "2 mm"',
     "[constraints]: unknown key(s) max_widht"),
    ('kind = "twist"', 'kind = "twist"\nshaft = 3', "unknown key(s) shaft"),
    ('[target]', '[targte]', "unknown top-level key(s) targte"),
    ('max_pressure = "60 kPa"', 'max_pressure = "60 kPa"\nmin_cells = 0',
     "constraints.min_cells: must be a whole number from 1 to 20, got 0"),
    ('max_pressure = "60 kPa"', 'max_pressure = "60 kPa"\nmin_cells = 2.5',
     "constraints.min_cells: must be a whole number"),
    ('max_pressure = "60 kPa"', 'max_pressure = "60 kPa"\nmin_cells = "3"',
     "constraints.min_cells: must be a whole number"),
])
def test_precise_errors(old, new, message):
    assert old in BASE
    with pytest.raises(SpecError) as exc:
        parse(BASE.replace(old, new, 1))
    assert message in str(exc.value)


def test_no_stages_and_tolerance_errors():
    with pytest.raises(SpecError, match="needs at least one"):
        parse('[constraints]\nmax_pressure = "1 kPa"\nmaterials = ["ecoflex-00-30"]')
    with pytest.raises(SpecError, match=r"tolerance\.pressure"):
        parse(BASE + '\n[tolerance]\npressure = "ten"\n')
    with pytest.raises(SpecError, match="shaft_radius: only twist stages"):
        parse(BASE.replace('pressure = "30 kPa"', 'pressure = "30 kPa"\nshaft_radius = "4 mm"'))
