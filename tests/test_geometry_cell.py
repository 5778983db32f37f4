"""Cell geometry: validation names the offending field; scaling keeps the ratios (hypothesis)."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from multimorph.errors import SpecError
from multimorph.geometry import CellGeometry
from multimorph.materials import Material

M = Material("gent", {"mu": 2.45e5, "jm": 20.0})
mm = st.floats(0.1, 50.0, allow_nan=False, allow_infinity=False)


@st.composite
def cells(draw):
    ws, df, ht, hb = draw(mm), draw(mm), draw(mm), draw(mm)
    wc, dc, hc = draw(mm), draw(mm), draw(mm)
    return CellGeometry((dc + 2 * df) * 1e-3, (wc + 2 * ws) * 1e-3, (hc + ht + hb) * 1e-3,
                        ht * 1e-3, hb * 1e-3, ws * 1e-3, df * 1e-3, material=M)


@given(cells(), st.floats(1e-3, 1e3))
@settings(max_examples=60, deadline=None)
def test_scaling_keeps_every_ratio(cell, factor):
    big = cell.scaled(factor)
    for k, v in cell.ratios().items():
        assert big.ratios()[k] == pytest.approx(v, rel=1e-12)
    assert big.chamber_width == pytest.approx(factor * cell.chamber_width, rel=1e-12)


@given(cells())
@settings(max_examples=60, deadline=None)
def test_chamber_is_what_the_walls_leave(cell):
    assert cell.chamber_width + 2 * cell.side_wall == pytest.approx(cell.width)
    assert cell.chamber_length + 2 * cell.end_wall == pytest.approx(cell.length)
    assert cell.chamber_height + cell.top_wall + cell.bottom_wall == pytest.approx(cell.height)


@given(mm, mm)
@settings(max_examples=40, deadline=None)
def test_side_walls_that_leave_no_chamber_are_named(w, extra):
    ws = 0.5 * w + extra / 10
    with pytest.raises(SpecError, match=r"side_wall .* leaves no chamber in width"):
        CellGeometry(20e-3, w * 1e-3, 8e-3, 1e-3, 2e-3, ws * 1e-3, 2e-3, material=M)


@pytest.mark.parametrize(("key", "value", "message"), [
    ("top_wall", "0 mm", "top_wall: must be a positive length"),
    ("end_wall", "11 mm", "end_wall 11 mm leaves no chamber in length 20 mm"),
    ("height", "3 mm", "leave no chamber in height"),
    ("length", "20 kPa", "cell.length"),
])
def test_from_spec_errors_name_the_field(key, value, message):
    table = {"length": "20 mm", "width": "10 mm", "height": "8 mm", "top_wall": "1 mm",
             "bottom_wall": "2 mm", "side_wall": "2 mm", "end_wall": "2 mm",
             "material": {"model": "gent", "mu": "245 kPa", "jm": 20}}
    table[key] = value
    with pytest.raises(SpecError, match=message):
        CellGeometry.from_spec(table)
