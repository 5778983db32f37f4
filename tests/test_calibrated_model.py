"""The shipped calibrated cell model: it beats the Ritz model on FE designs it never saw, knows
its support, and is the default of the commands (issue 22)."""

from __future__ import annotations

import copy
import json
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from multimorph.calibrated import CalibrationWarning, load_model
from multimorph.geometry import CellGeometry
from multimorph.io import load_toml
from multimorph.models import DEFAULT_MODEL

pytestmark = pytest.mark.slow

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _median_error(rows: list, key: str) -> float:
    errs = [getattr(r, key) for r in rows if r is not None and getattr(r, key) is not None]
    errs = [abs(e) for e in errs if np.isfinite(e)]
    assert len(errs) >= 3, key
    return float(np.median(errs))


@pytest.mark.parametrize("kind", ["bending", "stretching"])
def test_on_the_held_out_fe_designs_the_calibrated_model_is_far_closer_than_ritz(kind) -> None:
    """The held-out fifth of the FE reference set (never used in the fit): the calibrated
    model's Ph is within 10 % (median) and its Pc within 20 % of FE, where the Ritz model
    is off by 100–250 % (measured at stop 31 on the kind's first training set, bending /
    stretching_mirror: Pc 2.4 % / 6.2 %, Ph 2.4 % / 4.7 % against Ritz 127 % / 172 %,
    164 % / 259 %; docs/validation.md)."""
    from multimorph.calibrated._fit import KIND_SETS
    from multimorph.calibrated.validate import evaluate

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        res = evaluate(kind, KIND_SETS[kind][0])
    cal_pc, ritz_pc = _median_error(res["calibrated"], "pc_error"), \
        _median_error(res["ritz"], "pc_error")
    cal_ph, ritz_ph = _median_error(res["calibrated"], "ph_error"), \
        _median_error(res["ritz"], "ph_error")
    assert cal_pc < 0.20 and cal_ph < 0.10
    assert ritz_pc > 0.5 and ritz_ph > 0.5
    assert cal_pc < ritz_pc / 4 and cal_ph < ritz_ph / 4


def test_a_fast_path_is_not_cut_before_its_anchor_by_an_emulated_ritz_pc() -> None:
    """The fast variant's data range is 0.85 × the emulated Ritz Pc; on
    `bending_softbottom_mirror` #28 (held out) the emulator puts it at 8.7 kPa where the
    Ritz model reads 42.1 kPa, which cut the path at V/V0 1.7, before its activation: it
    read Pc 2.1 kPa (the cell's first bend the wrong way) against FE's 18.1 kPa, its
    anchor (17.7 kPa) unused beyond the path. The range is at least
    ``ANCHOR_RANGE_FACTOR`` × the Pc anchor (stop 48): the path reaches its anchors and
    Pc and Ph are within the issue's 10 % of FE (the cut read 88 % low). On the shipped
    model (stop 54) the fast variant reads Pc 19.1 kPa (+5.6 %; its anchor 18.9, its
    path 19.2) and Ph 20.5 kPa (+2.0 %), the exact variant Pc 18.4 kPa (+1.3 %); stop 48's
    read the fast Pc within 1 %: one held-out design's error moves with each refit, the
    bending pools' p90 is 5–7 % (docs/validation.md §3)."""
    from multimorph.calibrated._fit import fe_training_data
    from multimorph.calibrated._model import ANCHOR_RANGE_FACTOR
    from multimorph.calibrated._validate import fe_response
    from multimorph.calibrated.validate import at_end_of, requested_pressure

    name = "bending_softbottom_mirror"
    data = fe_training_data("bending", set_names=(name,), ritz=False)
    r = int(np.flatnonzero(data.design == 28)[0])
    assert data.holdout[r]
    model, _ = at_end_of(load_model(), "bending", name)
    p_max = requested_pressure(name, 28, data.paths[r])
    fe = fe_response(data.paths[r], data.cells[r], "bending").characteristic
    resp = model.responses([data.cells[r]], p_max, fast=True)[0]
    cal = resp.meta["calibration"]
    assert cal["anchors"]["used"] == ["critical", "hardening"]
    assert cal["data_pressure_end"] >= ANCHOR_RANGE_FACTOR * cal["anchors"][
        "critical_pressure"] * (1 - 1e-12)
    assert resp.characteristic.critical == pytest.approx(fe.critical, rel=0.10)
    assert resp.characteristic.hardening == pytest.approx(fe.hardening, rel=0.10)


