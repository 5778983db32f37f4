"""``fem --compare`` asks the cell model for what a device asks it for (``fe.run_job``): a
twisting module's or a tilted strip's tilted cell where the model answers tilted cells (the
calibrated and FE models), the straight cell where it does not (the Ritz model). Before,
``fem --compare`` of the gripper's twister read the calibrated model's straight cell with
the Ritz shear rule: Pc 22.9 kPa on its curvature, where ``simulate`` (the tilted cell's
own calibrated path) has 32.4 kPa and FE 32.1 kPa."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

pytest.importorskip("felupe")

from multimorph.device import answered_cell, device_from_spec, simulate_device
from multimorph.fe import FESettings, compare_twisting
from multimorph.fe.analyses import _job
from multimorph.geometry import TiltedCell
from multimorph.io import load_toml
from multimorph.models import cell_model

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _gripper():
    return device_from_spec(load_toml(EXAMPLES / "gripper.toml"))


def _recording(tilted: bool):
    asked: list = []

    def model(cell, p_max):  # type: ignore[no-untyped-def]
        asked.append(cell)
        return SimpleNamespace(asked=cell)

    if tilted:
        model.tilted = True  # type: ignore[attr-defined]
    return model, asked


def test_a_twisting_module_is_compared_with_the_cell_the_model_answers(monkeypatch) -> None:
    twister = _gripper().module("twister")
    fe = SimpleNamespace(pressure=np.array([0.0, 2.0e4]))
    monkeypatch.setattr(_job, "simulate_twisting_module", lambda *a, **k: fe)
    monkeypatch.setattr(_job, "compare_twisting",
                        lambda result, rom, rom_p_max: {"rom": rom, "p": rom_p_max})
    job = _job.FEJob("twisting", FESettings(), 2.0e4, module=twister, compare=True)
    for tilted in (True, False):
        model, asked = _recording(tilted)
        out = _job.run_job(job, cell_model=model)
        assert len(asked) == 1 and out.comparison["p"] == 4.0e4
        if tilted:
            assert asked[0] == TiltedCell(twister.cell, twister.tilt)
        else:
            assert asked[0] is twister.cell


def test_a_tilted_strip_is_compared_with_the_cell_the_model_answers(monkeypatch) -> None:
    cell = _gripper().module("twister").cell
    monkeypatch.setattr(_job, "simulate_cell", lambda *a, **k: "fe")
    monkeypatch.setattr(_job, "compare_cell_run", lambda rom, fe: rom)
    for tilt in (0.0, 0.5):
        job = _job.FEJob.for_cell(cell, FESettings(p_max=1.0e4), n_cells=2, tilt=tilt,
                                  compare=True)
        for tilted in (True, False):
            model, asked = _recording(tilted)
            _job.run_job(job, cell_model=model)
            want = TiltedCell(cell, tilt) if (tilt and tilted) else cell
            assert asked == [want]


def test_the_twisting_comparison_reads_the_twist_simulate_predicts() -> None:
    """With the calibrated model, the comparison's model side is the twister of
    ``simulate``: the same Pc and Ph (read on the twist rate) and the same twist angle at
    every common pressure; the straight cell's answer (the old comparison) is another."""
    device = _gripper()
    twister = device.module("twister")
    model = cell_model("calibrated-fast")
    result = simulate_device(device, 6.0e4, cell_model=model)
    sim = result.strains["twister"]
    # and simulate says what that twist is worth (whole-module FE: a third to a sixth)
    assert [n for n in result.to_dict()["notes"] if "strip rule" in n] == [
        "twister: its twist is the strip rule's (τ = γ / R on its cells' strip shear); the "
        "whole module on its shaft in 3D FE twists a third to a sixth of it at the same "
        "pressures (docs/design.md)"]
    # an FE side that only sets the common pressures (0 … 40 kPa)
    P = np.linspace(0.0, 4.0e4, 41)
    load = SimpleNamespace(pressure=P, twist_rate=np.zeros_like(P),
                           axial_stretch=np.ones_like(P))
    fe = SimpleNamespace(module=twister, pressure=P, response=SimpleNamespace(loading=load),
                         activation=lambda: (None, None))
    rom = model(answered_cell(model, twister.cell, twister.tilt), 6.0e4)
    out = compare_twisting(fe, twister, rom=rom)
    assert out["signal_rom"] == "twist_rate"
    assert out["pc_rom"] == pytest.approx(sim.response.characteristic.critical, rel=1e-12)
    assert out["ph_rom"] == pytest.approx(sim.response.characteristic.hardening, rel=1e-12)
    want = np.degrees(np.interp(out["pressure_pa"], sim.pressure, np.abs(sim.twist))
                      * twister.length)
    np.testing.assert_allclose(np.abs(out["twist_deg_rom"]), want, rtol=1e-9)
    straight = compare_twisting(fe, twister, rom=model(twister.cell, 6.0e4))
    assert straight["signal_rom"] == "curvature"
    assert abs(straight["pc_rom"] / out["pc_rom"] - 1.0) > 0.1


def test_the_comparison_figure_names_the_model_it_ran() -> None:
    """``comparison.png``'s title says which cell model FE was compared with (it read
    "reduced model vs 3D FE" over a calibrated model's curve)."""
    from multimorph.fe.report._files import _compared_model

    assert _compared_model(SimpleNamespace(meta={"model": "calibrated"})) == "calibrated"
    assert _compared_model({"module": "tw", "model": "calibrated-fast"}) == "calibrated-fast"
    assert _compared_model({"a": {"model": "calibrated"}, "b": {"model": "ritz"}}) == \
        "calibrated / ritz"
    assert _compared_model({}) == "reduced"
