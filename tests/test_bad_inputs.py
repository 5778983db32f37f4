"""The bad-input corpus (``tests/bad_inputs/cases.py``): every case refused cleanly, at once.

Each case runs the real command line in-process (``multimorph.cli._app.run``) in its own
folder, with the models replaced by stubs that fail the test if called: bad input must be
refused by the validation at the edges, before any computation. A clean refusal is exit
status 2 (or the case's documented one), exactly one line on stderr naming the field, option
or file and line, no traceback, and nothing written.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from bad_inputs.cases import Case, all_cases, prepare, snapshot

CASES = all_cases()


class ModelRan(AssertionError):
    """A model was called although the input is bad."""


def _model_ran(*args: object, **kwargs: object) -> None:
    raise ModelRan("the model ran on bad input: validation must refuse it first")


@pytest.fixture()
def no_model(monkeypatch: pytest.MonkeyPatch) -> None:
    import multimorph.design
    import multimorph.device._simulate
    import multimorph.materials
    import multimorph.rom
    import multimorph.sweep._run

    monkeypatch.setattr(multimorph.rom, "solve_cell", _model_ran)
    monkeypatch.setattr(multimorph.device._simulate, "default_cell_model", _model_ran)
    monkeypatch.setattr(multimorph.design, "design", _model_ran)
    monkeypatch.setattr(multimorph.materials, "fit_material", _model_ran)
    monkeypatch.setattr(multimorph.sweep._run, "_run_local", _model_ran)
    monkeypatch.setattr(multimorph.sweep._run, "_run_distributed", _model_ran)


def test_corpus_size_and_spread() -> None:
    # issue 20: at least 150 cases over the five commands, in every class
    assert len(CASES) >= 150
    commands = {c.command for c in CASES}
    assert commands == {"material-fit", "cell", "simulate", "design", "sweep"}
    from bad_inputs.cases import CLASSES

    assert {c.kind for c in CASES} == set(CLASSES)


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input_is_refused_cleanly(case: Case, tmp_path: Path, no_model: None,
                                      monkeypatch: pytest.MonkeyPatch,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    from multimorph.cli._app import run
    from multimorph.io import claim_output

    if case.setup == "out-readonly" and os.geteuid() == 0:
        pytest.skip("root writes into read-only folders")
    folder = tmp_path / "run"
    folder.mkdir()
    argv, out = prepare(case, folder)
    monkeypatch.chdir(folder)  # default output folders would land here
    before = snapshot(folder)
    if case.setup == "locked":
        with claim_output(out):
            code = run(argv)
    else:
        code = run(argv)
    captured = capsys.readouterr()
    lines = [ln for ln in captured.err.splitlines() if ln.strip()]
    assert "Traceback" not in captured.err
    assert code == case.code, captured.err
    assert len(lines) == 1, captured.err
    assert case.expect in lines[0], lines[0]
    assert snapshot(folder) == before, "a refused run left files behind"
    for p in folder.rglob("*"):  # let tmp_path be cleaned up
        if p.is_dir():
            p.chmod(0o755)
