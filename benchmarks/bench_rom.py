"""Throughput of the reduced cell model: batched curves per second and single-curve latency.

Run: python benchmarks/bench_rom.py [--n 10000] [--chunk 2000] [--pmax-over-mu 1.2]

Random valid designs (Gent walls, μ 150–400 kPa, Jm 12–40, bottom 5 μ; ratios in the ranges
of the paper's cells) are traced from P = 0 to pmax over mu · μ in chunks of one vectorised,
jitted call each. Prints a table: compile time, batch throughput (full κ(P) curves per
second, excluding compilation) and the time of one curve for a single design after warm-up.
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--n", type=int, default=10_000)
    ap.add_argument("--chunk", type=int, default=2_000)
    ap.add_argument("--pmax-over-mu", type=float, default=1.2)
    ap.add_argument("--single-repeats", type=int, default=10)
    args = ap.parse_args()

    import jax

    from multimorph.geometry import CellGeometry
    from multimorph.materials import Material
    from multimorph.rom import solve_batch, solve_cell

    class Rows(list):
        def append(self, row: tuple[str, str]) -> None:  # print as soon as measured
            super().append(row)
            print(f"{row[0]:<40}  {row[1]}", flush=True)

    rows: list[tuple[str, str]] = Rows()
    rows.append(("device", f"{jax.devices()[0]} ({os.cpu_count()} cpus)"))
    batch = random_batch(args.n)
    chunk = min(args.chunk, args.n)

    def sub(i0: int, i1: int):
        from dataclasses import replace

        return replace(batch, length=batch.length[i0:i1],
                       ratios={k: v[i0:i1] for k, v in batch.ratios.items()},
                       mu=batch.mu[i0:i1],
                       wall_params={k: v[i0:i1] for k, v in batch.wall_params.items()},
                       bottom_params={k: v[i0:i1] for k, v in batch.bottom_params.items()},
                       break_stretch=batch.break_stretch[i0:i1])

    pm = args.pmax_over_mu * batch.mu
    t = time.perf_counter()
    solve_batch(sub(0, chunk), pm[:chunk])
    rows.append((f"compile + first chunk of {chunk}", f"{time.perf_counter() - t:.1f} s"))
    t = time.perf_counter()
    ok = 0
    points = 0
    for i0 in range(0, args.n - args.n % chunk, chunk):
        rb = solve_batch(sub(i0, i0 + chunk), pm[i0:i0 + chunk])
        ok += int(rb.ok.sum())
        points += int(rb.count.sum())
    n_done = args.n - args.n % chunk
    dt = time.perf_counter() - t
    rows.append((f"batch: {n_done} designs", f"{dt:.2f} s"))
    rows.append(("batch throughput", f"{n_done / dt:.1f} curves/s"))
    rows.append(("reached pmax", f"{ok}/{n_done}"))
    rows.append(("mean points per curve", f"{points / max(n_done, 1):.1f}"))

    m = Material("gent", {"mu": 2.45e5, "jm": 20.0})
    cell = CellGeometry(20e-3, 10e-3, 8e-3, 0.8e-3, 2e-3, 1.5e-3, 1.5e-3, material=m,
                        bottom_material=m.scaled(5.0))
    t = time.perf_counter()
    solve_cell(cell, args.pmax_over_mu * cell.mu)
    rows.append(("single: compile + first curve", f"{time.perf_counter() - t:.1f} s"))
    times = []
    for _ in range(args.single_repeats):
        t = time.perf_counter()
        r = solve_cell(cell, args.pmax_over_mu * cell.mu)
        times.append(time.perf_counter() - t)
    rows.append(("single curve (median, warm)", f"{1e3 * float(np.median(times)):.1f} ms "
                 f"({len(r.path)} points, incl. Pc/Ph)"))
    width = max(len(a) for a, _ in rows)
    print()
    print(f"{'quantity'.ljust(width)}  value")
    print(f"{'-' * width}  {'-' * 30}")
    for a, b in rows:
        print(f"{a.ljust(width)}  {b}")


if __name__ == "__main__":
    main()