def test_a_cell_outside_the_box_is_answered_by_ritz_and_says_which_groups() -> None:
    cell = CellGeometry.from_spec(load_toml(EXAMPLES / "cell.toml")["cell"])
    model = load_model()
    assert model.support(cell)["inside"]
    thick = replace(cell, top_wall=4e-3)          # ht/d = 0.2, above the box
    sup = model.support(thick)
    assert not sup["inside"] and "ht/d" in sup["outside"]
    with pytest.warns(CalibrationWarning, match="ht/d"):
        r = model.response(thick, 0.3 * cell.mu)
    assert r.meta["model"] == "ritz"
    assert r.meta["calibration"]["inside"] is False
    assert "ht/d" in r.meta["calibration"]["outside"]
    # in a batch with it, a cell inside the box gets the same answer as alone
    with pytest.warns(CalibrationWarning):
        both = model.responses([cell, thick], 0.3 * cell.mu)
    alone = model.response(cell, 0.3 * cell.mu)
    np.testing.assert_allclose(both[0].path.pressure, alone.path.pressure)
    np.testing.assert_allclose(both[0].path.curvature, alone.path.curvature)
    assert both[1].meta["model"] == "ritz"


def test_the_cell_command_uses_the_fast_calibrated_model_by_default(tmp_path) -> None:
    from multimorph.cli import app
    from multimorph.cli._app import _register

    _register()
    assert DEFAULT_MODEL == "calibrated-fast"
    res = CliRunner().invoke(app, ["cell", str(EXAMPLES / "cell.toml"), "--json", "--out",
                                   str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert data["model"] == "calibrated-fast" and data["calibration"]["inside"] is True
    assert data["calibration"]["features"] == "emulated"
    # a pressure path that rises with the volume, up to the data set's V/V0 = 25 at most
    assert np.all(np.diff(data["volume"]) > 0)
    assert data["calibration"]["volume_ratio_end"] <= 25.0 + 1e-9
    bad = CliRunner().invoke(app, ["cell", str(EXAMPLES / "cell.toml"), "--model", "cfd",
                                   "--out", str(tmp_path / "p")])
    assert bad.exit_code == 2 and "--model" in bad.output
    assert not (tmp_path / "p").exists()


def test_the_shipped_ritz_emulator_reproduces_the_ritz_features_it_stands_for() -> None:
    """The emulated Ritz features and Ritz Pc (what the model reads instead of tracing the
    Ritz model) agree with the exact ones on designs of the box it was not fitted on; the
    accuracy it was shipped with is in the manifest."""
    import dataclasses

    from multimorph.calibrated import reference_spec
    from multimorph.calibrated._box import cell_groups
    from multimorph.calibrated._ritz import ritz_features_and_pc

    model = load_model()
    if "bending" not in model.emulators:
        pytest.skip("the shipped model traces the Ritz model (no emulator)")
    test_err = model.manifest["emulators"]["bending"]["test_error"]
    assert test_err["log_p_ritz_t075"]["median"] < 0.05
    assert test_err["log_pc_ritz"]["median"] < 0.05
    spec = dataclasses.replace(reference_spec("bending"), samples=16, seed=123)
    cells = [c for c in spec.design_table().cells if c is not None][:8]
    exact, pcs = ritz_features_and_pc(cells)
    box = model.emulator_boxes["bending"]
    x = box.scaled(np.array([[cell_groups(c)[n] for n in box.names] for c in cells]))
    emu = model.emulators["bending"].predict(x)
    ok = np.all(np.isfinite(exact), axis=1)
    assert ok.sum() >= 6
    # log P at two volumes: a few per cent (relative pressure)
    assert np.median(np.abs(emu[ok, :2] - exact[ok, :2])) < 0.03
    fin = np.isfinite(pcs)
    mus = np.array([c.mu for c in cells])
    assert np.median(np.abs(emu[fin, 4] - np.log(pcs[fin] / mus[fin]))) < 0.08


def test_the_fast_variant_reads_emulated_features_and_stays_near_the_exact_model() -> None:
    """``calibrated-fast`` (emulated Ritz features, no Ritz trace) says which variant made
    it and lands near the exact-feature model on the example cell (its own held-out error
    against FE is in docs/validation.md)."""
    from multimorph.models import cell_model

    model = load_model()
    if not model.fast_kinds:
        pytest.skip("the shipped model has no fast variant")
    cell = CellGeometry.from_spec(load_toml(EXAMPLES / "cell.toml")["cell"])
    exact = cell_model("calibrated")(cell, 0.9 * cell.mu)
    fast = cell_model("calibrated-fast")(cell, 0.9 * cell.mu)
    assert exact.meta["model"] == "calibrated"
    assert fast.meta["model"] == "calibrated-fast"
    assert fast.meta["calibration"]["features"] == "emulated"
    pc, pc_fast = exact.characteristic.critical, fast.characteristic.critical
    assert pc is not None and pc_fast is not None
    assert abs(pc_fast / pc - 1.0) < 0.25


def test_the_bending_model_answers_as_inside_a_module_and_knows_the_plate_level() -> None:
    """Since stop 33 the bending GPs take the cell's end condition as an input (plate-ended
    sets 0, their mirror-ended twins 1; ``_fit.end_column``) and every command is answered
    at 1, the cell as inside a module. On designs the fit never saw with either end, where
    the plate stiffens the cell by 5 % or more (one-elastomer and wide cells), the mirror
    level must follow the mirror FE and sit below the plate level, which follows the plate
    FE: the input carries the physics of the ends, not noise."""
    from multimorph.calibrated._dataset import is_holdout, load_reference
    from multimorph.calibrated._validate import fe_response
    from multimorph.calibrated.validate import at_end_of

    model = load_model()
    assert model.kinds["bending"].end_input == 1.0
    plate_model, end = at_end_of(model, "bending", "bending")
    assert end == 0.0 and plate_model.kinds["bending"].end_input == 0.0
    assert at_end_of(model, "bending", "bending_mirror")[0] is model
    sets = load_reference()
    rows = []
    for plate in ("bending", "bending_single", "bending_single2", "bending_narrow"):
        a, b = sets[plate], sets[f"{plate}_mirror"]
        index = {int(d): i for i, d in enumerate(a.design)}
        for j, d in enumerate(b.design):
            i = index.get(int(d))
            if i is None or not (a.ok[i] and b.ok[j]):
                continue
            if not (is_holdout(plate, int(d)) or is_holdout(f"{plate}_mirror", int(d))):
                continue
            fp = fe_response(a.path(i), a.cell(i), "bending").characteristic.critical
            fm = fe_response(b.path(j), b.cell(j), "bending").characteristic.critical
            if fp and fm and fm < 0.95 * fp:
                rows.append((b.cell(j), fp, fm, float(np.max(a.path(i)["pressure"]))))
    assert len(rows) >= 10
    err_m, err_p, ratio = [], [], []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CalibrationWarning)
        for cell, fp, fm, pmax in rows:
            m = model.responses([cell], pmax)[0].characteristic.critical
            p = plate_model.responses([cell], pmax)[0].characteristic.critical
            if m is None or p is None:
                continue
            err_m.append(abs(m - fm) / fm)
            err_p.append(abs(p - fp) / fp)
            ratio.append(m / p)
    assert len(ratio) >= 0.8 * len(rows)
    assert np.median(err_m) < 0.10 and np.median(err_p) < 0.10
    assert np.median(ratio) < 0.95


def test_a_design_rounded_onto_a_box_edge_is_inside_and_beyond_it_is_not() -> None:
    """A device file writes lengths to 0.01 mm, which can move a group designed on the
    box's edge 0.06 % past it (the gripper's fingers: ht/d 0.1601 for 0.16, stop 37): that
    is inside (EDGE_RTOL); 1 % past the edge is outside, and named."""
    from multimorph.calibrated._box import EDGE_RTOL

    box = load_model().kinds["bending"].box
    j = box.names.index("ht/d")
    groups = dict(zip(box.names, 0.5 * (box.low + box.high), strict=True))
    assert box.outside(groups) == {}
    hi = float(box.high[j])
    assert box.outside({**groups, "ht/d": hi * 1.0006}) == {}
    assert box.outside({**groups, "ht/d": hi * (1 + 0.9 * EDGE_RTOL)}) == {}
    out = box.outside({**groups, "ht/d": hi * 1.01})
    assert list(out) == ["ht/d"] and out["ht/d"][2] == pytest.approx(hi)
    assert box.outside({**groups, "ht/d": float(box.low[j]) * 0.99}) != {}


def test_the_bending_signal_gp_brings_the_curve_after_the_snap_closer_to_fe() -> None:
    """The bending kind's signal GP (a kernel of its own past the snap, averaged with the
    path GP's signal, stop 40): on the held-out mirror-ended FE designs, the largest error
    of κd at V/V0 ≥ e (over the design's largest |κd|) is smaller in the median than with
    the path GP's signal alone, in both variants; and the run time averages the two."""
    from multimorph.calibrated._fit import fe_training_data
    from multimorph.calibrated._representation import T_GRID
    from multimorph.calibrated.validate import at_end_of, unseen_designs

    base = load_model()
    if base.kinds["bending"].signal is None:
        pytest.skip("the shipped bending kind has no signal GP")
    data = fe_training_data("bending", set_names=("bending_mirror",), ritz=False)
    model, _ = at_end_of(base, "bending", "bending_mirror")
    rows = np.flatnonzero(unseen_designs(model.manifest, "bending", "bending_mirror",
                                         data.design, data.holdout))
    assert rows.size >= 40
    cells = [data.cells[r] for r in rows]
    late = T_GRID >= 1.0
    for fast in (True, False) if model.fast_kinds else (False,):
        kinds = model.fast_kinds if fast else model.kinds
        k = kinds["bending"]
        assert 0.0 < k.signal_weight <= 1.0
        path_only = copy.copy(model)
        alone = {**kinds, "bending": replace(k, signal=None)}
        if fast:
            path_only.fast_kinds = alone
        else:
            path_only.kinds = alone
        errs = []
        for m in (model, path_only):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", CalibrationWarning)
                pred = m.grid(cells, fast=fast)
            e = []
            for j, r in enumerate(rows):
                cov = data.mask[r] & late
                if not cov.any():
                    continue
                y_fe = data.y[r][:, 1] * T_GRID
                y_m = pred.values[j][:, 1] * T_GRID
                e.append(np.max(np.abs(y_m - y_fe)[cov]) / np.max(np.abs(y_fe[data.mask[r]])))
            errs.append(float(np.median(e)))
        assert errs[0] < errs[1], (fast, errs)


def test_where_the_anchor_and_the_path_disagree_the_band_and_the_cell_line_say_so() -> None:
    """A cell whose path and anchor read Pc far apart (``bending_lowjm_mirror`` #21, a
    Jm 9–14 cell no fit has seen): the model's path reads its Pc at 4.4 kPa, its anchor at
    32.5 kPa, FE at 4.5. The anchor is left out (more than MAX_FACTOR from the path's
    reading), so the reported Pc is the path's; its ±1σ band must then reach over the
    anchor's own ±1σ, the path must be the right one of the two (FE within 15 % of it,
    where the anchor is 6 times FE), and the readable cell line (and a device's, for its
    module) must say so. (Until stop 44 the case was ``bending_single_mirror`` #15, where
    the anchor was the right one; stop 45's path reads it within 16 % and uses its anchor.)

    The band's lower side is the path's own σ, 2 % in log P here, and it understates the
    path's error on this cell: stop 53's model read 4.6 kPa (0.5σ from FE), stop 54's 4.8
    (+6.5 %, 1.7σ), stop 59's 5.0 (+11 %, 3.3σ). At Jm 9–14 the errors' tail is heavier
    than the band (docs/validation.md §4 stop 44 and stop 59; the pool's coverage is read
    by validate, not on one design), so this case checks the choice of reading, not the
    band's width."""
    import math

    from multimorph.calibrated._anchor import MAX_FACTOR
    from multimorph.calibrated._dataset import load_reference
    from multimorph.calibrated._validate import fe_response
    from multimorph.calibrated.validate import requested_pressure
    from multimorph.cli._cell import model_line

    ref = load_reference()["bending_lowjm_mirror"]
    row = int(np.flatnonzero(ref.design == 21)[0])
    cell, path = ref.cell(row), ref.path(row)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CalibrationWarning)
        resp = load_model().responses([cell], requested_pressure(
            "bending_lowjm_mirror", 21, path), fast=True)[0]
    cal = resp.meta["calibration"]
    a = cal["anchors"]
    own, anchor = a["path_critical_pressure"], a["critical_pressure"]
    assert "critical" not in a["used"]
    assert abs(math.log(anchor / own)) > math.log(MAX_FACTOR)
    assert resp.characteristic.critical == pytest.approx(own)
    lo, hi = cal["critical_pressure_range"]
    assert lo < own < anchor < hi
    fe = fe_response(path, cell, "bending").characteristic.critical
    assert abs(own / fe - 1.0) < 0.15 and anchor / fe > 4.0
    line = model_line({"model": "calibrated-fast", "calibration": cal})
    assert f"{own / 1e3:.3g} kPa" in line and f"{anchor / 1e3:.3g} kPa" in line
    assert "disagree" in line
    agree = {**a, "used": ["critical", "hardening"]}
    assert "disagree" not in model_line({"model": "calibrated-fast",
                                        "calibration": {**cal, "anchors": agree}})
    # a device with such a cell says which module (multimorph simulate's model words)
    from multimorph.cli._simulate import model_words

    words = model_words({"model": "calibrated-fast", "modules": {
        "fingers": {"calibration": cal}, "twister": {"calibration": {"anchors": agree}}}})
    assert "Pc uncertain for fingers " in words and "twister" not in words


