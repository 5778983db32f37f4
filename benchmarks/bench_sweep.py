"""Benchmark: a 10,000-design ROM sweep through Dask vs the raw batched ROM call.

Run from the repository root (one command; prints a table)::

    python benchmarks/bench_sweep.py                      # 10,000 random designs
    python benchmarks/bench_sweep.py --designs 2000 --modes raw,threads

Rows:

- ``raw``: the backend's batched call on all valid designs, batch by batch in one process,
  after one warm-up batch (no Dask, no store) — the floor;
- ``threads``: ``run_sweep`` on Dask's threaded scheduler (``--workers`` threads), results
  written to a fresh Zarr folder (same process: the JIT cache is warm after ``raw``);
- ``local``: ``run_sweep`` on a ``dask.distributed`` LocalCluster of ``--workers`` processes,
  including cluster start-up and the JIT compilation in each worker process;
- ``resume``: rerunning the finished ``threads`` sweep (nothing to do: reading the store).

"overhead" is the time relative to ``raw`` (1.00 = no overhead). Designs are random
(``combine = "random"``, seed 1) over ht/d, ws/d, df/d and μ around the examples' base cell.
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import sys
import tempfile
import time
import tomllib
from pathlib import Path

SPEC = """
[cell]
length = "20 mm"
width = "10 mm"
height = "8 mm"
top_wall = "1 mm"
bottom_wall = "2 mm"
side_wall = "1.5 mm"
end_wall = "2 mm"

[cell.material]
model = "gent"
mu = "245 kPa"
jm = 20

[cell.bottom_material]
model = "gent"
mu = "1225 kPa"
jm = 20

[sweep]
backend = "{backend}"
outputs = [{outputs}]
pmax = "{pmax}"
combine = "random"
samples = {n}
seed = 1

[sweep.parameters]
"ht/d" = {{ start = 0.03, stop = 0.09 }}
"ws/d" = {{ start = 0.04, stop = 0.16 }}
"df/d" = {{ start = 0.05, stop = 0.2 }}
"mu" = {{ start = "150 kPa", stop = "400 kPa", scale = "log" }}
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=10_000)
    ap.add_argument("--batch-size", type=int, default=None)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--pmax", default="500 kPa")
    ap.add_argument("--outputs", default="characteristic,curves")
    ap.add_argument("--backend", default="rom", help="rom, or module:Factory")
    ap.add_argument("--modes", default="raw,threads,local,resume")
    ap.add_argument("--keep", type=Path, default=None, help="keep the sweep folders here")
    args = ap.parse_args()

    from multimorph.sweep import get_backend, parse_sweep_spec, run_sweep

    outputs = ", ".join(f'"{o}"' for o in args.outputs.split(","))
    text = SPEC.format(backend=args.backend, outputs=outputs, pmax=args.pmax, n=args.designs)
    spec = parse_sweep_spec(tomllib.loads(text))
    plugins = (args.backend,) if ":" in args.backend else ()  # named here, on purpose
    backend = get_backend(spec.backend, plugins=plugins)
    bs = args.batch_size or backend.batch_size
    modes = args.modes.split(",")
    root = args.keep or Path(tempfile.mkdtemp(prefix="bench-sweep-"))
    root.mkdir(parents=True, exist_ok=True)
    rows: list[tuple[str, float, int, int]] = []

    t = time.perf_counter()
    table = spec.design_table()
    t_table = time.perf_counter() - t
    valid = table.valid_indices
    cells = [table.cells[i] for i in valid]
    print(f"{len(table)} designs ({len(valid)} valid), batch size {bs}, "
          f"{args.workers} workers, backend {spec.backend}; design table {t_table:.2f} s",
          file=sys.stderr)

    raw = None
    if "raw" in modes:
        t = time.perf_counter()
        backend.evaluate_batch(cells[:bs], spec.pmax, spec.outputs, spec.options)  # warm-up
        print(f"warm-up batch (JIT compile): {time.perf_counter() - t:.1f} s", file=sys.stderr,
              flush=True)
        t = time.perf_counter()
        n_ok = 0
        for k in range(0, len(cells), bs):
            out = backend.evaluate_batch(cells[k:k + bs], spec.pmax, spec.outputs,
                                         spec.options)
            n_ok += sum(not isinstance(r, BaseException) for r in out)
            print(f"  raw: {k + len(out)} designs in {time.perf_counter() - t:.1f} s",
                  file=sys.stderr, flush=True)
        raw = time.perf_counter() - t
        rows.append(("raw batched call (warm)", raw, n_ok, len(cells) - n_ok))
        print(f"raw: {raw:.1f} s", file=sys.stderr)
    for mode in ("threads", "local"):
        if mode not in modes:
            continue
        out_dir = root / mode
        shutil.rmtree(out_dir, ignore_errors=True)
        t = time.perf_counter()
        s = run_sweep(spec, out_dir, scheduler=mode, workers=args.workers, batch_size=bs,
                      allow_plugins=plugins, progress=lambda d, n, m=mode, t0=t: print(
                          f"  {m}: {d}/{n} designs, {time.perf_counter() - t0:.1f} s",
                          file=sys.stderr, flush=True))
        el = time.perf_counter() - t
        label = "warm JIT cache" if mode == "threads" and raw is not None else "cold"
        rows.append((f"sweep, {mode} ({label})", el, s.n_ok, s.n_failed))
        print(f"{mode}: {el:.1f} s (compute {s.compute_time:.1f} s)", file=sys.stderr)
        if mode == "threads" and "resume" in modes:
            t = time.perf_counter()
            r = run_sweep(spec, out_dir, scheduler="threads", workers=args.workers,
                          batch_size=bs, allow_plugins=plugins)
            rows.append(("resume of finished sweep", time.perf_counter() - t, r.n_ok,
                         r.n_failed))

    print(f"\nbench_sweep: {args.designs} designs, backend {spec.backend}, pmax {args.pmax}, "
          f"outputs {args.outputs}, batch {bs}, workers {args.workers}")
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
          f"Python {platform.python_version()}")
    print(f"{'run':<28} {'time (s)':>9} {'designs/s':>10} {'ok':>6} {'failed':>6} "
          f"{'overhead':>9}")
    for name, el, ok, failed in rows:
        rate = (ok + failed) / el if el > 0 else float("nan")
        ov = f"{el / raw:9.2f}" if raw else f"{'-':>9}"
        print(f"{name:<28} {el:9.2f} {rate:10.1f} {ok:6d} {failed:6d} {ov}")
    if args.keep is None:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
