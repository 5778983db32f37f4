"""The FE reference data set: archive round trip, seeding a sweep folder, the split."""

from __future__ import annotations

import json

import numpy as np
import pytest

from multimorph.calibrated import REFERENCE_SETS, is_holdout, reference_spec
from multimorph.calibrated._dataset import (
    CURVES,
    _set_from_columns,
    collect_set,
    load_reference,
    write_reference,
)
from multimorph.calibrated.build_dataset import seed


def _fake_set(name: str = "grid24", rows: tuple[int, ...] = (0, 3, 5)):
    spec = reference_spec(name)
    n, m = len(rows), 7
    rng = np.random.default_rng(1)
    cols = {"design": np.array(rows), "status": np.array(["ok", "failed", "ok"]),
            "error": np.array(["", "ContinuationError: stalled", ""]),
            "n_points": np.array([7, 0, 5]),
            "curve_stable": np.ones((n, m), bool),
            "meta": [json.dumps({"nfree": 100 + i, "code_version": "x"}) for i in range(n)],
            "critical_pressure": np.array([3e4, np.nan, 2e4])}
    for c in ("pressure", "curvature", "peak_stretch", "axial_stretch", "volume",
              "bend_angle", "twist_rate"):
        arr = np.cumsum(rng.uniform(0.1, 1.0, (n, m)), axis=1)
        arr[1] = np.nan
        arr[2, 5:] = np.nan
        cols[f"curve_{c}"] = arr
    return _set_from_columns(name, cols, spec)


def test_archive_round_trip_keeps_every_array(tmp_path) -> None:
    ref = _fake_set()
    arch, man = tmp_path / "ref.npz", tmp_path / "ref.json"
    write_reference({"grid24": ref}, archive=arch, manifest=man)
    back = load_reference(str(arch))["grid24"]
    np.testing.assert_array_equal(back.design, ref.design)
    np.testing.assert_array_equal(back.status, ref.status)
    np.testing.assert_array_equal(back.values, ref.values)
    for c in CURVES:
        np.testing.assert_array_equal(back.curves[c], ref.curves[c])
    assert back.meta == ref.meta
    info = json.loads(man.read_text())["sets"]["grid24"]
    assert info["finished"] == 3 and info["ok"] == 2 and info["failed"] == 1
    assert info["code_versions"] == ["x"]
    # the rebuilt cell is the spec's design at that index
    assert back.cell(2) == reference_spec("grid24").design_table().cells[5]


def test_a_sweep_folder_seeded_from_the_archive_holds_the_same_designs(tmp_path) -> None:
    ref = _fake_set()
    assert seed("grid24", tmp_path / "grid24", {"grid24": ref}) == 3
    assert seed("grid24", tmp_path / "grid24", {"grid24": ref}) == 0  # nothing twice
    got = collect_set("grid24", tmp_path / "grid24")
    assert got is not None
    np.testing.assert_array_equal(got.design, ref.design)
    np.testing.assert_array_equal(got.status, ref.status)
    ok = ref.status == "ok"
    for c in ("pressure", "bend_angle"):
        a, b = got.curves[c][ok], ref.curves[c][ok]
        np.testing.assert_array_equal(a[:, :b.shape[1]], b)


def test_the_holdout_split_is_a_fixed_fifth_that_does_not_move() -> None:
    ids = np.arange(5000)
    frac = np.mean([is_holdout("bending", i) for i in ids])
    assert frac == pytest.approx(0.2, abs=0.02)
    assert [is_holdout("bending", i) for i in range(40)] == [
        is_holdout("bending", i) for i in range(40)]
    assert all(is_holdout("grid24", i) for i in range(24))  # a validation set only
    assert all(is_holdout("grid24_mirror", i) for i in range(24))