@pytest.mark.parametrize("part", ["signal", "pressure", "path", "anchors"])
def test_refitting_a_part_for_an_unknown_kind_is_refused_and_writes_nothing(part, capsys):
    """`python -m multimorph.calibrated.fit signal|pressure|path|anchors --kinds K`: a kind the
    shipped model does not have is an error naming it (exit 2), and the model files are
    left as they were."""
    from multimorph.calibrated._fit import MODEL_FILE, MODEL_MANIFEST
    from multimorph.calibrated.fit import main

    before = (MODEL_FILE.stat().st_mtime_ns, MODEL_MANIFEST.read_bytes())
    assert main([part, "--kinds", "wobbling"]) == 2
    assert f"fit {part}: the shipped model has no 'wobbling' kind" in capsys.readouterr().err
    assert (MODEL_FILE.stat().st_mtime_ns, MODEL_MANIFEST.read_bytes()) == before


def test_the_shipped_model_names_every_set_its_kinds_train_on():
    """Every set a kind's fit reads (`_fit.KIND_SETS`) is in the shipped manifest's `sets`
    of that kind, both variants: a set added to the calibration without a refit fails here,
    and the held-out checks (`validate.unseen_designs`, whose twin rule reads `sets`) see
    the sets the model has seen (stop 47: `bending3_mirror`, fitted part by part, was
    missing from them)."""
    from multimorph.calibrated._fit import KIND_SETS, MODEL_MANIFEST

    manifest = json.loads(MODEL_MANIFEST.read_text())
    for key in ("kinds", "fast_kinds"):
        for kind, info in manifest[key].items():
            assert set(KIND_SETS[kind]) <= set(info["sets"]), (key, kind)


