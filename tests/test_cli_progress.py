"""Progress of long commands as plain lines on a non-terminal stderr; the compile notice."""

from __future__ import annotations

import io
import logging
import re

import pytest
import typer
from typer.testing import CliRunner

from multimorph.cli import _simulate
from multimorph.cli._progress import LineProgress
from test_device_simulate import SPEC, step_model


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_lines_at_most_one_a_second_first_and_last_always() -> None:
    clock, out = Clock(), io.StringIO()
    lines = LineProgress("design", "candidates", stream=out, clock=clock)
    for t, done in [(0.0, 0), (0.3, 100), (0.6, 200), (1.1, 300), (1.5, 400), (1.9, 500)]:
        clock.now = 100.0 + t
        lines.update(done, 5000, phase="global search")
    clock.now = 102.5
    lines.close()
    assert out.getvalue().splitlines() == [
        "[design] global search: 0/5000 candidates, 0.0 s",
        "[design] global search: 300/5000 candidates, 1.1 s",  # ≥ 1 s after the first
        "[design] global search: 500/5000 candidates, 2.5 s",  # the last, at close
    ]


def test_close_does_not_repeat_a_shown_line_and_keeps_total_and_phase() -> None:
    clock, out = Clock(), io.StringIO()
    lines = LineProgress("fem", stream=out, clock=clock)
    lines.update(1, 4, phase="inflating")
    clock.now += 2.0
    lines.update(None, phase="writing", detail="results")  # count as before
    lines.close()
    assert out.getvalue().splitlines() == ["[fem] inflating: 1/4, 0.0 s",
                                           "[fem] writing: results, 2.0 s"]


@pytest.fixture()
def app(monkeypatch: pytest.MonkeyPatch) -> typer.Typer:
    from multimorph.device import _simulate as sim

    monkeypatch.setattr(sim, "default_cell_model", step_model)
    a = typer.Typer(pretty_exceptions_enable=False)
    _simulate.register(a)
    a.command("noop")(lambda: None)
    return a


def test_simulate_prints_progress_lines_when_piped(app: typer.Typer, tmp_path) -> None:
    spec = tmp_path / "dev.toml"
    spec.write_text(SPEC)
    r = CliRunner().invoke(app, ["simulate", str(spec), "--out", str(tmp_path / "o"),
                                 "--frames", "3"])
    assert r.exit_code == 0, r.output
    lines = [line for line in r.stderr.splitlines() if line.startswith("[simulate]")]
    pattern = re.compile(r"\[simulate\] [a-z ]+: .+, \d+\.\d s$")
    assert lines and all(pattern.match(line) for line in lines), r.stderr
    assert lines[0].startswith("[simulate] tracing modules: 0/2 modules")
    assert lines[-1].startswith("[simulate] animation: 3/3 frames")  # the last, always
    assert len(lines) <= 2 + float(lines[-1].rsplit(", ", 1)[1][:-2]) + 1  # ≤ ~1 a second
    assert "\x1b" not in r.stderr  # no terminal control codes in a log


def test_simulate_json_is_quiet(app: typer.Typer, tmp_path) -> None:
    spec = tmp_path / "dev.toml"
    spec.write_text(SPEC)
    r = CliRunner().invoke(app, ["simulate", str(spec), "--out", str(tmp_path / "o"),
                                 "--frames", "0", "--json"])
    assert r.exit_code == 0 and "[simulate]" not in r.stderr


def test_compile_notice_once_and_only_on_a_cold_cache(tmp_path, monkeypatch,
                                                      caplog: pytest.LogCaptureFixture) -> None:
    from multimorph.rom import _notice

    calls = []
    caplog.set_level(logging.INFO, logger="multimorph.compile")

    def kernel(x: int) -> int:
        calls.append(x)
        return 2 * x

    def process() -> None:  # a new process: nothing told yet
        monkeypatch.setattr(_notice, "_told", [])

    process()
    fn = _notice.announced(kernel, "k1", cache=lambda: str(tmp_path))
    assert fn(1) == 2 and fn(2) == 4 and calls == [1, 2]
    assert [r.getMessage() for r in caplog.records] == [_notice.NOTICE]
    other = _notice.announced(kernel, "k2", cache=lambda: str(tmp_path))
    other(3)
    assert len(caplog.records) == 1  # once per process
    process()
    caplog.clear()
    _notice.announced(kernel, "k1", cache=lambda: str(tmp_path))(4)  # warm: k1 compiled
    assert caplog.records == []
    _notice.announced(kernel, "k3", cache=lambda: None)(5)  # no cache: every run
    assert [r.getMessage() for r in caplog.records] == [_notice.NOTICE_NO_CACHE]


def test_commands_print_the_compile_notice_on_stderr(tmp_path, monkeypatch, capsys) -> None:
    from multimorph.cli._common import handle_errors
    from multimorph.rom import _notice

    monkeypatch.setattr(_notice, "_told", [])
    with handle_errors():
        _notice.announced(lambda: None, "k", cache=lambda: str(tmp_path))()
    assert capsys.readouterr().err.strip() == _notice.NOTICE
