"""Test-data readers: the three formats, unit handling, and precise errors on bad files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from multimorph.errors import DataFileError
from multimorph.materials import LoadCurve, Specimen, read_test_data
from multimorph.materials.build_library import data_dir

MARECHAL = data_dir() / "marechal2021"
TRELOAR = data_dir() / "treloar1944"


def _write(tmp_path: Path, text: str, name: str = "data.csv") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_marechal_file() -> None:
    d = read_test_data(MARECHAL / "dragon_skin_30.csv")
    assert d.name == "DragonSkin30"
    assert d.cases == ("uniaxial",)
    assert d.metadata["Specimen Width (mm)"] == "6"
    c = d.curves[0]
    # first data row: engineering strain 0.0446, engineering stress 0.01736 MPa
    assert c.stretch[0] == pytest.approx(1.0446)
    assert c.stress[0] == pytest.approx(0.01736e6)
    # pull to failure: the last row is the break, engineering strain 7.09091
    assert d.break_stretch == pytest.approx(8.09091)
    t = d.truncate(4.0)
    assert t.curves[0].max_stretch <= 4.0 < c.max_stretch
    assert t.break_stretch == d.break_stretch


def test_every_shipped_marechal_file_reads() -> None:
    files = sorted(MARECHAL.glob("*.csv"))
    assert len(files) == 19
    for f in files:
        d = read_test_data(f)
        assert len(d.curves[0]) > 50 and d.break_stretch > 1.5


def test_plain_treloar_with_case_from_file_name() -> None:
    d = read_test_data(TRELOAR / "pure_shear.csv")
    assert d.cases == ("pure_shear",)
    assert d.curves[0].stress[0] == pytest.approx(0.0667e6)
    assert read_test_data(TRELOAR / "uniaxial.csv", case="equibiaxial").cases == ("equibiaxial",)


@pytest.mark.parametrize(("header", "row", "lam", "stress"), [
    ("stretch,nominal_stress_mpa", "1.5,0.25", 1.5, 0.25e6),
    ("stretch,stress (kPa)", "1.5,250", 1.5, 0.25e6),
    ("lambda;stress [Pa]", "1.5;250000", 1.5, 0.25e6),
    ("strain,stress (MPa)", "0.5,0.25", 1.5, 0.25e6),
    ("engineering_strain_percent,engineering_stress_kpa", "50,250", 1.5, 0.25e6),
    ("strain (%)\tstress (psi)", "50\t10", 1.5, 10 * 6894.757293168),
    # true strain / true stress: lambda = exp(e), nominal = sigma / lambda
    ("true strain,true stress (MPa)", f"{np.log(1.5)},0.375", 1.5, 0.25e6),
])
def test_plain_headers_and_units(tmp_path: Path, header: str, row: str, lam: float,
                                 stress: float) -> None:
    d = read_test_data(_write(tmp_path, f"{header}\n{row}\n"))
    c = d.curves[0]
    assert c.case == "uniaxial"
    assert c.stretch[0] == pytest.approx(lam)
    assert c.stress[0] == pytest.approx(stress, rel=1e-9)


def test_plain_case_column(tmp_path: Path) -> None:
    text = ("# Treloar-like data\ncase,stretch,stress (MPa)\nUT,1.5,0.5\nUT,2.0,0.8\n"
            "ET,1.5,0.7\npure shear,1.5,0.6\nplanar,2.0,0.9\n")
    d = read_test_data(_write(tmp_path, text))
    assert d.cases == ("uniaxial", "equibiaxial", "pure_shear")
    assert d.curve("pure_shear").stress.tolist() == [0.6e6, 0.9e6]
    only = read_test_data(_write(tmp_path, text), case="uniaxial")
    assert only.cases == ("uniaxial",)


def test_force_displacement_defaults_and_override(tmp_path: Path) -> None:
    f = _write(tmp_path, "displacement (mm),force (N)\n0,0\n33,18\n66,30\n")
    d = read_test_data(f)
    c = d.curves[0]
    # ASTM D412 die C: L0 = 33 mm, A = 6 mm x 3 mm = 18 mm^2
    assert c.stretch.tolist() == pytest.approx([1.0, 2.0, 3.0])
    assert c.stress.tolist() == pytest.approx([0.0, 1.0e6, 30 / 18e-6])
    d2 = read_test_data(f, specimen=Specimen(gauge_length=66e-3, width=10e-3, thickness=2e-3))
    assert d2.curves[0].stretch.tolist() == pytest.approx([1.0, 1.5, 2.0])
    assert d2.curves[0].stress[1] == pytest.approx(18 / 20e-6)


@pytest.mark.parametrize(("text", "line", "problem"), [
    ("", None, "empty file"),
    ("   \n\n", None, "empty file"),
    ("stretch,stress (kPa)\n1.1,10\n1.2,abc\n", 3, "'abc' is not a number"),
    ("stretch,stress (kPa)\n1.1,10\n1.2,20,30\n", 3, "expected 2 columns, found 3"),
    ("stretch,stress (kPa)\n1.1,10\n1.3,20\n1.2,30\n", 4, "stretch decreases"),
    ("stretch,stress (kPa)\n-1.1,10\n", 2, "not positive"),
    ("stretch,stress (kPa)\n", 1, "no data rows"),
    ("stretch,stress\n1.1,10\n", 1, "has no unit"),
    ("stretch,stress (m)\n1.1,10\n", 1, "is not a unit of Pa"),
    ("time,temperature\n1,2\n", 1, "expected a stretch"),
    ("stretch,stress (kPa)\n1.1,nan\n", 2, "not a finite number"),
    ("case,stretch,stress (kPa)\nsideways,1.1,10\n", 2, "unknown load case"),
])
def test_malformed_plain_files(tmp_path: Path, text: str, line: int | None,
                               problem: str) -> None:
    f = _write(tmp_path, text, "bad.csv")
    with pytest.raises(DataFileError) as exc:
        read_test_data(f)
    msg = str(exc.value)
    assert str(f) in msg and problem in msg
    assert exc.value.line == line
    if line is not None:
        assert f"line {line}" in msg


def test_malformed_marechal_files(tmp_path: Path) -> None:
    good = (MARECHAL / "rtv615.csv").read_text().splitlines()
    # a non-numeric cell in the 5th data row (file line 18 + 5 = 23)
    bad = list(good)
    cells = bad[22].split(";")
    cells[4] = "n/a"
    bad[22] = ";".join(cells)
    f = _write(tmp_path, "\n".join(bad) + "\n", "bad_marechal.csv")
    with pytest.raises(DataFileError, match=r"bad_marechal\.csv, line 23: Engineering Stress"):
        read_test_data(f)
    # a missing column
    bad = list(good)
    bad[30] = ";".join(bad[30].split(";")[:3])
    f = _write(tmp_path, "\n".join(bad) + "\n", "short.csv")
    with pytest.raises(DataFileError, match=r"line 31: expected 5 ';'-separated columns"):
        read_test_data(f)
    # header only
    f = _write(tmp_path, "\n".join(good[:18]) + "\n", "nodata.csv")
    with pytest.raises(DataFileError, match="no data rows"):
        read_test_data(f)
    # header cut before the column names
    f = _write(tmp_path, "\n".join(good[:10]) + "\n", "cut.csv")
    with pytest.raises(DataFileError, match="no column header"):
        read_test_data(f, format="marechal")


def test_missing_and_binary_files(tmp_path: Path) -> None:
    with pytest.raises(DataFileError, match="no such file"):
        read_test_data(tmp_path / "nope.csv")
    b = tmp_path / "blob.csv"
    b.write_bytes(b"\x00\x01\x02stretch")
    with pytest.raises(DataFileError, match="not a text file"):
        read_test_data(b)
    with pytest.raises(DataFileError, match="not a regular file"):
        read_test_data(tmp_path)


def test_load_curve_validation() -> None:
    from multimorph.errors import SpecError

    with pytest.raises(SpecError, match="must not decrease"):
        LoadCurve("uniaxial", [1.2, 1.1], [1.0, 2.0])
    with pytest.raises(SpecError, match="positive"):
        LoadCurve("uniaxial", [0.0, 1.1], [1.0, 2.0])
    with pytest.raises(SpecError, match="2 stretches but 1"):
        LoadCurve("uniaxial", [1.0, 1.1], [1.0])


_UNITS = {"Pa": 1.0, "kPa": 1e3, "MPa": 1e6}


@settings(max_examples=30, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(increments=st.lists(st.floats(1e-3, 0.5), min_size=1, max_size=30),
       stresses=st.lists(st.floats(-1e3, 1e7), min_size=30, max_size=30),
       unit=st.sampled_from(sorted(_UNITS)), strain=st.booleans(),
       delim=st.sampled_from([",", ";", "\t"]))
def test_plain_csv_round_trip(tmp_path: Path, increments: list[float], stresses: list[float],
                              unit: str, strain: bool, delim: str) -> None:
    # property: whatever we write (stretch or strain, any stress unit, any delimiter) reads
    # back as the same stretches and the same nominal stresses in Pa
    lam = 1.0 + np.cumsum(increments)
    p = np.array(stresses[: lam.size])
    x = lam - 1.0 if strain else lam
    head = ("strain" if strain else "stretch") + delim + f"nominal stress ({unit})"
    rows = [f"{float(a)!r}{delim}{float(b) / _UNITS[unit]!r}" for a, b in zip(x, p, strict=True)]
    f = tmp_path / "round.csv"
    f.write_text("\n".join([head, *rows]) + "\n")
    c = read_test_data(f).curves[0]
    np.testing.assert_allclose(c.stretch, lam, rtol=1e-12)
    np.testing.assert_allclose(c.stress, p, rtol=1e-12, atol=1e-9)


def test_force_file_specimen_from_comments(tmp_path: Path) -> None:
    f = _write(tmp_path, "# specimen gauge length: 66 mm\n# width = 1 cm\n# thickness: 2 mm\n"
                         "displacement (mm),force (N)\n0,0\n33,20\n")
    c = read_test_data(f).curves[0]
    assert c.stretch.tolist() == pytest.approx([1.0, 1.5])
    assert c.stress[1] == pytest.approx(20 / 20e-6)
    bad = _write(tmp_path, "# width = 1 kg\ndisplacement (mm),force (N)\n0,0\n33,20\n", "b.csv")
    with pytest.raises(DataFileError, match=r"b\.csv, line 1: width"):
        read_test_data(bad)
