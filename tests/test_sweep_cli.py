"""``multimorph sweep`` and ``multimorph plot map`` (test-only sphere backend)."""

from __future__ import annotations

import json
from pathlib import Path

import typer
from typer.testing import CliRunner

from multimorph.cli import _plot, _sweep
from test_sweep_run import write_spec


def make_app() -> typer.Typer:
    app = typer.Typer()
    _sweep.register(app)
    _plot.register(app)
    return app


def test_sweep_json_then_plot_map(tmp_path: Path) -> None:
    runner = CliRunner()
    spec = write_spec(tmp_path, num=4)
    out = tmp_path / "out"
    r = runner.invoke(make_app(), ["sweep", str(spec), "--out", str(out), "--scheduler",
                                   "threads", "--workers", "2", "--batch-size", "2", "--json"])
    assert r.exit_code == 0, r.output
    summary = json.loads(r.stdout)
    assert (summary["n_designs"], summary["n_ok"], summary["n_invalid"]) == (12, 8, 4)
    assert summary["invalid"][0]["values"] == {"ht/d": 0.02, "ws/d": 0.3}
    assert "side_wall" in summary["invalid"][0]["reason"]

    r = runner.invoke(make_app(), ["plot", "map", str(out), "--json"])
    assert r.exit_code == 0, r.output
    files = [Path(f) for f in json.loads(r.stdout)["files"]]
    assert {f.name for f in files} == {"families_ht_d.png", "pc_vs_ht_d.png",
                                       "pc_map_ht_d__ws_d.png"}
    assert all(f.stat().st_size > 10_000 for f in files)

    r = runner.invoke(make_app(), ["plot", "map", str(out / "results.zarr"), "--x", "ws/d",
                                   "--y", "ht/d", "--out", str(tmp_path / "m"),
                                   "--format", "svg"])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "m" / "pc_map_ws_d__ht_d.svg").is_file()

    r = runner.invoke(make_app(), ["plot", "map", str(out), "--x", "hx/d", "--json"])
    assert r.exit_code == 2
    assert "no parameter 'hx/d' in these results; available: ht/d, ws/d" in r.stdout


def test_sweep_bad_spec_exits_2_with_the_field(tmp_path: Path) -> None:
    spec = write_spec(tmp_path)
    spec.write_text(spec.read_text().replace('name = "ht/d"', 'name = "cell.roof"'))
    r = CliRunner().invoke(make_app(), ["sweep", str(spec), "--out", str(tmp_path / "o"),
                                        "--json"])
    assert r.exit_code == 2
    assert "unknown parameter path 'cell.roof'" in json.loads(r.stdout)["error"]
    assert not (tmp_path / "o").exists()


def test_a_spec_cannot_import_code_a_plugin_needs_the_command_line(tmp_path: Path) -> None:
    # issue 20: backend = "module:callable" in a spec is refused (a spec file is data); the
    # same import path runs only when the command line allows it with --allow-plugin
    spec = write_spec(tmp_path)
    spec.write_text(spec.read_text().replace('"sphere"', '"test_sweep_analytic:SphereBackend"'))
    args = ["sweep", str(spec), "--out", str(tmp_path / "o"), "--scheduler", "sync", "--json"]
    r = CliRunner().invoke(make_app(), args)
    assert r.exit_code == 2
    error = json.loads(r.stdout)["error"]
    assert "sweep.backend: unknown backend 'test_sweep_analytic:SphereBackend'" in error
    assert "--allow-plugin" in error
    assert not (tmp_path / "o").exists()
    r = CliRunner().invoke(make_app(), [*args, "--allow-plugin",
                                        "test_sweep_analytic:SphereBackend"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["n_ok"] == 8


def test_every_design_invalid_is_refused_and_every_design_failed_exits_1(
        tmp_path: Path) -> None:
    spec = write_spec(tmp_path)
    text = spec.read_text()
    spec.write_text(text.replace("values = [0.1, 0.15, 0.3]", "values = [0.3, 0.4]"))
    r = CliRunner().invoke(make_app(), ["sweep", str(spec), "--out", str(tmp_path / "a"),
                                        "--scheduler", "sync"])
    assert r.exit_code == 2
    assert "all 8 designs are invalid, nothing to run" in r.stderr
    assert not (tmp_path / "a").exists()
    # every evaluated design fails (the test model raises above a 0.1 mm top wall)
    spec.write_text(text + "\n[sweep.options]\nfail_top_wall_above = 1e-4\n")
    r = CliRunner().invoke(make_app(), ["sweep", str(spec), "--out", str(tmp_path / "b"),
                                        "--scheduler", "sync", "--json"])
    assert r.exit_code == 1
    summary = json.loads(r.stdout)
    assert summary["n_ok"] == 0 and summary["n_failed"] == 8
    assert (tmp_path / "b" / "results.zarr").is_dir()  # the errors are kept
