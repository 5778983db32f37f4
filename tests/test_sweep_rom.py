"""Sweeps with the reduced model: the Figure-4 trends, and threads vs LocalCluster equality."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from multimorph.errors import MultimorphError
from multimorph.sweep import RomBackend, open_results, parse_sweep_spec, run_sweep
from test_sweep_run import assert_same_results

EXAMPLES = Path(__file__).parents[1] / "examples"


@pytest.fixture(scope="module", autouse=True)
def _need_rom() -> None:
    try:
        batched = RomBackend._api()[1]
    except MultimorphError as exc:
        pytest.skip(f"reduced model not available: {exc}")
    if not batched:
        pytest.skip("the reduced model has no batched entry point yet (one design at a time "
                    "is too slow for these tests)")


def small(name: str, num: int, tmp: Path) -> Path:
    """An example sweep with fewer points."""
    raw = tomllib.loads((EXAMPLES / name).read_text())
    text = (EXAMPLES / name).read_text()
    q = raw["sweep"]["parameter"][0]
    text = text.replace(f"num = {q['num']}", f"num = {num}")
    p = tmp / name
    p.write_text(text)
    return p


@pytest.mark.slow
def test_pc_rises_with_wall_ratios(tmp_path: Path) -> None:
    # the paper's trend (Jeong et al. 2023, Fig. 4 and S1): Pc increases with ht/d, ws/d, df/d
    # (batches of 4 everywhere: the jitted model compiles once for this module)
    for name in ("sweep_ht.toml", "sweep_ws.toml", "sweep_df.toml"):
        spec = small(name, 4, tmp_path)
        out = tmp_path / f"out-{Path(name).stem}"
        s = run_sweep(spec, out, scheduler="threads", workers=1, batch_size=4)
        assert s.n_ok == 4, s.failed
        pc = open_results(out)["critical_pressure"].values
        assert np.all(np.isfinite(pc)), (name, pc)
        assert np.all(np.diff(pc) > 0), (name, pc)


@pytest.mark.slow
def test_rom_sweep_identical_on_threads_and_local_cluster(tmp_path: Path) -> None:
    # 12 designs: 3 ht/d x 4 ws/d, 2 worker processes vs 2 threads, same batches of 4
    text = (EXAMPLES / "sweep_map_ht_ws.toml").read_text()
    text = text.replace('"ht/d" = { start = 0.03, stop = 0.09, num = 8 }',
                        '"ht/d" = { start = 0.03, stop = 0.09, num = 3 }').replace(
        '"ws/d" = { start = 0.04, stop = 0.16, num = 8 }',
        '"ws/d" = { start = 0.04, stop = 0.16, num = 4 }')
    spec = tmp_path / "map.toml"
    spec.write_text(text)
    assert parse_sweep_spec(tomllib.loads(text)).n_designs == 12
    a = run_sweep(spec, tmp_path / "threads", scheduler="threads", workers=2, batch_size=4)
    b = run_sweep(spec, tmp_path / "cluster", scheduler="local", workers=2, batch_size=4)
    assert a.n_ok == b.n_ok == 12, (a.failed, b.failed)
    assert_same_results(open_results(tmp_path / "threads"), open_results(tmp_path / "cluster"))
