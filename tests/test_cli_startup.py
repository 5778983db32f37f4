"""The default `multimorph cell` runs no JAX, so a first call does not import it (about a
second of every CLI start before stop 61, when `multimorph.materials` imported it with the
Material class). JAX still comes with what uses it (fits, load cases, the Ritz model)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

SCRIPT = """
import sys
from multimorph.cli import main
sys.argv = ["multimorph", "cell", {spec!r}, "--out", {out!r}]
try:
    main()
except SystemExit as exc:
    assert exc.code in (0, None), exc.code
assert "jax" not in sys.modules, "the default cell command imported JAX"
from multimorph.materials import drucker_stability, fit_material   # lazily, on first use
assert "jax" in sys.modules
import jax
assert jax.config.jax_enable_x64       # multimorph's float64, set before JAX was imported
print("ok")
"""


def test_the_default_cell_command_does_not_import_jax(tmp_path: Path) -> None:
    code = SCRIPT.format(spec=str(EXAMPLES / "cell.toml"), out=str(tmp_path / "o"))
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.strip().endswith("ok")
    assert (tmp_path / "o" / "response.json").is_file()
