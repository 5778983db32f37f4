"""The shipped example sweeps (``examples/sweep_*.toml``) parse, are valid, and run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from multimorph.sweep import load_sweep_spec, open_results, run_sweep
from multimorph.viz import design_maps
from test_sweep_analytic import SphereBackend

EXAMPLES = sorted((Path(__file__).parents[1] / "examples").glob("sweep_*.toml"))


def test_there_are_figure_4_style_examples() -> None:
    names = {p.stem for p in EXAMPLES}
    assert {"sweep_df", "sweep_ht", "sweep_ws", "sweep_mu", "sweep_map_ht_ws"} <= names


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_parses_and_every_design_is_valid(path: Path) -> None:
    from multimorph.calibrated import load_model

    spec = load_sweep_spec(path)
    assert spec.backend == "calibrated-fast"   # the default cell model (since stop 61)
    assert spec.base.material.model == "gent"  # inline, independent of the library
    table = spec.design_table()
    assert len(table) == spec.n_designs >= 6
    assert not table.invalid, table.invalid[:3]
    # every design inside the calibrated box: no Ritz fallback in an example's map
    model = load_model()
    outside = [(i, model.support(c)["outside"]) for i, c in enumerate(table.cells)
               if not model.support(c)["inside"]]
    assert not outside, outside


def test_example_pipeline_runs_end_to_end_with_a_stand_in_model(tmp_path: Path) -> None:
    # machinery only: the thin-sphere stand-in replaces the reduced model here
    s = run_sweep(Path(EXAMPLES[0]).parent / "sweep_map_ht_ws.toml", tmp_path / "out",
                  scheduler="threads", workers=2, batch_size=16, backend=SphereBackend())
    assert s.n_ok == 64
    ds = open_results(tmp_path / "out")
    assert np.isfinite(ds["critical_pressure"].values).sum() > 0
    files = design_maps(ds, tmp_path / "maps")
    assert [f.name for f in files] == ["families_ht_d.png", "pc_vs_ht_d.png",
                                       "pc_map_ht_d__ws_d.png"]