def test_the_bending_kind_takes_the_derived_input_its_manifest_names() -> None:
    """Since stop 51 the bending GPs take μb·hb / (μ·ht) after the groups, since stop 54
    also the top wall's share of the two membranes' stiffness and the side walls' over
    the top wall's (``_box.DERIVED_INPUTS``): the shipped manifest names them for both
    variants, the loaded box appends them, and every GP of the kind was fitted on inputs
    of that width — a model file and its loader that disagreed would predict from shifted
    inputs. Two cells with the same groups but for a bottom swapped against its thickness
    (the same product) get the same first two derived inputs and different groups."""
    from multimorph.calibrated._box import DERIVED_INPUTS, cell_groups

    model = load_model()
    for variant in (model.kinds, model.fast_kinds):
        k = variant["bending"]
        assert k.box.derived == DERIVED_INPUTS["bending"] == ("bottom/top", "top share",
                                                              "side/top")
        width = len(k.box.names) + len(k.box.derived) + len(k.fmean) + (k.end_input is not None)
        gps = [k.gp, k.pressure, k.signal, *k.anchors.values()]
        assert all(g is not None and g.x.shape[1] == width for g in gps)
    assert model.kinds["stretching"].box.derived == ()
    from multimorph.materials import Material

    wall = Material("gent", {"mu": 1e5, "jm": 30.0})
    a = CellGeometry(20e-3, 10e-3, 8e-3, 1e-3, 2e-3, 2e-3, 2e-3, material=wall,
                     bottom_material=wall.scaled(8.0))
    b = replace(a, bottom_wall=4e-3, bottom_material=wall.scaled(4.0))
    box = model.kinds["bending"].box
    xa, xb = (box.inputs(box.values_of(cell_groups(c))[None, :])[0] for c in (a, b))
    n = len(box.names)
    assert xa[n:n + 2] == pytest.approx(xb[n:n + 2]) and not np.allclose(xa[:n], xb[:n])


