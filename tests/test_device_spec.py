"""Device spec parsing and validation: precise errors for malformed devices (issue 4)."""

import math
import tomllib

import pytest

from multimorph.device import device_from_spec
from multimorph.errors import SpecError

BASE = """
[device]
name = "test"
pmax = "60 kPa"

[materials.soft]
model = "gent"
mu = "60 kPa"
jm = 15

[cells.c]
length = "6 mm"
width = "10 mm"
height = "8 mm"
top_wall = "1 mm"
bottom_wall = "2 mm"
side_wall = "1.5 mm"
end_wall = "1 mm"
material = "soft"
bottom_material = { model = "gent", mu = "1 MPa", jm = 30 }

[[module]]
name = "twister"
kind = "twisting"
cell = "c"
cells = 5
tilt = "30 deg"
shaft_radius = "5 mm"

[[module]]
name = "finger"
kind = "bending"
cell = "c"
cells = 8
attach_to = "twister"
count = 3
radius = "8 mm"
"""


def parse(text):
    return device_from_spec(tomllib.loads(text))


def test_valid_device_parses_with_si_values():
    dev = parse(BASE)
    tw, fi = dev.modules
    assert dev.pmax == pytest.approx(60e3)
    assert tw.tilt == pytest.approx(math.radians(30))
    assert tw.shaft_radius == pytest.approx(5e-3)
    assert tw.length == pytest.approx(30e-3)
    assert fi.attach_to == "twister" and fi.count == 3 and fi.branch == "finger-branch"
    assert fi.cell.bottom_material.shear_modulus == pytest.approx(1e6)
    assert fi.cell.material.shear_modulus == pytest.approx(60e3)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda s: s.replace('material = "soft"', 'material = "no-such-silicone"'),
         "no-such-silicone"),
        (lambda s: s.replace('side_wall = "1.5 mm"', 'side_wall = "6 mm"'),
         "side_wall 6 mm leaves no chamber in width 10 mm"),
        (lambda s: s.replace('top_wall = "1 mm"', 'top_wall = "-1 mm"'),
         "top_wall: must be a positive length"),
        (lambda s: s.replace('tilt = "30 deg"', "tilt = 30"),
         "tilt: give an angle with its unit"),
        (lambda s: s.replace('kind = "bending"', 'kind = "wiggling"'),
         "kind must be one of"),
        (lambda s: s.replace('attach_to = "twister"', 'attach_to = "nobody"'),
         "attach_to 'nobody' is not a module"),
        (lambda s: s.replace('cells = 8', 'cells = 0'), "n_cells must be a positive integer"),
        (lambda s: s.replace('name = "finger"', 'name = "twister"'),
         "module names must be unique"),
        (lambda s: s.replace('cell = "c"\ncells = 5', 'cell = "d"\ncells = 5'),
         "no [cells.d] table"),
        (lambda s: s.replace('pmax = "60 kPa"', 'pmax = "60 mm"'),
         "device.pmax"),
        (lambda s: s + '\n[extra]\nx = 1\n', "unknown top-level key(s) extra"),
    ],
)
def test_malformed_devices_get_precise_errors(edit, message):
    with pytest.raises(SpecError) as err:
        parse(edit(BASE))
    assert message in str(err.value)


def test_overlapping_modules_are_rejected():
    text = BASE + """
[[module]]
name = "extra"
kind = "bending"
cell = "c"
cells = 2
start = "12 mm"
"""
    with pytest.raises(SpecError, match="overlap on branch 'main'"):
        parse(text)


def test_module_without_chamber_is_rejected():
    text = BASE.replace('end_wall = "1 mm"', 'end_wall = "3 mm"')
    with pytest.raises(SpecError, match="end_wall 3 mm leaves no chamber in length 6 mm"):
        parse(text)


def test_stretching_module_needs_symmetric_walls():
    text = BASE.replace('kind = "bending"', 'kind = "stretching"')
    with pytest.raises(SpecError, match="symmetric walls"):
        parse(text)
