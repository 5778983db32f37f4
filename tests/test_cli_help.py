"""``multimorph --help`` of every command shows the spec tables it names; ``--version``."""

from __future__ import annotations

import re

import pytest
import typer
from typer.testing import CliRunner

from multimorph.cli import app
from multimorph.cli._app import _register, run

#: A spec table named in a help text: ``[cell]``, ``[[module]]`` (escaped or not).
TABLE = re.compile(r"\[\[?[a-z_]+\]\]?")


def _commands() -> list[tuple[list[str], object]]:
    """Every command and command group of the CLI, as (command path, click command)."""
    _register()
    root = typer.main.get_command(app)
    found: list[tuple[list[str], object]] = []

    def walk(path: list[str], command: object) -> None:
        found.append((path, command))
        for name, sub in getattr(command, "commands", {}).items():
            walk([*path, name], sub)

    walk([], root)
    return found


def _tables(command: object) -> set[str]:
    texts = [getattr(command, "help", None) or ""]
    texts += [getattr(p, "help", None) or "" for p in getattr(command, "params", [])]
    # the help texts are stored rich-escaped (``\[cell]``): the table is what is left
    return {m for text in texts for m in TABLE.findall(text.replace("\\", ""))}


def test_help_texts_name_the_spec_tables() -> None:
    # the check below is not vacuous: these tables are named in some command's help
    named = set().union(*(_tables(c) for _, c in _commands()))
    assert {"[cell]", "[device]", "[[module]]", "[[stage]]"} <= named


COMMANDS = _commands()


@pytest.mark.parametrize(("path", "command"), COMMANDS,
                         ids=[" ".join(path) or "multimorph" for path, _ in COMMANDS])
def test_help_shows_square_brackets(path: list[str], command: object) -> None:
    r = CliRunner().invoke(app, [*path, "--help"], env={"COLUMNS": "200"})
    assert r.exit_code == 0, r.output
    for table in _tables(command):
        assert table in r.stdout, f"{' '.join(path)} --help lost {table}"
    assert "a  table" not in r.stdout  # what rich made of "a [cell] table"


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    from multimorph import __version__
    from multimorph._provenance import code_version

    assert run(["--version"]) == 0
    line = capsys.readouterr().out.strip()
    assert line.startswith(f"multimorph {__version__}")
    assert (code_version() in line) and len(line.splitlines()) == 1
    r = CliRunner().invoke(app, ["--version"])
    assert r.exit_code == 0 and r.stdout.strip() == line
