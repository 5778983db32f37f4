"""Every script in examples/ runs and gives the physics it claims."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def test_fit_treloar(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = _load("fit_treloar").main(tmp_path)
    printed = capsys.readouterr().out
    assert "Ogden 1972 (published)" in printed
    for case in ("uniaxial", "equibiaxial", "pure_shear"):
        assert out["Ogden 1972 (published)"][case] < 0.05
        assert out["Ogden-3, our joint fit"][case] < 0.05
    assert out["gent"]["mu"] == pytest.approx(0.300e6, rel=0.02)
    assert out["gent"]["jm"] == pytest.approx(94.0, rel=0.05)
    assert (tmp_path / "treloar_ogden.png").is_file()
