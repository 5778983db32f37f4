"""A sweep runs on the default cell model, the calibrated one, unless its spec names another
(issue 22: the default of ``cell``, ``simulate``, ``design`` and ``sweep``), and says which
model answered its designs. Until stop 61 a spec without ``backend`` ran on the Ritz model,
about twice as stiff as FE, and so did every shipped example sweep."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest
from typer.testing import CliRunner

from multimorph.cli import _sweep
from multimorph.errors import SpecError
from multimorph.models import DEFAULT_MODEL
from multimorph.sweep import (
    DEFAULT_BACKEND,
    SweepStore,
    answered_by,
    load_sweep_spec,
    open_results,
    parse_sweep_spec,
)
from multimorph.viz import model_note
from test_sweep_cli import make_app

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

SPEC = """
[cell]
length = "20 mm"
width = "10 mm"
height = "8 mm"
top_wall = "1 mm"
bottom_wall = "2 mm"
side_wall = "1.5 mm"
end_wall = "2 mm"

[cell.material]
model = "gent"
mu = "245 kPa"
jm = 20

[cell.bottom_material]
model = "gent"
mu = "1225 kPa"
jm = 20

[sweep]
outputs = ["characteristic"]
pmax = "300 kPa"
{backend}

[[sweep.parameter]]
name = "cell.top_wall"
values = ["1 mm", "1.2 mm", "4 mm"]
"""


def _spec(tmp: Path, backend: str = "") -> Path:
    p = tmp / "spec.toml"
    p.write_text(SPEC.replace("{backend}", backend))
    return p


def test_a_spec_without_a_backend_runs_on_the_default_cell_model(tmp_path: Path) -> None:
    assert DEFAULT_BACKEND == DEFAULT_MODEL == "calibrated-fast"
    assert load_sweep_spec(_spec(tmp_path)).backend == "calibrated-fast"
    raw = tomllib.loads(SPEC.replace("{backend}", 'backend = "rom"'))
    assert parse_sweep_spec(raw).backend == "rom"   # a named backend is kept
    for path in sorted(EXAMPLES.glob("sweep_*.toml")):
        assert load_sweep_spec(path).backend == DEFAULT_MODEL, path.name


def test_the_summary_says_which_model_answered_each_design(tmp_path: Path) -> None:
    """Top walls of 1 and 1.2 mm (ht/d 0.05, 0.06) lie in the calibrated box, 4 mm (0.2)
    above it: that design is answered by the Ritz model, and the summary counts it."""
    out = tmp_path / "out"
    r = CliRunner().invoke(make_app(), ["sweep", str(_spec(tmp_path)), "--out", str(out),
                                        "--scheduler", "sync", "--json"])
    assert r.exit_code == 0, r.output
    summary = json.loads(r.stdout)
    assert summary["n_ok"] == 3
    assert summary["model"] == "calibrated-fast"
    assert summary["models"] == {"calibrated-fast": 2, "ritz": 1}
    line = _sweep.sweep_model_line(summary["model"], summary["models"])
    assert line.startswith("calibrated-fast (Ritz corrected against 3D FE")
    assert "1 design outside its calibrated box answered by the ritz model" in line
    # the readable output prints that line (a resumed run: nothing left to compute)
    r = CliRunner().invoke(make_app(), ["sweep", str(_spec(tmp_path)), "--out", str(out),
                                        "--scheduler", "sync"])
    assert r.exit_code == 0, r.output
    assert "model: calibrated-fast" in r.output and "answered by the ritz" in r.output
    # and the maps drawn from these results say so in their titles
    ds = open_results(out)
    assert answered_by(ds) == ("calibrated-fast", {"calibrated-fast": 2, "ritz": 1})
    assert model_note(ds) == ("calibrated-fast model (corrected against 3D FE); 1 design by "
                              "the ritz model (outside its box)")
    r = CliRunner().invoke(make_app(), ["plot", "map", str(out), "--json"])
    assert r.exit_code == 0, r.output
    drawn = json.loads(r.stdout)
    assert (drawn["model"], drawn["models"]) == answered_by(ds)


def test_a_folder_run_on_another_backend_is_not_resumed(tmp_path: Path) -> None:
    """The same spec text (so the same hash) read with another default backend: a folder
    of the old run is refused before anything runs, and the message says how to resume."""
    path = _spec(tmp_path)
    spec = load_sweep_spec(path)
    store = SweepStore(tmp_path / "out", spec, spec.design_table(), path.read_text())
    store.prepare()
    man = store.path / "sweep.json"
    old = json.loads(man.read_text())
    assert old["backend"] == "calibrated-fast"
    store.check()                                   # its own folder: resumable
    man.write_text(json.dumps({**old, "backend": "rom"}))
    with pytest.raises(SpecError, match=r"computed with backend 'rom'.*backend = 'rom'"):
        store.check()
