"""Throughput of the reduced cell model: batched curves per second and single-curve latency.

Run: python benchmarks/bench_rom.py [--n 10000] [--chunk 256] [--workers 2]

Random valid designs (Gent walls, μ 150–400 kPa, Jm 12–40, bottom 5 μ; ratios in the ranges
of the paper's cells) are traced from P = 0 to pmax over mu · μ. Prints a table: compile
time; one process running a vectorised chunk (with the tracer's cost unit: gradient/Hessian
evaluations per curve and the time of one evaluation per design, which bound the
throughput); one process looping over single traces; the headline batch of ``--n`` designs
over ``--workers`` processes in chunks of ``solve_batch``'s default mode (full κ(P) curves
per second, excluding compilation); and the time of one curve for a single design after warm-up.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np


def random_batch(n: int, seed: int = 0):
    from multimorph.rom import CellBatch

    rng = np.random.default_rng(seed)
    w = rng.uniform(0.35, 0.6, n)
    h = rng.uniform(0.3, 0.5, n)
    hb = rng.uniform(0.06, 0.12, n)
    ht = rng.uniform(0.025, 0.06, n)
    ws = rng.uniform(0.04, 0.1, n) * w / 0.5
    df = rng.uniform(0.04, 0.12, n)
    mu = rng.uniform(150e3, 400e3, n)
    jm = rng.uniform(12.0, 40.0, n)
    return CellBatch(
        length=np.full(n, 20e-3), ratios={"w": w, "h": h, "ht": ht, "hb": hb, "ws": ws,
                                          "df": df},
        mu=mu, wall_law="gent", bottom_law="gent",
        wall_params={"mu": np.ones(n), "jm": jm},
        bottom_params={"mu": np.full(n, 5.0), "jm": jm},
        break_stretch=np.full(n, np.nan))


def _sub(batch, i0: int, i1: int):
    from dataclasses import replace

    return replace(batch, length=batch.length[i0:i1],
                   ratios={k: v[i0:i1] for k, v in batch.ratios.items()},
                   mu=batch.mu[i0:i1],
                   wall_params={k: v[i0:i1] for k, v in batch.wall_params.items()},
                   bottom_params={k: v[i0:i1] for k, v in batch.bottom_params.items()},
                   break_stretch=batch.break_stretch[i0:i1])


def _worker_chunk(args: tuple[int, int, int, int, float]) -> tuple[int, int, int, float]:
    """Process-pool task: trace designs [i0, i1) of the seeded batch with ``solve_batch``'s
    default mode (a loop of single traces on CPUs, vmapped on accelerators); compiled once
    per worker, from the on-disk cache after the first worker."""
    n, i0, i1, seed, pmax_over_mu = args
    from multimorph.rom import solve_batch

    batch = _sub(random_batch(n, seed), i0, i1)
    t = time.perf_counter()
    rb = solve_batch(batch, pmax_over_mu * batch.mu)
    return int(rb.ok.sum()), int(rb.count.sum()), int(rb.n_eval.sum()), time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--n", type=int, default=10_000, help="designs of the headline batch")
    ap.add_argument("--chunk", type=int, default=256, help="designs per vectorised call")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                    help="processes for the headline batch")
    ap.add_argument("--pmax-over-mu", type=float, default=1.2)
    ap.add_argument("--single-repeats", type=int, default=10)
    ap.add_argument("--loop", type=int, default=64, help="designs of the single-trace loop")
    args = ap.parse_args()

    import jax

    from multimorph.geometry import CellGeometry
    from multimorph.materials import Material
    from multimorph.rom import solve_batch, solve_cell

    class Rows(list):
        def append(self, row: tuple[str, str]) -> None:  # print as soon as measured
            super().append(row)
            print(f"{row[0]:<44}  {row[1]}", flush=True)

    rows: list[tuple[str, str]] = Rows()
    rows.append(("device", f"{jax.devices()[0]} ({os.cpu_count()} cpus)"))
    chunk = min(args.chunk, args.n)
    pmo = args.pmax_over_mu

    # 1. one process, vectorised: compile, then a warm chunk of fresh designs
    warm = random_batch(chunk, seed=99)
    t = time.perf_counter()
    solve_batch(warm, pmo * warm.mu, vectorise=True)
    rows.append((f"compile + first vmapped chunk of {chunk}",
                 f"{time.perf_counter() - t:.1f} s"))
    probe = random_batch(chunk, seed=98)
    t = time.perf_counter()
    rb = solve_batch(probe, pmo * probe.mu, vectorise=True)
    dt = time.perf_counter() - t
    ne = rb.n_eval
    rows.append((f"vmapped chunk of {chunk}, 1 process", f"{chunk / dt:.1f} curves/s"))
    rows.append(("  derivative evaluations per curve", f"mean {ne.mean():.0f}, max {ne.max()} "
                 f"(the chunk runs to the max)"))
    rows.append(("  time per evaluation per design", f"{dt / ne.max() / chunk * 1e6:.0f} us"))
    rows.append(("  accepted points per curve", f"{rb.count.mean():.1f}"))

    # 2. one process, loop of single traces (includes Pc/Ph per design)
    loop = random_batch(args.loop, seed=97)
    cells = []
    for i in range(args.loop):
        wm = Material("gent", {"mu": float(loop.mu[i]), "jm": float(loop.wall_params["jm"][i])})
        bm = Material("gent", {"mu": 5.0 * float(loop.mu[i]),
                               "jm": float(loop.wall_params["jm"][i])})
        r = {k: float(v[i]) * 20e-3 for k, v in loop.ratios.items()}
        cells.append(CellGeometry(20e-3, r["w"], r["h"], r["ht"], r["hb"], r["ws"], r["df"],
                                  material=wm, bottom_material=bm))
    solve_cell(cells[0], pmo * cells[0].mu)
    t = time.perf_counter()
    for c in cells:
        solve_cell(c, pmo * c.mu)
    dt = time.perf_counter() - t
    rows.append((f"loop of {args.loop} single traces, 1 process",
                 f"{args.loop / dt:.1f} curves/s (incl. Pc/Ph)"))

    # 3. the headline: n designs over `workers` processes, vectorised chunks
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing import get_context

    n = args.n
    tasks = [(n, i0, min(i0 + chunk, n), 0, pmo) for i0 in range(0, n, chunk)]
    with ProcessPoolExecutor(args.workers, mp_context=get_context("spawn")) as pool:
        t = time.perf_counter()
        list(pool.map(_worker_chunk, [(chunk, 0, chunk, 99, pmo)] * args.workers))
        rows.append((f"start {args.workers} workers + compile in each",
                     f"{time.perf_counter() - t:.1f} s"))
        t = time.perf_counter()
        res = list(pool.map(_worker_chunk, tasks))
        dt = time.perf_counter() - t
    ok = sum(r[0] for r in res)
    pts = sum(r[1] for r in res)
    nev = sum(r[2] for r in res)
    rows.append((f"batch: {n} designs, {args.workers} processes, solve_batch default",
                 f"{dt:.1f} s"))
    rows.append(("batch throughput", f"{n / dt:.1f} curves/s"))
    rows.append(("reached pmax", f"{ok}/{n}"))
    rows.append(("mean points / evaluations per curve", f"{pts / n:.1f} / {nev / n:.0f}"))

    # 4. latency of one curve
    m = Material("gent", {"mu": 2.45e5, "jm": 20.0})
    cell = CellGeometry(20e-3, 10e-3, 8e-3, 0.8e-3, 2e-3, 1.5e-3, 1.5e-3, material=m,
                        bottom_material=m.scaled(5.0))
    t = time.perf_counter()
    solve_cell(cell, pmo * cell.mu)
    rows.append(("single: compile + first curve", f"{time.perf_counter() - t:.1f} s"))
    times = []
    for _ in range(args.single_repeats):
        t = time.perf_counter()
        r = solve_cell(cell, pmo * cell.mu)
        times.append(time.perf_counter() - t)
    rows.append(("single curve (median, warm)", f"{1e3 * float(np.median(times)):.1f} ms "
                 f"({len(r.path)} points, {r.meta['evaluations']} evaluations, incl. Pc/Ph)"))
    width = max(len(a) for a, _ in rows)
    print()
    print(f"{'quantity'.ljust(width)}  value")
    print(f"{'-' * width}  {'-' * 30}")
    for a, b in rows:
        print(f"{a.ljust(width)}  {b}")


if __name__ == "__main__":
    main()