def _tilted_sample(n: int = 12):
    """The shipped model and the first ``n`` valid cells of the `twisting` set."""
    from multimorph.calibrated._fit import load_reference

    ref = load_reference()["twisting"]
    return load_model(), [ref.cell(int(r)) for r in np.flatnonzero(ref.ok)[:n]]


def test_the_tilted_pc_anchor_is_the_mean_of_its_likelihood_and_cross_validated_gps() -> None:
    """Since stop 55 the twisting kind's Pc anchor is two GPs (``_fit.ANCHOR_CV``): the
    shipped model has the cross-validated one for Pc alone, in both variants, and the
    predicted log Pc of tilted cells is the mean of the two GPs' (each predicted by a copy
    of the model that has only it), its std their equal mixture's: at least the smaller
    of the two and at least half their difference."""
    from multimorph.calibrated._fit import ANCHOR_CV

    assert ANCHOR_CV == {"twisting": ("pc",)}
    model, cells = _tilted_sample()
    for fast, variant in ((False, "kinds"), (True, "fast_kinds")):
        k = getattr(model, variant)["twisting"]
        assert set(k.anchors) == {"pc", "pc_cv", "ph", "ph_ratio"}
        assert all("_cv" not in name for name in getattr(model, variant)["bending"].anchors)
        both = model.grid(cells, fast=fast)
        one = []
        for name in ("pc", "pc_cv"):
            m = copy.copy(model)
            setattr(m, variant, {**getattr(model, variant), "twisting": replace(
                k, anchors={"pc": k.anchors[name], "ph": k.anchors["ph"]})})
            one.append(m.grid(cells, fast=fast))
        a, b = (g.anchors[:, 0] for g in one)
        sa, sb = (g.anchor_std[:, 0] for g in one)
        assert np.abs(a - b).max() > 1e-3   # two different GPs
        np.testing.assert_allclose(both.anchors[:, 0], 0.5 * (a + b), atol=1e-12)
        s = both.anchor_std[:, 0]
        assert np.all(s >= np.minimum(sa, sb) - 1e-12) and np.all(s >= 0.5 * np.abs(a - b))


