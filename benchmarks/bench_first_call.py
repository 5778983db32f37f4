"""The first call of the JAX-traced models in a fresh process: cold, warm, and warm without
the exported kernels.

Run: python benchmarks/bench_first_call.py [--only cell-ritz cell-calibrated design]

Each command runs in a new process with a temporary cache folder (``MULTIMORPH_JAX_CACHE``):

* cold: an empty folder (tracing and compiling everything, as on a fresh machine);
* warm: the same folder again (JAX's compiled kernels and multimorph's exported ones,
  ``multimorph.rom._exported``, read back);
* warm, no export: ``MULTIMORPH_JAX_EXPORT=0`` (the compilation cache alone, as before
  stop 60; its own warm-up run first, which is not timed).

Commands: ``multimorph cell examples/cell.toml --model ritz`` (the Ritz path tracer),
``--model calibrated`` (the exact calibrated variant, which traces the Ritz model for its
features), and ``multimorph design examples/target_jar_lifter.toml`` (its search on
``calibrated-fast``, its checks on ``calibrated``: bending and stretching tracers). Prints
a table; the figures go in benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMMANDS = {
    "cell-ritz": ["cell", "examples/cell.toml", "--model", "ritz"],
    "cell-calibrated": ["cell", "examples/cell.toml", "--model", "calibrated"],
    "design": ["design", "examples/target_jar_lifter.toml"],
}


def timed(args: list[str], cache: Path, out: Path, export: bool = True) -> float:
    env = {**os.environ, "MULTIMORPH_JAX_CACHE": str(cache)}
    if not export:
        env["MULTIMORPH_JAX_EXPORT"] = "0"
    t = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "multimorph.cli", *args, "--out", str(out)],
                       cwd=ROOT, env=env, capture_output=True, text=True)
    dt = time.perf_counter() - t
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(args)} failed:\n{r.stderr[-2000:]}")
    return dt


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="+", choices=sorted(COMMANDS), default=list(COMMANDS))
    args = ap.parse_args(argv)
    print(f"{'command':<16} {'cold':>8} {'warm':>8} {'warm, no export':>16}", flush=True)
    for name in args.only:
        with tempfile.TemporaryDirectory() as tmp:
            cache, out = Path(tmp) / "cache", Path(tmp) / "out"
            cold = timed(COMMANDS[name], cache, out)
            warm = timed(COMMANDS[name], cache, out)
            timed(COMMANDS[name], cache, out, export=False)   # its compile cache warmed
            plain = timed(COMMANDS[name], cache, out, export=False)
        print(f"{name:<16} {cold:>7.1f}s {warm:>7.1f}s {plain:>15.1f}s", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