@pytest.mark.parametrize("name", sorted(REFERENCE_SETS))
def test_every_reference_spec_parses_and_covers_its_kind(name: str) -> None:
    spec = reference_spec(name)
    assert spec.backend == "fe" and spec.kind == REFERENCE_SETS[name]
    table = spec.design_table()
    assert len(table.valid_indices) >= {"grid24": 24, "yeoh": 8, "grid24_mirror": 24,
                                        "yeoh_mirror": 8, "bending_narrow": 40,
                                        "stretching_narrow": 25,
                                        "bending_single": 40,
                                        "bending_single2": 40,
                                        "bending_single2_mirror": 40,
                                        "bending_single_mirror": 40,
                                        "bending_single3_mirror": 40,
                                        "bending_narrow_mirror": 40,
                                        "stretching_narrow_mirror": 25,
                                        "bending_lowjm_mirror": 50,
                                        "bending2_mirror": 50,
                                        "yeoh2_mirror": 50,
                                        "yeoh_stretching_mirror": 25,
                                        "yeoh_twisting": 25,
                                        "yeoh3_mirror": 100}.get(name, 100)
    if name.endswith(("_narrow", "_single", "_single2", "_lowjm_mirror",
                      "_softbottom_mirror", "_lowbt_mirror",
                      "_single3_mirror")):
        # a refinement set lies inside its kind's calibrated box (the main set's)
        from multimorph.calibrated._box import Box, cell_groups

        kind = REFERENCE_SETS[name]
        box = Box.from_spec(kind, reference_spec(kind))
        for cell in table.cells:
            if cell is not None:
                assert not box.outside(cell_groups(cell))


def test_a_design_held_out_of_its_twin_set_is_seen_by_no_fit_or_check() -> None:
    """The mirror-ended twin of a set holds the same designs: a fit on both keeps a design
    out when either split holds it out, and a check of a twin the model was not fitted on
    counts only the designs whose fitted twin was held out (the model never saw them in
    any form)."""
    from multimorph.calibrated._fit import fe_training_data, twin_set
    from multimorph.calibrated.validate import unseen_designs

    assert twin_set("bending") == "bending_mirror" and twin_set("bending_mirror") == "bending"
    design = np.arange(200)
    own = np.array([is_holdout("bending_mirror", int(d)) for d in design])
    twin = np.array([is_holdout("bending", int(d)) for d in design])
    assert own.any() and twin.any() and (own != twin).any()
    plate_fit = {"kinds": {"bending": {"sets": ["bending", "bending_narrow"]}}}
    mirror_fit = {"kinds": {"bending": {"sets": ["bending_mirror"]}}}
    np.testing.assert_array_equal(
        unseen_designs(plate_fit, "bending", "bending_mirror", design, own), twin)
    np.testing.assert_array_equal(
        unseen_designs(mirror_fit, "bending", "bending_mirror", design, own), own)
    np.testing.assert_array_equal(
        unseen_designs({"kinds": {}}, "bending", "bending_mirror", design, own),
        np.ones(200, bool))
    assert unseen_designs(plate_fit, "bending", "grid24_mirror", np.arange(24),
                          np.ones(24, bool)).all()
    both = fe_training_data("bending", set_names=("bending", "bending_mirror"), ritz=False)
    for s, d, h in zip(both.set_name, both.design, both.holdout, strict=True):
        assert h == (is_holdout(str(s), int(d)) or is_holdout(twin_set(str(s)), int(d)))


def test_every_fe_activation_is_read_after_the_chamber_balloons() -> None:
    """Real FE paths of the data set (stop 33): a mirror-ended cell that barely bends
    (bending_mirror #20: its end turns by 10⁻³ rad in its first steps) used to read its
    "Pc" at 0.9 kPa, a volume ratio of 1.09, against the fold at 22.6 kPa where it balloons;
    a path cut at 5.5 kPa by the reduced model's early Pc (#99) read 2.3 kPa. Every Pc of
    the bending sets now lies where the chamber has grown by at least
    BALLOONING_VOLUME_RATIO (the ballooning cells read at 2.0 and above)."""
    from multimorph.calibrated._validate import fe_response
    from multimorph.response import BALLOONING_VOLUME_RATIO

    ref = load_reference()["bending_mirror"]
    rows = {int(d): r for r, d in enumerate(ref.design)}
    c20 = fe_response(ref.path(rows[20]), ref.cell(rows[20]), "bending").characteristic
    assert c20.critical_kind == "limit_point"
    assert c20.critical == pytest.approx(22.6e3, rel=0.01)
    c99 = fe_response(ref.path(rows[99]), ref.cell(rows[99]), "bending").characteristic
    assert c99.critical is None and c99.hardening is None
    for r in np.flatnonzero(ref.ok):
        path = ref.path(int(r))
        ch = fe_response(path, ref.cell(int(r)), "bending").characteristic
        if ch.critical is not None:
            v = np.interp(ch.critical, path["pressure"][:np.argmax(path["pressure"]) + 1],
                          path["volume"][:np.argmax(path["pressure"]) + 1])
            assert v >= BALLOONING_VOLUME_RATIO * path["volume"][0]
