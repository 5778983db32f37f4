"""Running sweeps: one result per design, failures recorded, resume, scheduler equality.

The model is the test-only thin-sphere backend of ``test_sweep_analytic`` (not the physics
of a cell): these tests are about the sweep machinery.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import zarr

from multimorph.errors import MultimorphError, SpecError
from multimorph.sweep import SweepStore, open_results, parse_sweep_spec, run_sweep
from test_sweep_analytic import SphereBackend

TESTS = Path(__file__).parent

SPEC = """
[cell]
length = "20 mm"
width = "10 mm"
height = "8 mm"
top_wall = "1 mm"
bottom_wall = "2 mm"
side_wall = "2 mm"
end_wall = "2 mm"

[cell.material]
model = "gent"
mu = "245 kPa"
jm = 20

[sweep]
backend = "sphere"
outputs = ["characteristic", "curves"]
pmax = "200 kPa"
{extra}

[[sweep.parameter]]
name = "ht/d"
start = 0.02
stop = 0.08
num = {num}

[[sweep.parameter]]
name = "ws/d"
values = [0.1, 0.15, 0.3]
"""


def write_spec(tmp: Path, num: int = 4, extra: str = "", name: str = "spec.toml") -> Path:
    p = tmp / name
    p.write_text(SPEC.replace("{extra}", extra).replace("{num}", str(num)))
    return p


def part_indices(out: Path) -> np.ndarray:
    parts = sorted((out / "parts").glob("part-*.zarr"))
    if not parts:
        return np.zeros(0, np.int64)
    return np.concatenate([zarr.open_group(str(p), mode="r")["design"][:] for p in parts])


def assert_same_results(a: Any, b: Any) -> None:
    """Equal numbers, strings and design tables (bitwise: same batches, same arithmetic)."""
    assert sorted(a.data_vars) == sorted(b.data_vars)
    for v in a.data_vars:
        x, y = a[v].values, b[v].values
        if x.dtype.kind == "f":
            np.testing.assert_array_equal(x, y, err_msg=v)
        else:
            assert x.tolist() == y.tolist(), v


def test_threads_one_result_per_design_equal_to_direct_evaluation(tmp_path: Path) -> None:
    spec = write_spec(tmp_path)
    seen: list[tuple[int, int]] = []
    s = run_sweep(spec, tmp_path / "out", scheduler="threads", workers=2, batch_size=3,
                  progress=lambda d, t: seen.append((d, t)))
    assert (s.n_designs, s.n_invalid, s.n_ok, s.n_failed) == (12, 4, 8, 0)
    assert seen[0] == (0, 8) and seen[-1] == (8, 8)
    ds = open_results(tmp_path / "out")
    assert ds.sizes["design"] == 12
    idx = part_indices(tmp_path / "out")
    assert sorted(idx.tolist()) == [i for i in range(12) if i % 3 != 2]  # ws/d = 0.3 invalid
    assert list(ds["status"].values[2::3]) == ["invalid"] * 4
    assert "side_wall 6 mm leaves no chamber" in ds["error"].values[2]
    # every stored number is the backend's number for that design
    table = parse_sweep_spec(tomllib.loads(spec.read_text())).design_table()
    for i in (0, 4, 10):
        ref = SphereBackend._one(table.cells[i], 200e3, 60)
        assert ds["critical_pressure"].values[i] == ref.characteristic.critical
        n = int(ds["n_points"].values[i])
        np.testing.assert_array_equal(ds["curve_pressure"].values[i, :n], ref.path.pressure)
        assert np.isnan(ds["curve_pressure"].values[i, n:]).all()
    # the spec, its hash and the versions travel with the results
    assert ds.attrs["spec_hash"] == parse_sweep_spec(tomllib.loads(spec.read_text())).spec_hash
    assert "multimorph" in ds.attrs["versions"]
    assert (tmp_path / "out" / "spec.toml").read_text() == spec.read_text()
    assert ds["ht_d"].attrs["long_name"] == "ht/d"


def test_failing_design_is_recorded_not_fatal(tmp_path: Path) -> None:
    # top walls above 1.3 mm make the (test) model raise; batches are retried design by design
    spec = write_spec(tmp_path, extra="[sweep.options]\nfail_top_wall_above = 1.3e-3")
    s = run_sweep(spec, tmp_path / "out", scheduler="sync", batch_size=4)
    ds = open_results(tmp_path / "out")
    ht = ds["top_wall"].values
    failed = ds["status"].values == "failed"
    assert s.n_failed == failed.sum() > 0
    np.testing.assert_array_equal(failed, ht > 1.3e-3)
    assert all("ValueError: synthetic failure" in e for e in ds["error"].values[failed])
    assert np.isnan(ds["critical_pressure"].values[failed]).all()
    ok = ds["status"].values == "ok"
    assert ok.sum() == s.n_ok == 12 - 4 - s.n_failed
    assert np.isfinite(ds["critical_pressure"].values[ok]).all()


def test_retry_failed_reruns_only_failures_and_success_supersedes(tmp_path: Path) -> None:
    flag = tmp_path / "flaky"
    flag.write_text("")
    spec = write_spec(tmp_path, extra=f"[sweep.options]\nfail_top_wall_above = 1.3e-3\n"
                                      f"fail_while_exists = {str(flag)!r}")
    out = tmp_path / "out"
    first = run_sweep(spec, out, scheduler="sync", batch_size=4)
    assert first.n_failed > 0
    flag.unlink()  # the cause of the failures is gone
    assert run_sweep(spec, out, scheduler="sync", batch_size=4).n_run == 0  # kept by default
    again = run_sweep(spec, out, scheduler="sync", batch_size=4, retry_failed=True)
    assert (again.n_run, again.n_failed, again.n_ok) == (first.n_failed, 0, 8)
    ds = open_results(out)
    assert ds.sizes["design"] == 12 and (ds["status"].values == "ok").sum() == 8
    assert np.isfinite(ds["critical_pressure"].values[ds["status"].values == "ok"]).all()


def test_rerun_resumes_and_a_different_spec_is_refused(tmp_path: Path) -> None:
    spec = write_spec(tmp_path)
    out = tmp_path / "out"
    first = run_sweep(spec, out, scheduler="sync", batch_size=2)
    ref = open_results(out)
    # lose two finished batches (as if killed before they were written), rerun
    parts = sorted((out / "parts").glob("part-*.zarr"))
    for p in parts[1:3]:
        shutil.rmtree(p)
    (out / "parts" / ".tmp-part-half-written").mkdir()  # a killed write leaves this
    again = run_sweep(spec, out, scheduler="sync", batch_size=2)
    assert (again.n_resumed, again.n_run) == (first.n_ok - 4, 4)
    assert not (out / "parts" / ".tmp-part-half-written").exists()
    assert sorted(part_indices(out).tolist()) == sorted(ref["design"].values[
        ref["status"].values == "ok"].tolist())
    assert_same_results(open_results(out), ref)
    # a complete sweep reruns nothing
    assert run_sweep(spec, out, scheduler="sync").n_run == 0
    # another spec into the same folder is refused, naming both hashes
    other = write_spec(tmp_path, num=5, name="other.toml")
    with pytest.raises(SpecError, match="holds results of a different sweep spec"):
        run_sweep(other, out, scheduler="sync")
    # a folder with other files is not taken over
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "notes.txt").write_text("mine")
    with pytest.raises(SpecError, match="not a sweep folder and not empty"):
        run_sweep(spec, tmp_path / "busy", scheduler="sync")


def test_folder_is_locked_while_a_sweep_writes(tmp_path: Path) -> None:
    spec = parse_sweep_spec(tomllib.loads(write_spec(tmp_path).read_text()))
    store = SweepStore(tmp_path / "out", spec, spec.design_table())
    with store.locked(), pytest.raises(MultimorphError, match="another sweep is writing"):
        run_sweep(spec, tmp_path / "out", scheduler="sync")


def test_open_results_of_an_unfinished_sweep_says_so(tmp_path: Path) -> None:
    spec = parse_sweep_spec(tomllib.loads(write_spec(tmp_path).read_text()))
    SweepStore(tmp_path / "out", spec, spec.design_table()).prepare()
    with pytest.raises(MultimorphError, match="has not finished: rerun it to resume"):
        open_results(tmp_path / "out")


@pytest.mark.slow
def test_threads_and_local_cluster_processes_give_identical_results(tmp_path: Path) -> None:
    # 36 designs (27 valid); LocalCluster with 2 separate worker processes vs local threads
    spec = write_spec(tmp_path, num=12)
    a = run_sweep(spec, tmp_path / "threads", scheduler="threads", workers=2, batch_size=4)
    b = run_sweep(spec, tmp_path / "cluster", scheduler="local", workers=2, batch_size=4)
    assert (a.n_ok, b.n_ok, a.n_designs) == (24, 24, 36)
    assert b.scheduler == "local"
    assert_same_results(open_results(tmp_path / "threads"), open_results(tmp_path / "cluster"))


@pytest.mark.slow
def test_sigkill_half_way_then_rerun_completes_exactly_once(tmp_path: Path) -> None:
    # 40 designs, 1 per task, 0.1 s each: SIGKILL the CLI process once a third is stored
    spec = write_spec(tmp_path, num=20, extra="[sweep.options]\ndelay = 0.1")
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(TESTS), os.environ.get(
        "PYTHONPATH", "")])}
    code = ("import sys, typer, test_sweep_analytic\nfrom multimorph.cli import _sweep, _plot\n"
            "app = typer.Typer()\n_sweep.register(app)\n_plot.register(app)\n"
            "app(sys.argv[1:])\n")
    proc = subprocess.Popen(
        [sys.executable, "-c", code, "sweep", str(spec), "--out", str(out), "--scheduler",
         "sync", "--batch-size", "1"], env=env, stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while part_indices(out).size < 13 if (out / "parts").is_dir() else True:
            assert proc.poll() is None, "sweep ended before it could be killed"
            assert time.monotonic() < deadline, "sweep too slow to reach half-way"
            time.sleep(0.05)
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
    finally:
        if proc.poll() is None:
            proc.kill()
    stored = part_indices(out)
    assert 13 <= stored.size < 40  # killed part-way
    assert not (out / "results.zarr").exists()
    s = run_sweep(spec, out, scheduler="threads", workers=2, batch_size=1)
    assert s.n_resumed == stored.size and s.n_run == 40 - stored.size
    idx = part_indices(out)
    assert sorted(idx.tolist()) == sorted(set(idx.tolist()))  # nothing duplicated
    assert sorted(idx.tolist()) == [i for i in range(60) if i % 3 != 2]  # nothing lost
    ref = run_sweep(spec, tmp_path / "ref", scheduler="threads", workers=2, batch_size=1)
    assert ref.n_ok == s.n_ok == 40
    assert_same_results(open_results(out), open_results(tmp_path / "ref"))


def test_fe_backend_without_the_fe_room_names_the_missing_piece(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "multimorph.fe", None)  # as if not installed
    spec = write_spec(tmp_path)
    spec.write_text(spec.read_text().replace('"sphere"', '"fe"'))
    with pytest.raises(MultimorphError, match=r"needs multimorph\.fe, which is not available"
                       r".*finite-element model of issue 5"):
        run_sweep(spec, tmp_path / "out", scheduler="sync")
    assert not (tmp_path / "out").exists()


def test_unknown_backend_is_a_spec_error(tmp_path: Path) -> None:
    spec = write_spec(tmp_path)
    spec.write_text(spec.read_text().replace('"sphere"', '"cfd"'))
    with pytest.raises(SpecError, match="unknown backend 'cfd'; known: calibrated, "
                                        "calibrated-fast, fe, ritz, rom"):
        run_sweep(spec, tmp_path / "out", scheduler="sync")


def test_unknown_scheduler_is_refused(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match="scheduler: expected local, threads, sync or an addr"):
        run_sweep(write_spec(tmp_path), tmp_path / "out", scheduler="processes")


class PaddedSphere(SphereBackend):
    """Records the batch sizes it is called with; asks for padded batches."""

    pad_batches = True

    def __init__(self) -> None:
        self.sizes: list[int] = []

    def evaluate_batch(self, designs, pmax, outputs, options):  # type: ignore[no-untyped-def]
        self.sizes.append(len(designs))
        return super().evaluate_batch(designs, pmax, outputs, options)


def test_short_batches_are_padded_for_jitted_backends_and_padding_dropped(
        tmp_path: Path) -> None:
    be = PaddedSphere()
    spec = write_spec(tmp_path, num=5)  # 15 designs, 10 valid: batches of 3 -> 3, 3, 3, 1
    s = run_sweep(spec, tmp_path / "out", scheduler="sync", batch_size=3, backend=be)
    assert be.sizes == [3, 3, 3, 3]
    assert s.n_ok == 10
    assert sorted(part_indices(tmp_path / "out").tolist()) == [i for i in range(15)
                                                              if i % 3 != 2]
    ds = open_results(tmp_path / "out")
    table = parse_sweep_spec(tomllib.loads(spec.read_text())).design_table()
    for i in table.valid_indices:
        ref = SphereBackend._one(table.cells[i], 200e3, 60).characteristic.critical
        assert ds["critical_pressure"].values[i] == ref


@pytest.mark.slow
def test_fe_backend_one_design_per_task(tmp_path: Path) -> None:
    pytest.importorskip("felupe")
    spec = write_spec(tmp_path, num=1)  # ht/d = 0.02: 3 designs, 2 valid
    text = spec.read_text().replace('"sphere"', '"fe"')
    text = text.replace('pmax = "200 kPa"', 'pmax = "10 kPa"').replace(
        "values = [0.1, 0.15, 0.3]", "values = [0.1, 0.3]")
    spec.write_text(text + '\n[sweep.options]\nmesh = "coarse"\n')
    s = run_sweep(spec, tmp_path / "out", scheduler="sync")
    assert (s.n_designs, s.n_invalid, s.n_ok) == (2, 1, 1), s.failed
    ds = open_results(tmp_path / "out")
    assert ds.attrs["backend"] == "fe"
    n = int(ds["n_points"].values[0])
    assert n > 2 and ds["curve_pressure"].values[0, n - 1] == pytest.approx(10e3)
    spec.write_text(text + "\n[sweep.options]\nmesh_size = 1\n")
    with pytest.raises(SpecError, match=r"sweep\.options: not an FE setting"):
        run_sweep(spec, tmp_path / "out2", scheduler="sync")


def test_parts_with_an_extra_curve_on_shorter_paths_merge_on_one_point_axis(
        tmp_path: Path) -> None:
    """A curve that only some parts record (the tilted data set's strip shear in parts seeded
    from the archive) may be shorter than the sweep's longest path: it is padded with NaN,
    the merge does not fail (stop 34: the twisting set's final merge did)."""
    spec = parse_sweep_spec(tomllib.loads(write_spec(tmp_path).read_text()))
    table = spec.design_table()
    store = SweepStore(tmp_path / "out", spec, table)
    store.prepare()
    i, j = [k for k, c in enumerate(table.cells) if c is not None][:2]

    def record(m: int, **extra: Any) -> dict[str, Any]:
        p = np.linspace(0.0, 1e4, m)
        return {"status": "ok", "pressure": p, "curvature": p * 1e-3,
                "peak_stretch": 1.0 + p * 1e-5, "stable": np.ones(m, bool), **extra}

    store.write_part([i], [record(5, shear=np.linspace(0.0, 0.1, 5))])
    store.write_part([j], [record(8)])
    store.consolidate()
    res = open_results(tmp_path / "out")
    shear = res["curve_shear"].values
    assert res["curve_pressure"].shape[1] == shear.shape[1] == 8
    np.testing.assert_allclose(shear[i, :5], np.linspace(0.0, 0.1, 5))
    assert np.all(np.isnan(shear[i, 5:])) and np.all(np.isnan(shear[j]))
    np.testing.assert_allclose(res["curve_pressure"].values[j], np.linspace(0.0, 1e4, 8))
