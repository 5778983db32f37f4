"""The data set's refinement: FE paths that end where the continuation turned round are
traced again with finer steps and laid over the originals (multimorph.calibrated._refine)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from multimorph.calibrated import reference_spec
from multimorph.calibrated._dataset import _set_from_columns, collect_set, load_reference
from multimorph.calibrated._refine import (
    REFINED_FOLDER,
    REFINED_KINDS,
    REFINEMENT,
    VOLUME_GROWTH,
    candidates,
    ended_by_continuation,
    overlay_refined,
    turned_at_critical,
)
from multimorph.calibrated.build_dataset import seed
from multimorph.sweep import SweepStore

SET = "twisting"


def _limit_path(n: int = 30, turn_back: bool = True) -> dict[str, np.ndarray]:
    """A tilted path whose pressure peaks at 30 kPa (a limit point of the shear); past the
    peak the chamber volume stays (the continuation turned round) or grows by 50 %."""
    s = np.linspace(0.0, 1.0, n)
    P = 3e4 * np.sin(np.pi * s / 1.2)  # the peak at s = 0.6
    peak = int(np.argmax(P))
    V = 1e-6 * (1.0 + s)
    if turn_back:
        V[peak:] = V[peak]
    return {"pressure": P, "shear": 0.3 * s, "curvature": np.zeros(n),
            "peak_stretch": 1.0 + s, "axial_stretch": 1.0 + 0.01 * s, "volume": V,
            "bend_angle": np.zeros(n), "twist_rate": np.zeros(n), "stable": np.ones(n, bool)}


def _smooth_path(n: int = 40) -> dict[str, np.ndarray]:
    """A tilted path that goes on: pressure rising monotonically, the shear rising
    steepest at 20 kPa (a knee: Pc on the slope) then hardening, volume growing 4x."""
    s = np.linspace(0.0, 1.0, n)
    shear = 0.3 / (1.0 + np.exp(-(s - 0.5) / 0.06)) + 0.01 * s
    return {"pressure": 4e4 * s, "shear": shear, "curvature": np.zeros(n),
            "peak_stretch": 1.0 + 2 * s, "axial_stretch": 1.0 + 0.01 * s,
            "volume": 1e-6 * (1.0 + 3 * s), "bend_angle": np.zeros(n), "twist_rate": np.zeros(n),
            "stable": np.ones(n, bool)}


def _columns(designs, paths, metas) -> dict[str, np.ndarray]:
    m = max(len(p["pressure"]) for p in paths)
    cols: dict[str, np.ndarray] = {"design": np.asarray(designs),
                                   "status": np.array(["ok"] * len(designs), dtype=object),
                                   "error": np.array([""] * len(designs), dtype=object),
                                   "meta": np.array([json.dumps(x) for x in metas], dtype=object),
                                   "n_points": np.array([len(p["pressure"]) for p in paths])}
    for k in paths[0]:
        arr = np.full((len(paths), m), False if k == "stable" else np.nan,
                      dtype=bool if k == "stable" else float)
        for i, p in enumerate(paths):
            arr[i, :len(p[k])] = p[k]
        cols["curve_stable" if k == "stable" else f"curve_{k}"] = arr
    return cols


def test_a_limit_point_is_a_turned_round_end_only_when_the_volume_stops_there() -> None:
    from multimorph.calibrated._refine import _critical

    cell = reference_spec(SET).design_table().cells[0]
    stuck, on = _limit_path(), _limit_path(turn_back=False)
    pc, kind = _critical(stuck, cell, "twisting")
    assert kind == "limit_point" and pc == pytest.approx(3e4, rel=2e-3)
    assert turned_at_critical(stuck, pc, kind)
    assert not turned_at_critical(on, *_critical(on, cell, "twisting"))  # volume grew 50 %
    # a volume growing by just under VOLUME_GROWTH past the peak is still a turned-round end
    almost = _limit_path()
    peak = int(np.argmax(almost["pressure"]))
    almost["volume"][-1] = almost["volume"][peak] * (1 + 0.9 * VOLUME_GROWTH)
    assert turned_at_critical(almost, pc, kind)
    assert not turned_at_critical(stuck, pc, "max_slope")  # a Pc on the slope is no end
    assert not turned_at_critical(stuck, None, None)


def test_only_ends_of_the_continuation_are_candidates_not_ends_of_the_traced_range() -> None:
    assert ended_by_continuation({"status": "stalled"})
    assert ended_by_continuation({"status": "max_steps"})
    assert ended_by_continuation({"status": "stopped", "stop_reason": "retraced the path "
                                  "(continuation turned round, e.g. at a branch point)"})
    assert not ended_by_continuation({"status": "stopped",
                                      "stop_reason": "chamber volume ratio exceeded 25"})
    assert not ended_by_continuation({"status": "completed"})


def _folder_with_one_design(tmp_path, design: int):
    spec = reference_spec(SET)
    cols = _columns([design], [_limit_path()], [{"points": 30, "status": "stalled"}])
    ref = _set_from_columns(SET, cols, spec)
    assert seed(SET, tmp_path / SET, {SET: ref}) == 1
    return spec, ref


def test_a_refined_path_replaces_the_original_and_says_what_it_replaced(tmp_path) -> None:
    spec = reference_spec(SET)
    d = int(spec.design_table().valid_indices[0])
    _, ref = _folder_with_one_design(tmp_path, d)
    assert candidates(ref) == [d]
    store = SweepStore(tmp_path / SET / REFINED_FOLDER, spec, spec.design_table())
    with store.locked():
        store.prepare()
        finer = {**_smooth_path(), "meta": {"points": 40, "continuation": dict(REFINEMENT)}}
        store.write_part([d], [finer])
    got = collect_set(SET, tmp_path / SET)
    assert got is not None and got.n_points[0] == 40
    np.testing.assert_array_equal(got.path(0)["pressure"], _smooth_path()["pressure"])
    note = got.meta[0]["refinement"]
    assert note["options"] == REFINEMENT and note["turned_again"] is False
    assert note["previous"]["critical_kind"] == "limit_point"
    assert note["previous"]["critical_pressure"] == pytest.approx(3e4, rel=2e-3)
    assert note["previous"]["status"] == "stalled"
    # the finer path went on past the old end: its Pc is on the slope, at 20 kPa
    assert note["critical_kind"] == "max_slope"
    assert note["critical_pressure"] == pytest.approx(2e4, rel=0.05)
    assert candidates(got) == []  # refined once: never a candidate again


def test_a_failed_refinement_keeps_the_original_path_and_records_the_error(tmp_path) -> None:
    spec = reference_spec(SET)
    d = int(spec.design_table().valid_indices[1])
    _, ref = _folder_with_one_design(tmp_path, d)
    store = SweepStore(tmp_path / SET / REFINED_FOLDER, spec, spec.design_table())
    with store.locked():
        store.prepare()
        store.write_part([d], [{"status": "failed", "error": "ContinuationError: stalled"}])
    got = collect_set(SET, tmp_path / SET)
    assert got is not None and got.status[0] == "ok"
    np.testing.assert_array_equal(got.path(0)["pressure"], ref.path(0)["pressure"])
    assert got.meta[0]["refinement"]["error"] == "ContinuationError: stalled"
    assert candidates(got) == []


def test_a_finer_path_that_reads_no_pc_leaves_the_original_label(tmp_path) -> None:
    """A finer path that wanders on past the old limit point through more folds than the
    Pc reading resolves (no Pc on it) does not erase a Pc: the original path stays."""
    from multimorph.calibrated._refine import KEPT_NO_PC, _critical

    spec = reference_spec(SET)
    d = int(spec.design_table().valid_indices[2])
    _, ref = _folder_with_one_design(tmp_path, d)
    n = 25
    flat = {**_smooth_path(n), "shear": np.linspace(0.0, 0.01, n),
            "volume": 1e-6 * np.linspace(1.0, 1.1, n)}  # never balloons: no Pc to read
    assert _critical(flat, spec.design_table().cells[d], "twisting")[0] is None
    store = SweepStore(tmp_path / SET / REFINED_FOLDER, spec, spec.design_table())
    with store.locked():
        store.prepare()
        store.write_part([d], [{**flat, "meta": {"continuation": dict(REFINEMENT)}}])
    got = collect_set(SET, tmp_path / SET)
    assert got is not None
    np.testing.assert_array_equal(got.path(0)["pressure"], ref.path(0)["pressure"])
    note = got.meta[0]["refinement"]
    assert note["kept"] == KEPT_NO_PC and note["critical_pressure"] is None
    assert candidates(got) == []


def test_overlay_leaves_designs_without_a_refinement_alone() -> None:
    cols = _columns([2, 5], [_limit_path(), _smooth_path()], [{}, {}])
    out = overlay_refined(cols, {}, lambda i: None, "twisting")
    for k in cols:
        np.testing.assert_array_equal(out[k], cols[k])


def test_the_shipped_tilted_sets_hold_no_turned_round_end_left_unrefined() -> None:
    """Every tilted FE path of the archive whose Pc is where the continuation turned round
    has been traced again with finer steps (``build_dataset --refine``, stop 56), and every
    refined path of the archive says what it replaced."""
    assert set(REFINED_KINDS) == {"bending", "stretching", "twisting"}
    refs = load_reference()
    tilted = [r for r in refs.values() if r.kind == "twisting"]
    assert len(tilted) >= 5
    for ref in tilted:
        assert candidates(ref) == [], ref.name
    notes = [(r, m) for ref in refs.values() for r, m in enumerate(ref.meta)
             if "refinement" in m]
    assert sum(1 for ref in tilted for m in ref.meta if "refinement" in m) >= 20
    for _, m in notes:
        x = m["refinement"]
        assert x["previous"]["critical_kind"] == "limit_point"
        assert x["options"]["dx_max"] == REFINEMENT["dx_max"]
        if "error" not in x and "kept" not in x:  # the finer run's settings are its record's
            assert m["continuation"]["dx_max"] == REFINEMENT["dx_max"]
            assert m["continuation"]["max_steps"] == REFINEMENT["max_steps"]
