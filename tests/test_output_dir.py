"""Output folders written atomically (multimorph.io.atomic_output_dir)."""

import pytest

from multimorph.cli._design import FILES, SOMETIMES
from multimorph.io import atomic_output_dir


def test_files_move_in_only_on_success(tmp_path):
    out = tmp_path / "run"
    with pytest.raises(RuntimeError), atomic_output_dir(out) as tmp:
        (tmp / "report.json").write_text("{}")
        raise RuntimeError("interrupted")
    assert not (out / "report.json").exists()          # nothing half-written
    assert not list(tmp_path.glob(".run.tmp-*"))        # and no temporary folder left
    with atomic_output_dir(out) as tmp:
        (tmp / "report.json").write_text("{}")
    assert (out / "report.json").read_text() == "{}"


def test_a_later_run_leaves_no_stale_device(tmp_path):
    """A design run into the folder of an earlier one: the earlier feasible run's
    ``device.toml`` must not stay beside the later infeasible run's
    ``closest_device.toml`` (stop 37: the verify benchmark published such a stale device
    as the FE-verified design). Files outside ``stale`` are the user's and stay."""
    out = tmp_path / "run"
    with atomic_output_dir(out, stale=SOMETIMES) as tmp:
        for name in ("device.toml", "sequence.png", "report.json"):
            (tmp / name).write_text("first")
    (out / "notes.txt").write_text("mine")
    with atomic_output_dir(out, stale=SOMETIMES) as tmp:
        for name in ("closest_device.toml", "report.json"):
            (tmp / name).write_text("second")
    assert sorted(p.name for p in out.iterdir()) == ["closest_device.toml", "notes.txt",
                                                      "report.json"]
    assert (out / "report.json").read_text() == "second"
    assert not set(SOMETIMES) & set(FILES)
