"""``multimorph design`` through the command line (the stand-in cell model injected)."""

from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from multimorph.cli import _design
from multimorph.device import device_from_spec, simulate_device
from test_design_helpers import STANDIN, standin_cell, wide_gripper_text

EXAMPLES = Path(__file__).parents[1] / "examples"


@pytest.fixture()
def app(monkeypatch) -> typer.Typer:
    import multimorph.design as des

    monkeypatch.setattr(des, "rom_batch_model", lambda vectorised=False: STANDIN)
    a = typer.Typer(pretty_exceptions_enable=False)
    _design.register(a)
    a.command("noop")(lambda: None)  # keep 'design' a sub-command
    return a


def run(app, *args):
    # the stand-in replaces the reduced model's batch model: select it with --model ritz
    return CliRunner().invoke(app, ["design", *map(str, args), "--model", "ritz"])


def test_design_writes_device_report_and_plots(app, tmp_path):
    out = tmp_path / "g"
    wide = tmp_path / "target_gripper_wide.toml"
    wide.write_text(wide_gripper_text())
    r = run(app, wide, "--out", out, "--budget", 2400,
            "--population", 16, "--seed", 3, "--robustness", 24, "--json")
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    assert data["feasible"] is True and data["explanation"] == []
    # the twister's 30-50 kPa band is wider than one module spans: two graded parts
    g = data["graded"]["twister"]
    assert g["parts"] == ["twister-1", "twister-2"] and g["predicted"]["met"] is True
    assert g["predicted"]["start_pressure"] == pytest.approx(30e3, rel=0.1)
    assert g["predicted"]["end_pressure"] == pytest.approx(50e3, rel=0.1)
    assert data["robustness"]["n_samples"] == 24 and 0 <= data["robustness"]["p_order"] <= 1
    for f in ("device.toml", "report.md", "report.json", "sequence.png", "convergence.png",
              "robustness.png"):
        assert (out / f).is_file(), f
    dev = device_from_spec(tomllib.loads((out / "device.toml").read_text()))
    res = simulate_device(dev, cell_model=standin_cell)
    assert res.sequence.order == ["fingers", "twister-1", "twister-2"]
    md = (out / "report.md").read_text()
    assert "Robustness (Monte Carlo)" in md and "Graded stages" in md
    # a twist stage's angle is the strip rule's; the report says what whole-module FE found
    assert "Twist stages (twister-1, twister-2): the predicted angle is the strip rule's" in md
    assert "a third to a sixth of that angle" in md
    assert json.loads((out / "report.json").read_text())["model"] == "ritz"  # which model
    # same seed, same report (timings aside)
    r2 = run(app, wide, "--out", tmp_path / "g2", "--budget", 2400,
             "--population", 16, "--seed", 3, "--robustness", 24, "--json")
    d2 = json.loads(r2.stdout)
    assert d2["designs"] == data["designs"] and d2["robustness"] == data["robustness"]


def test_no_graded_keeps_one_module_per_stage(app, tmp_path):
    r = run(app, EXAMPLES / "target_gripper.toml", "--out", tmp_path / "n", "--budget", 900,
            "--population", 16, "--seed", 3, "--robustness", 0, "--no-graded", "--json")
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    assert data["graded"] == {} and [s["name"] for s in data["stages"]] == ["fingers", "twister"]


def test_infeasible_exits_3_with_explanation(app, tmp_path):
    spec = (EXAMPLES / "target_gripper.toml").read_text().replace(
        'max_pressure = "60 kPa"', 'max_pressure = "35 kPa"')
    target = tmp_path / "t.toml"
    target.write_text(spec)
    out = tmp_path / "o"
    r = run(app, target, "--out", out, "--json")
    assert r.exit_code == 3, r.output
    data = json.loads(r.stdout)
    assert data["feasible"] is False
    assert any("max_pressure binds" in e for e in data["explanation"])
    assert "INFEASIBLE" in (out / "report.md").read_text()
    assert not (out / "device.toml").exists()


def test_spec_error_exits_2_nothing_written(app, tmp_path):
    target = tmp_path / "bad.toml"
    target.write_text('[[stage]]\nkind = "curl"\n')
    out = tmp_path / "o"
    r = run(app, target, "--out", out, "--json")
    assert r.exit_code == 2
    assert "stage[0] (stage1).kind" in json.loads(r.stdout)["error"]
    assert not out.exists()


def test_verify_fe_missing_is_named(app, tmp_path, monkeypatch):
    import multimorph.design._verify as ver

    monkeypatch.setattr(ver, "fe_available",
                        lambda: (False, "multimorph.fe lacks simulate_cell"))
    r = run(app, EXAMPLES / "target_gripper.toml", "--out", tmp_path / "o", "--verify-fe",
            "--json")
    assert r.exit_code == 2
    assert "--verify-fe: multimorph.fe lacks simulate_cell" in json.loads(r.stdout)["error"]


def test_search_progress_is_printed_as_lines_when_piped(app, tmp_path):
    # CliRunner's stderr is not a terminal: the bar becomes lines (first and last always)
    r = run(app, EXAMPLES / "target_gripper.toml", "--out", tmp_path / "p", "--budget", 300,
            "--population", 8, "--seed", 1, "--robustness", 0, "--no-gradient")
    assert r.exit_code in (0, 3), r.output
    lines = [line for line in r.stderr.splitlines() if line.startswith("[design]")]
    assert re.match(r"\[design\] search: [a-z]+: \d+/300 candidates, \d+\.\d s$", lines[0])
    done = [int(m) for m in re.findall(r": (\d+)/300 candidates", "\n".join(lines))]
    assert done == sorted(done) and lines[-1].endswith(" s")
