"""Throughput of the default cell model (calibrated): full curves per second, one-curve
latency, and the first ``multimorph cell`` in a fresh process.

Run: python benchmarks/bench_calibrated.py [--n 10000] [--workers 2]
     [--model calibrated|calibrated-fast] [--kinds bending stretching twisting]

Designs: per cell kind, a scrambled Sobol sample over its calibrated box (the FE data set's:
bending cells, mirror-symmetric stretching cells, tilted cells), the valid ones (chambers ≥
0.1 d), each traced to 150 kPa. A "full curve" is what every consumer gets: the Response
(the equilibrium path on ~96 points, loading and unloading curves, Pc, Ph, failure,
stability, the uncertainty band of Pc; a tilted cell's twist rate). Prints a table; the
figures go in benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from functools import lru_cache
from multiprocessing import get_context
from typing import Any


@lru_cache(maxsize=4)
def designs(n: int, kind: str = "bending", seed: int = 5) -> list:
    from multimorph.calibrated import reference_spec

    spec = dataclasses.replace(reference_spec(kind), samples=int(n * 1.2) + 8, seed=seed)
    cells = [c for c in spec.design_table().cells if c is not None]
    return cells[:n]


def _chunk(args: tuple[int, str, int, int, bool]) -> tuple[int, float]:
    n, kind, i0, i1, fast = args
    from multimorph.calibrated import CalibrationWarning, load_model

    cells = designs(n, kind)[i0:i1]
    model = load_model()
    t = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CalibrationWarning)
        out = model.responses(cells, 150e3, fast=fast)
    return sum(not isinstance(r, Exception) for r in out), time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10_000)
    ap.add_argument("--chunk", type=int, default=1000)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--model", default="calibrated", choices=("calibrated", "calibrated-fast"))
    ap.add_argument("--kinds", nargs="+", default=["bending", "stretching", "twisting"],
                    choices=("bending", "stretching", "twisting"))
    args = ap.parse_args()
    fast = args.model == "calibrated-fast"
    rows: list[tuple[str, str]] = []

    def row(a: str, b: str) -> None:
        rows.append((a, b))
        print(f"{a:<52}  {b}", flush=True)

    row("machine", f"{os.cpu_count()} cpus; model {args.model}")
    # 1. the first `multimorph cell` in a fresh process with an empty JAX cache
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "MULTIMORPH_JAX_CACHE": os.path.join(tmp, "jax")}
        t = time.perf_counter()
        r = subprocess.run([sys.executable, "-c", "from multimorph.cli import main; main()",
                            "cell", "examples/cell.toml", "--out", os.path.join(tmp, "o"),
                            "--json", "--model", args.model],
                           capture_output=True, text=True, env=env)
        dt = time.perf_counter() - t
        row("first `multimorph cell examples/cell.toml` (fresh)",
            f"{dt:.2f} s (exit {r.returncode})")
    from multimorph.calibrated import load_model

    t = time.perf_counter()
    model = load_model()
    row("load the model", f"{(time.perf_counter() - t) * 1e3:.0f} ms")
    for kind in args.kinds:
        _kind_rows(kind, args, model, fast, row)


def _kind_rows(kind: str, args: argparse.Namespace, model: Any, fast: bool,
               row: Callable[[str, str], None]) -> None:
    """One warm curve, a batch in one process and all designs on the workers, for one
    cell kind."""
    from multimorph.calibrated import CalibrationWarning

    cells = designs(args.n, kind)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CalibrationWarning)
        model.responses(cells[:8], 150e3, fast=fast)
        t = time.perf_counter()
        reps = 50
        for c in cells[:reps]:
            model.responses([c], 150e3, fast=fast)
        row(f"{kind}: one curve, warm (mean of 50)",
            f"{(time.perf_counter() - t) / reps * 1e3:.2f} ms")
        t = time.perf_counter()
        out = model.responses(cells[:args.chunk], 150e3, fast=fast)
        dt = time.perf_counter() - t
    inside = sum(not isinstance(r, Exception) and r.meta.get("model") == args.model
                 for r in out)
    row(f"{kind}: batch of {args.chunk}, 1 process", f"{args.chunk / dt:.0f} curves/s "
        f"({inside} inside the calibrated box)")
    n = len(cells)
    tasks = [(args.n, kind, i0, min(i0 + args.chunk, n), fast)
             for i0 in range(0, n, args.chunk)]
    with ProcessPoolExecutor(args.workers, mp_context=get_context("spawn")) as pool:
        list(pool.map(_chunk, [(args.n, kind, 0, 8, fast)] * args.workers))
        t = time.perf_counter()
        res = list(pool.map(_chunk, tasks))
        dt = time.perf_counter() - t
    ok = sum(r[0] for r in res)
    row(f"{kind}: {n} designs, {args.workers} processes", f"{dt:.2f} s")
    row(f"{kind}: throughput (full curves)", f"{n / dt:.0f} curves/s ({ok} responses)")

if __name__ == "__main__":
    main()