def test_the_tilted_ph_anchor_is_the_mean_of_its_own_gp_and_pc_with_the_ratio() -> None:
    """Since stop 59 the twisting kind's Ph anchor has a second member
    (``_fit.ANCHOR_RATIO``): the Pc anchor's log Pc plus a GP of log(Ph / Pc). In both
    variants the grid's log Ph is the mean of the direct GP's and that member's (each read
    on a copy of the model that has only it), its variance their equal mixture's (the
    ratio member's own the sum of Pc's and the ratio's); the ratio GP, fitted on FE labels
    with Ph ≥ Pc, puts Ph at or above Pc; bending and stretching have no such member."""
    from multimorph.calibrated._fit import ANCHOR_RATIO

    assert ANCHOR_RATIO == {"twisting": ("ph",)}
    model, cells = _tilted_sample()
    for fast, variant in ((False, "kinds"), (True, "fast_kinds")):
        kinds = getattr(model, variant)
        k = kinds["twisting"]
        assert all("ph_ratio" not in kinds[o].anchors for o in ("bending", "stretching"))
        full = model.grid(cells, fast=fast)

        pcs = {n: k.anchors[n] for n in ("pc", "pc_cv")}
        direct, ratio = (_with_anchors(model, variant, {**pcs, "ph": k.anchors[ph]}, cells)
                         for ph in ("ph", "ph_ratio"))     # the ratio's "Ph" is log(Ph / Pc)
        pc, pc_sd = direct.anchors[:, 0], direct.anchor_std[:, 0]
        np.testing.assert_allclose(full.anchors[:, 0], pc, atol=1e-12)
        m1, s1 = direct.anchors[:, 1], direct.anchor_std[:, 1]
        r, sr = ratio.anchors[:, 1], ratio.anchor_std[:, 1]
        m2, s2 = pc + r, np.sqrt(pc_sd ** 2 + sr ** 2)
        np.testing.assert_allclose(full.anchors[:, 1], 0.5 * (m1 + m2), atol=1e-12)
        np.testing.assert_allclose(full.anchor_std[:, 1] ** 2,
                                   0.5 * (s1 ** 2 + s2 ** 2) + 0.25 * (m1 - m2) ** 2,
                                   rtol=1e-9)
        assert np.abs(m1 - m2).max() > 1e-3        # two different members
        assert np.all(r > -0.02)                   # Ph at or above Pc, within its scatter


