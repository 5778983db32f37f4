"""``multimorph simulate``: files and JSON for a device; malformed specs fail cleanly."""

import csv
import json
import math

import pytest
import typer
from typer.testing import CliRunner

from multimorph.cli import _simulate
from test_device_simulate import SPEC, step_model


@pytest.fixture()
def app(monkeypatch):
    # the closed-form cell model keeps this a test of the command layer, not of the ROM
    from multimorph.device import _simulate as sim

    monkeypatch.setattr(sim, "default_cell_model", step_model)
    a = typer.Typer(pretty_exceptions_enable=False)
    _simulate.register(a)
    a.command("noop")(lambda: None)
    return a


def test_simulate_writes_files_and_json(app, tmp_path):
    spec = tmp_path / "dev.toml"
    spec.write_text(SPEC)
    out = tmp_path / "out"
    r = CliRunner().invoke(app, ["simulate", str(spec), "--out", str(out), "--json",
                                 "--frames", "3"])
    assert r.exit_code == 0, r.output
    d = json.loads(r.stdout)
    assert d["sequence"]["order"] == ["base", "tip"]
    assert d["modules"]["base"]["critical_pressure"] == pytest.approx(15e3)
    assert d["notes"] == []  # neither coils nor overlaps (tests/test_device_pictures.py)
    assert {p.name for p in out.iterdir()} == {"summary.json", "curves.csv", "sequence.png",
                                              "shapes.png", "morph.gif", "report.html"}
    # curves.csv: the older columns first, then the names FE's CSV files use
    with open(out / "curves.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == list(_simulate.CSV_COLUMNS)
    last = [row for row in rows if row["module"] == "base"][-1]
    assert float(last["pressure_kpa"]) == pytest.approx(float(last["pressure_pa"]) / 1e3)
    assert last["curvature_1_per_m"] == last["bend_1_per_m"]
    # base: 4 cells of 5 mm at κ = 40 1/m: 0.8 rad
    assert float(last["bend_angle_deg"]) == pytest.approx(math.degrees(0.8), rel=1e-6)


@pytest.mark.parametrize(("edit", "message"), [
    (lambda s: s.replace('material = "soft"', 'material = "unobtainium"'), "unobtainium"),
    (lambda s: s.replace('orientation = "180 deg"', 'orientation = 180'), "orientation"),
    (lambda s: s.replace('side_wall = "1.5 mm"', 'side_wall = "5 mm"', 1), "leaves no chamber"),
    (lambda s: s.replace('cells = 4\norientation', 'cells = 4\nstart = "5 mm"\norientation'),
     "overlap"),
    (lambda s: s.replace('top_wall = "1 mm"', 'top_wall = "-1 mm"', 1), "positive length"),
])
def test_malformed_device_exits_nonzero_and_writes_nothing(app, tmp_path, edit, message):
    spec = tmp_path / "dev.toml"
    spec.write_text(edit(SPEC))
    out = tmp_path / "out"
    r = CliRunner().invoke(app, ["simulate", str(spec), "--out", str(out)])
    assert r.exit_code == 2
    assert message in r.output
    assert not out.exists()
    assert not list(tmp_path.glob(".out.tmp-*"))


def test_spec_without_pmax_needs_the_option(app, tmp_path):
    # issue 20: without device.pmax the command used a silent 60 kPa although its help says
    # the default is the spec's pmax; now it refuses, naming both ways to give it
    spec = tmp_path / "dev.toml"
    spec.write_text(SPEC.replace('pmax = "60 kPa"\n', ""))
    out = tmp_path / "out"
    r = CliRunner().invoke(app, ["simulate", str(spec), "--out", str(out), "--frames", "0"])
    assert r.exit_code == 2
    assert "device.pmax: missing" in r.stderr and "--pmax" in r.stderr
    assert not out.exists()
    r = CliRunner().invoke(app, ["simulate", str(spec), "--out", str(out), "--frames", "0",
                                 "--pmax", "40 kPa", "--json"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["pmax"] == pytest.approx(40e3)


@pytest.mark.parametrize("snapshots", ["abc", "-5 kPa", "20 kPa,100 kPa", "20 mm"])
def test_bad_snapshots_are_refused_before_the_run(app, tmp_path, monkeypatch, snapshots):
    from multimorph.device import _simulate as sim

    def never(*args, **kwargs):
        raise AssertionError("the model ran before --snapshots was checked")

    monkeypatch.setattr(sim, "default_cell_model", never)
    spec = tmp_path / "dev.toml"
    spec.write_text(SPEC)
    r = CliRunner().invoke(app, ["simulate", str(spec), "--out", str(tmp_path / "o"),
                                 "--snapshots", snapshots])
    assert r.exit_code == 2
    assert "--snapshots" in r.stderr
