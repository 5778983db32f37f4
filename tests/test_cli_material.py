"""``multimorph material`` and ``multimorph demo`` through the command line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from multimorph.cli import _demo, _material
from multimorph.materials.build_library import data_dir

MARECHAL = data_dir() / "marechal2021"


@pytest.fixture(scope="module")
def app() -> typer.Typer:
    a = typer.Typer(pretty_exceptions_enable=False)
    _material.register(a)
    _demo.register(a)
    return a


@pytest.fixture()
def runner() -> CliRunner:
    return CliRunner()


def test_fit_marechal_json(app: typer.Typer, runner: CliRunner, tmp_path: Path) -> None:
    out = tmp_path / "fit"
    r = runner.invoke(app, ["material", "fit", str(MARECHAL / "dragon_skin_30.csv"),
                            "--model", "gent", "--range", "4", "--out", str(out), "--json"])
    assert r.exit_code == 0, r.output
    d = json.loads(r.stdout)
    assert d["model"] == "gent" and d["status"] == "converged"
    assert d["units"] == {"mu": "Pa", "jm": "-"}
    assert 1e5 < d["params"]["mu"] < 4e5 and d["params"]["jm"] > 13.5
    assert d["stderr"]["mu"] > 0
    uni = d["per_case"]["uniaxial"]
    assert 0.9 < uni["r2"] <= 1 and 0 < uni["relative_rms"] < 0.3
    assert d["drucker_stable"]["uniaxial"] is True
    assert d["break_stretch"] == pytest.approx(8.09091)
    assert d["stretch_range"][1] == 4.0
    assert sorted(p.name for p in out.iterdir()) == ["fit.json", "fit.png"]
    saved = json.loads((out / "fit.json").read_text())
    assert saved["params"] == d["params"]
    assert (out / "fit.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_fit_human_output_has_units(app: typer.Typer, runner: CliRunner,
                                    tmp_path: Path) -> None:
    f = tmp_path / "uniaxial.csv"
    f.write_text("stretch,stress (kPa)\n" + "".join(
        f"{1 + 0.1 * i:.2f},{30 * (1 + 0.1 * i - (1 + 0.1 * i) ** -2):.4f}\n"
        for i in range(1, 20)))
    r = runner.invoke(app, ["material", "fit", str(f), "--model", "neo-hooke",
                            "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    assert "mu = 30 kPa" in r.stdout  # P = mu (lambda - lambda^-2), mu = 30 kPa
    assert "relative RMS 0.0 %" in r.stdout


@pytest.mark.parametrize("content", ["", "stretch,stress (kPa)\n1.1,abc\n",
                                     "stretch,stress (kPa)\n1.1\n"])
def test_malformed_file_fails_and_writes_nothing(app: typer.Typer, runner: CliRunner,
                                                 tmp_path: Path, content: str) -> None:
    f = tmp_path / "bad.csv"
    f.write_text(content)
    out = tmp_path / "out"
    r = runner.invoke(app, ["material", "fit", str(f), "--out", str(out)])
    assert r.exit_code != 0
    assert r.stdout == ""
    err = r.stderr.strip()
    assert len(err.splitlines()) == 1 and "bad.csv" in err
    assert not out.exists()
    assert [p.name for p in tmp_path.iterdir()] == ["bad.csv"]  # no temporary folder left


def test_missing_file_and_bad_model(app: typer.Typer, runner: CliRunner,
                                    tmp_path: Path) -> None:
    r = runner.invoke(app, ["material", "fit", str(tmp_path / "nope.csv"), "--json"])
    assert r.exit_code != 0 and "no such file" in r.stderr
    assert "error" in json.loads(r.stdout)
    r = runner.invoke(app, ["material", "fit", str(MARECHAL / "rtv615.csv"), "--model", "hooke",
                            "--out", str(tmp_path / "o")])
    assert r.exit_code != 0 and "unknown material model" in r.stderr
    assert not (tmp_path / "o").exists()


def test_list_and_show(app: typer.Typer, runner: CliRunner) -> None:
    r = runner.invoke(app, ["material", "list", "--json"])
    assert r.exit_code == 0
    rows = {m["name"]: m for m in json.loads(r.stdout)["materials"]}
    assert rows["ecoflex-00-30"]["model"] == "gent"
    assert rows["ecoflex-00-30"]["shear_modulus"] > 0  # SI (Pa) in JSON
    r = runner.invoke(app, ["material", "list"])
    assert r.exit_code == 0 and "kPa" in r.stdout
    r = runner.invoke(app, ["material", "show", "dragon-skin-30", "--model", "yeoh", "--json"])
    assert r.exit_code == 0
    d = json.loads(r.stdout)
    assert d["material"]["model"] == "yeoh"
    assert d["material"]["provenance"]["doi"] == "10.1089/soro.2019.0115"
    # its Yeoh fit (c20/c10 0.047) has no balloon limit point; its Gent fit (Jm 25) does
    assert d["membrane"] == {"limit_point": False, "limit_stretch": None,
                             "cells_activate": False}
    r = runner.invoke(app, ["material", "show", "dragon-skin-30", "--json"])
    assert json.loads(r.stdout)["membrane"]["limit_point"] is True
    r = runner.invoke(app, ["material", "show", "ecoflex-00-30"])
    assert r.exit_code == 0 and "kPa" in r.stdout and "ODbL" in r.stdout
    assert "balloon: snaps" in r.stdout
    r = runner.invoke(app, ["material", "show", "ecoflex-30"])
    assert r.exit_code != 0 and "did you mean" in r.stderr


@pytest.mark.parametrize("cmd", [["material", "list"], ["material", "show"],
                                 ["material", "fit"], ["material", "rebuild-library"],
                                 ["demo"]])
def test_every_command_has_help_with_example(app: typer.Typer, runner: CliRunner,
                                             cmd: list[str]) -> None:
    r = runner.invoke(app, [*cmd, "--help"])
    assert r.exit_code == 0
    assert "Example: multimorph" in r.stdout


def test_demo_on_two_materials(app: typer.Typer, runner: CliRunner, tmp_path: Path,
                               monkeypatch: pytest.MonkeyPatch) -> None:
    from multimorph.materials import build_library

    subset = {k: build_library.MARECHAL[k] for k in ("dragon_skin_30", "rtv615")}
    monkeypatch.setattr(build_library, "MARECHAL", subset)
    out = tmp_path / "demo"
    r = runner.invoke(app, ["demo", "--out", str(out), "--json", "--no-device"])
    assert r.exit_code == 0, r.output
    d = json.loads(r.stdout)
    rows = {m["name"]: m for m in d["materials"]["materials"]}
    assert set(rows) == {"dragon-skin-30", "rtv615"}
    lib_gent = build_library.fit_marechal("rtv615", ("gent",))[1]["gent"].params
    assert rows["rtv615"]["gent"]["mu"] == pytest.approx(lib_gent["mu"])
    assert sorted(p.name for p in out.iterdir()) == ["report.json", "report.md",
                                                     "silicone_fits.png"]
    assert "| rtv615 |" in (out / "report.md").read_text()


def test_fit_force_file_with_specimen_options(app: typer.Typer, runner: CliRunner,
                                              tmp_path: Path) -> None:
    # neo-Hookean data as force-displacement of a 10 mm x 2 mm x 50 mm specimen
    lam = [1 + 0.1 * i for i in range(1, 25)]
    rows = "".join(f"{50 * (x - 1):.6f},{20e-6 * 40e3 * (x - x**-2):.8f}\n" for x in lam)
    f = tmp_path / "pull.csv"
    f.write_text("displacement (mm),force (N)\n" + rows)
    r = runner.invoke(app, ["material", "fit", str(f), "--model", "neo-hooke", "--json",
                            "--gauge-length", "50 mm", "--width", "10 mm", "--thickness",
                            "2 mm", "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["params"]["mu"] == pytest.approx(40e3, rel=1e-6)


def test_negative_stress_and_repeated_stretch_are_warned_naming_the_lines(
        app: typer.Typer, runner: CliRunner, tmp_path: Path) -> None:
    # issue 20: a negative stress was dropped by the fit without a word; the shipped
    # Ecoflex 00-50 file has one (a load-cell offset) at line 19
    out = tmp_path / "fit"
    r = runner.invoke(app, ["material", "fit", str(MARECHAL / "ecoflex_00-50.csv"),
                            "--range", "4", "--out", str(out), "--json"])
    assert r.exit_code == 0, r.output
    assert "line 19: negative stress in tension" in r.stderr
    assert any("line 19" in w for w in json.loads(r.stdout)["warnings"])
    csv = tmp_path / "pull.csv"
    csv.write_text("stretch,stress (kPa)\n1.1,10\n1.2,19\n1.2,21\n1.5,40\n2.0,62\n2.5,80\n")
    r = runner.invoke(app, ["material", "fit", str(csv), "--out", str(tmp_path / "g")])
    assert r.exit_code == 0, r.output
    assert "lines 3 and 4 (stretch 1.2): one stretch with two different stresses" in r.stderr


def test_duplicated_rows_are_refused_not_fitted_with_false_precision(
        app: typer.Typer, runner: CliRunner, tmp_path: Path) -> None:
    # issue 20: every row given twice shrank the reported ± on μ (11.9 -> 8.2 kPa) as if
    # the data were twice as many independent measurements
    rows = (MARECHAL / "dragon_skin_30.csv").read_text().splitlines()
    head = next(i for i, ln in enumerate(rows) if ln.startswith("Time (s)"))
    doubled = rows[:head + 1] + [r for row in rows[head + 1:] for r in (row, row)]
    f = tmp_path / "ds30.csv"
    f.write_text("\n".join(doubled) + "\n")
    r = runner.invoke(app, ["material", "fit", str(f), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2
    assert f"ds30.csv, line {head + 3}: repeats line {head + 2} exactly" in r.stderr
    assert not (tmp_path / "o").exists()


def test_demo_prints_a_short_plain_summary(app: typer.Typer, runner: CliRunner,
                                           tmp_path: Path,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    from multimorph.materials import build_library

    subset = {k: build_library.MARECHAL[k] for k in ("dragon_skin_30", "rtv615")}
    monkeypatch.setattr(build_library, "MARECHAL", subset)
    out = tmp_path / "demo"
    r = runner.invoke(app, ["demo", "--out", str(out), "--no-device"])
    assert r.exit_code == 0, r.output
    lines = r.stdout.strip().splitlines()
    assert lines[0].startswith("Fitted Gent and Yeoh to 2 built-in silicones")
    assert "|" not in r.stdout and "#" not in r.stdout  # no raw Markdown
    assert lines[-1].startswith(f"Files in {out}/: report.md")
    assert "| rtv615 |" in (out / "report.md").read_text()  # the Markdown stays in the file


def test_the_demo_summary_names_the_model_of_its_numbers() -> None:
    report = {"materials": {"stretch_max": 4.0, "materials": [
        {"gent": {"relative_rms": 0.1}}, {"gent": {"relative_rms": 0.2}}]},
        "device": {"device": "gripper", "pmax": 60e3, "order": ["fingers", "twister"],
                   "module_models": {"fingers": "calibrated", "twister": "calibrated"},
                   "windows": {"fingers": {"critical_pressure": 25e3,
                                           "hardening_pressure": 30e3},
                               "twister": {"critical_pressure": 31e3,
                                           "hardening_pressure": None}},
                   "margins": [{"earlier": "fingers", "later": "twister", "margin": 1e3,
                                "verdict": "matched"}]}}
    lines = _demo.summary_lines(report, Path("out"))
    assert "Gent relative RMS median 15 % (from 10 to 20 %)" in lines[0]
    assert "with the calibrated cell model (calibrated: the Ritz model corrected" in lines[1]
    assert "ritz" not in lines[1]  # only the models that made the numbers
    assert lines[2] == "  fingers (calibrated model): Pc 25.0 kPa, Ph 30.0 kPa"
    assert "Ph not reached" in lines[3]
    assert lines[4] == ("  hand-over fingers → twister: matched (Pc later − Ph earlier = "
                        "+1.0 kPa)")
    assert lines[-1] == ("Open out/gripper/report.html for the device in 3D with a pressure "
                         "slider (works offline).")