def _with_anchors(model, variant: str, anchors: dict, cells: list):
    """The grid of ``cells`` on a copy of ``model`` whose twisting kind (``variant``:
    "kinds" or "fast_kinds") has only ``anchors``."""
    kinds = getattr(model, variant)
    m = copy.copy(model)
    setattr(m, variant, {**kinds, "twisting": replace(kinds["twisting"], anchors=anchors)})
    return m.grid(cells, fast=variant == "fast_kinds")


def test_the_tilted_strip_shear_is_the_mean_of_three_gps() -> None:
    """Since stop 55 the twisting kind's signal (the strip shear over t) is the equal mean
    of its path GP's, its signal GP's and exp of its log signal GP's
    (``_fit.LOG_SIGNAL_KINDS``), in both variants: the grid's signal is that mean of what
    copies of the model with one GP each predict, the log GP's term is a shear in the
    sense of the tilt (positive), and the kinds whose signal changes sign (a cell bends
    either way) have no log GP: a fit of one refuses them."""
    from types import SimpleNamespace

    from multimorph.calibrated._fit import (
        LOG_SIGNAL_KINDS,
        LOG_SIGNAL_WEIGHT,
        fit_log_signal,
    )

    assert LOG_SIGNAL_KINDS == ("twisting",) and LOG_SIGNAL_WEIGHT == pytest.approx(1 / 3)
    with pytest.raises(ValueError, match="changes sign"):
        fit_log_signal(SimpleNamespace(kind="bending"), None, None, None)
    model, cells = _tilted_sample()
    for fast, variant in ((False, "kinds"), (True, "fast_kinds")):
        kinds = getattr(model, variant)
        k = kinds["twisting"]
        assert k.log_signal is not None and k.signal is not None
        assert k.signal_weight == pytest.approx(1 / 3) == k.log_signal_weight
        assert all(kinds[other].log_signal is None for other in ("bending", "stretching"))
        both = model.grid(cells, fast=fast).values[:, :, 1]
        one = []
        for keep in ("path", "signal", "log_signal"):
            m = copy.copy(model)
            setattr(m, variant, {**kinds, "twisting": replace(
                k, signal=k.signal if keep == "signal" else None, signal_weight=1.0,
                log_signal=k.log_signal if keep == "log_signal" else None,
                log_signal_weight=1.0)})
            one.append(m.grid(cells, fast=fast).values[:, :, 1])
        np.testing.assert_allclose(both, sum(one) / 3.0, rtol=1e-10, atol=1e-12)
        assert np.all(one[2] > 0.0)
