"""The README's table of what each command writes matches the commands' FILES constants,
and its pictures exist, stay small and say which model made them."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from multimorph.cli import _cell, _demo, _design, _fem, _material, _plot, _simulate, _sweep

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")

#: Every file a command can write, from its own constants.
WRITES = {
    "material fit": _material.FIT_FILES,
    "cell": _cell.FILES,
    "simulate": (*_simulate.FILES, "morph.gif"),
    "design": (*_design.FILES, *_design.SOMETIMES),
    "fem": (*_fem.FILES, *_fem.SOMETIMES),
    "sweep": _sweep.FILES,
    "plot map": _plot.MAP_FILES,
    "demo": (*_demo.FILES, *_demo.GRIPPER_FILES),
}


def _table() -> dict[str, str]:
    start = README.index("| command | files it writes |")
    rows = {}
    for line in README[start:].splitlines()[2:]:
        if not line.startswith("|"):
            break
        command, files = line.strip("|").split("|", 1)
        rows[command.strip().strip("`")] = files
    return rows


def test_the_table_has_a_row_per_command() -> None:
    assert sorted(_table()) == sorted(WRITES)


@pytest.mark.parametrize("command", sorted(WRITES))
def test_the_table_names_every_file_the_command_writes(command: str) -> None:
    named = set(re.findall(r"`([^`]+)`", _table()[command]))
    assert set(WRITES[command]) <= named


def test_the_pictures_exist_stay_small_and_name_their_model() -> None:
    pictures = re.findall(r"!\[[^\]]*\]\((docs/img/[^)]+)\)\n\n(.+?)\n\n", README, re.S)
    assert len(pictures) == 5
    for path, caption in pictures:
        caption = " ".join(caption.split())
        assert (ROOT / path).is_file(), path
        assert (ROOT / path).stat().st_size < 300_000, path
        assert re.search(r"calibrated model|ritz model|\bFE\b|no cell model", caption), caption
