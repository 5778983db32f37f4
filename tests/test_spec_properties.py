"""Property tests of the spec parsers (hypothesis): round trips, and bad values refused with
the field named; and of the reduced model: a valid cell traces without NaN or says why not.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from multimorph.errors import SpecError
from multimorph.geometry import CELL_KEYS, CellGeometry
from multimorph.units import to_angle, to_si

GENT = {"model": "gent", "mu": "245 kPa", "jm": 20}
STIFF = {"model": "gent", "mu": "1.2 MPa", "jm": 20}

FAST = settings(max_examples=60, deadline=None)


@st.composite
def cells_mm(draw: st.DrawFn) -> dict[str, float]:
    """Valid cell dimensions (mm): every chamber side positive."""
    d = draw(st.floats(2.0, 60.0))
    w = draw(st.floats(2.0, 60.0))
    h = draw(st.floats(2.0, 60.0))
    ws = draw(st.floats(0.02, 0.45)) * w
    df = draw(st.floats(0.02, 0.45)) * d
    ht = draw(st.floats(0.02, 0.45)) * h
    hb = draw(st.floats(0.02, 0.45)) * h
    return {"length": d, "width": w, "height": h, "top_wall": ht, "bottom_wall": hb,
            "side_wall": ws, "end_wall": df}


def _table(dims: dict[str, float], unit: str = "mm", scale: float = 1.0) -> dict[str, object]:
    return {**{k: f"{v * scale!r} {unit}" for k, v in dims.items()},
            "material": dict(GENT), "bottom_material": dict(STIFF)}


@FAST
@given(cells_mm(), st.sampled_from([("mm", 1.0), ("cm", 0.1), ("um", 1e3), ("m", 1e-3)]))
def test_cell_spec_round_trip_in_any_length_unit(dims: dict[str, float],
                                                 unit: tuple[str, float]) -> None:
    cell = CellGeometry.from_spec(_table(dims, *unit))
    for key, v in dims.items():
        assert getattr(cell, key) == pytest.approx(v * 1e-3, rel=1e-12)
    # back to a spec (SI numbers are metres) and again: the same cell
    again = CellGeometry.from_spec({**{k: getattr(cell, k) for k in CELL_KEYS},
                                    "material": dict(GENT), "bottom_material": dict(STIFF)})
    assert again == cell


BAD_LENGTHS = st.one_of(
    st.floats(max_value=0.0, allow_nan=False).map(lambda x: f"{x!r} mm"),
    st.sampled_from(["nan mm", "inf mm", "-inf mm", "2 kPa", "2 furlongz", "2 deg", "",
                     "mm", "2 mm mm"]),
    st.sampled_from([True, False, None, [1, 2], {"a": 1}]),
    st.floats(min_value=1.0001, max_value=1e300).map(lambda x: f"{x!r} m"),
)


@FAST
@given(cells_mm(), st.sampled_from(sorted(CELL_KEYS)), BAD_LENGTHS)
def test_a_bad_length_is_refused_naming_the_field(dims: dict[str, float], key: str,
                                                  bad: object) -> None:
    table = _table(dims)
    table[key] = bad
    with pytest.raises(SpecError, match=f"cell.{key}"):
        CellGeometry.from_spec(table)


@FAST
@given(cells_mm(), st.sampled_from(sorted(CELL_KEYS)))
def test_a_missing_length_is_refused_naming_the_field(dims: dict[str, float],
                                                      key: str) -> None:
    table = _table(dims)
    del table[key]
    with pytest.raises(SpecError, match=f"cell.{key}: missing"):
        CellGeometry.from_spec(table)


@FAST
@given(st.floats(-1e6, 1e6, allow_nan=False), st.sampled_from(["m", "mm", "um", "km"]))
def test_to_si_reads_lengths_and_bare_numbers_alike(x: float, unit: str) -> None:
    factor = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "km": 1e3}[unit]
    assert to_si(f"{x!r} {unit}", "m") == pytest.approx(x * factor, rel=1e-12, abs=1e-300)
    # a bare number, written as a number or as a string, is SI
    assert to_si(x, "m") == to_si(repr(x), "m") == x


@FAST
@given(st.floats(-1e4, 1e4, allow_nan=False).filter(lambda v: v != 0),
       st.sampled_from([("deg", math.pi / 180), ("rad", 1.0), ("turn", 2 * math.pi),
                        ("arcmin", math.pi / 10800)]))
def test_angles_with_units_round_trip(x: float, unit: tuple[str, float]) -> None:
    assert to_angle(f"{x!r} {unit[0]}") == pytest.approx(x * unit[1], rel=1e-12)


@FAST
@given(st.one_of(st.floats(allow_nan=False, allow_infinity=False),
                 st.integers(-1000, 1000),
                 st.floats(allow_nan=False, allow_infinity=False).map(repr),
                 st.integers(-1000, 1000).map(str),
                 st.sampled_from(["30 %", "30 mm", "30 kPa", "30 percent"])),
       st.text(alphabet="abcdefghij._", min_size=1, max_size=12))
def test_an_angle_without_an_angle_unit_is_refused_naming_the_field(value: object,
                                                                    field: str) -> None:
    with pytest.raises(SpecError, match=f"^{field}: "):
        to_angle(value, field=field)


@FAST
@given(st.floats(0.01, 0.5), st.floats(0.01, 0.5), st.integers(1, 40),
       st.sampled_from(["linear", "log"]))
def test_sweep_ranges_have_num_values_within_bounds(a: float, b: float, num: int,
                                                   scale: str) -> None:
    from multimorph.materials import Material
    from multimorph.sweep._params import parse_parameter

    m = Material("gent", {"mu": 2.45e5, "jm": 20.0})
    q = parse_parameter({"name": "ht/d", "start": a, "stop": b, "num": num, "scale": scale},
                        field="sweep.parameter[0]", base_material=m, base_bottom=m,
                        cell_table={})
    assert len(q.values) == num
    assert q.values[0] == pytest.approx(a)
    assert q.values[-1] == pytest.approx(b if num > 1 else a)  # numpy: num = 1 is the start
    assert all(min(a, b) * (1 - 1e-12) <= v <= max(a, b) * (1 + 1e-12) for v in q.values)


@FAST
@given(st.one_of(st.integers(max_value=0), st.floats(allow_nan=True), st.text(max_size=5),
                 st.integers(min_value=1_000_001, max_value=10**12)))
def test_a_bad_num_is_refused_naming_the_parameter(num: object) -> None:
    from multimorph.materials import Material
    from multimorph.sweep._params import parse_parameter

    m = Material("gent", {"mu": 2.45e5, "jm": 20.0})
    with pytest.raises(SpecError, match=r"sweep\.parameter\[3\] \(ht/d\)"):
        parse_parameter({"name": "ht/d", "start": 0.02, "stop": 0.08, "num": num},
                        field="sweep.parameter[3]", base_material=m, base_bottom=m,
                        cell_table={})


@FAST
@given(st.floats(1.0, 170.0), st.floats(5.0, 50.0), st.floats(1.1, 1.9))
def test_target_stage_round_trip(angle_deg: float, p_kpa: float, ratio: float) -> None:
    from multimorph.design import target_from_spec

    spec = {"stage": [{"kind": "bend", "angle": f"{angle_deg!r} deg",
                       "pressure": f"{p_kpa!r} kPa"},
                      {"kind": "twist", "angle": f"{-angle_deg!r} deg",
                       "band": [f"{p_kpa!r} kPa", f"{p_kpa * ratio!r} kPa"]}],
            "constraints": {"max_pressure": f"{p_kpa * 2!r} kPa",
                            "materials": ["ecoflex-00-30"]}}
    t = target_from_spec(spec)
    assert t.stages[0].magnitude == pytest.approx(math.radians(angle_deg))
    assert t.stages[1].magnitude == pytest.approx(-math.radians(angle_deg))
    assert t.stages[0].end_pressure == pytest.approx(p_kpa * 1e3)
    assert t.stages[1].end_pressure == pytest.approx(p_kpa * ratio * 1e3)


# ----------------------------------------------------------------- the reduced model
@st.composite
def rom_cells(draw: st.DrawFn) -> CellGeometry:
    """Valid Gent cells over the ratios the design search explores (one law pair: the
    reduced model compiles once)."""
    from multimorph.materials import Material

    d = 10e-3
    mu = draw(st.floats(30e3, 500e3))
    wall = Material("gent", {"mu": mu, "jm": draw(st.floats(8.0, 60.0))})
    bottom = Material("gent", {"mu": mu * draw(st.floats(1.0, 20.0)), "jm": 20.0})
    return CellGeometry(length=d, width=d * draw(st.floats(0.6, 2.0)),
                        height=d * draw(st.floats(0.6, 1.5)),
                        top_wall=d * draw(st.floats(0.04, 0.15)),
                        bottom_wall=d * draw(st.floats(0.1, 0.25)),
                        side_wall=d * draw(st.floats(0.05, 0.15)),
                        end_wall=d * draw(st.floats(0.05, 0.15)),
                        material=wall, bottom_material=bottom)


@pytest.mark.slow
@settings(max_examples=6, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(rom_cells(), st.floats(0.2, 3.0))
def test_any_valid_cell_traces_without_nan_or_says_why(cell: CellGeometry,
                                                       p_over_mu: float) -> None:
    from multimorph.rom import ContinuationError, solve_cell

    assume(cell.chamber_height > 0)
    p_max = p_over_mu * cell.mu
    try:
        r = solve_cell(cell, p_max)
    except ContinuationError as exc:
        # a precise failure: where (pressure) and why
        text = str(exc)
        assert "kPa" in text and "could not trace" in text
        return
    path = r.path
    for name in ("pressure", "curvature", "axial_stretch", "volume", "peak_stretch"):
        assert np.all(np.isfinite(getattr(path, name))), name
    assert path.pressure[-1] == pytest.approx(p_max, rel=1e-6)
    ch = r.characteristic
    for value in (ch.critical, ch.hardening, ch.failure):
        assert value is None or 0 < value <= p_max * (1 + 1e-9)
    if ch.critical is not None and ch.critical_kind == "max_slope":
        assert ch.critical < path.pressure.max()   # never the end of the traced range
