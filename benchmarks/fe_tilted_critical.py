"""Tilted FE paths that end at a critical point they could not pass: traced again with finer steps.

    python benchmarks/fe_tilted_critical.py [--sets twisting twisting2 ...] [--shard 0/2]
        [--json FILE]

A tilted cell's FE Pc is read on its strip shear (the shared definitions of
:mod:`multimorph.response`): a limit point where one exists. On 23 of the 446 tilted FE
paths of the data set that limit point is where the arc-length continuation turned round
(its run stalled, ran out of steps or retraced its path): past it the chamber volume never
grows (by 2 % or more) — the path walks back, or stays, instead of going on. Such an end
is either a critical point of the cell (a bifurcation: the equilibrium it was on stops
being stable) or a step the continuation could not take. This traces each of them again
with half the continuation's step limits (``dx_max``, ``dp_max``; ``max_steps`` raised to
match), everything else as its set's spec, and prints, per design, the data set's Pc, the
finer run's (its kind, and whether it turned round again) and the calibrated model's
(``calibrated-fast``), so that a label that was the continuation's, not the cell's, shows.
Since stop 56 the data set's builder repairs such labels itself (``build_dataset --refine``,
:mod:`multimorph.calibrated._refine`, the same test and step limits): on the refined
archive this lists the paths that turned round again.

Each finer run is kept in ``benchmarks/runs/fe_tilted_critical/<set>/<design>.npz``
(written whole or not at all): an interrupted run resumes where it stopped. ``--shard i/n``
runs every n-th design from the i-th (two processes share the work without a scheduler).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from fe_mesh_curves import _kpa, _pct, stored_fe_path  # noqa: E402

from multimorph.calibrated._refine import REFINEMENT, turned_at_critical  # noqa: E402

#: The tilted sets of the data set.
TILTED_SETS = ("twisting", "twisting2", "twisting_narrow", "twisting3")
#: The finer continuation and the test of a turned-round end: the data set's own
#: (:mod:`multimorph.calibrated._refine`, which ``build_dataset --refine`` runs since stop 56).
FINER = REFINEMENT


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", nargs="+", default=list(TILTED_SETS))
    ap.add_argument("--shard", default="0/1", help="i/n: every n-th design from the i-th")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "runs" / "fe_tilted_critical"))
    ap.add_argument("--json", default=None, help="write the rows to this file")
    args = ap.parse_args(argv)
    i_shard, n_shard = (int(v) for v in args.shard.split("/"))

    from multimorph.calibrated import load_model
    from multimorph.calibrated._dataset import load_reference
    from multimorph.calibrated._validate import fe_response
    from multimorph.calibrated.validate import requested_pressure

    refs = load_reference()
    todo = []
    for name in args.sets:
        ref = refs[name]
        for r in np.flatnonzero(ref.ok):
            ch = fe_response(ref.path(int(r)), ref.cell(int(r)), "twisting").characteristic
            if turned_at_critical(ref.path(int(r)), ch.critical, ch.critical_kind):
                todo.append((name, int(r), ch))
    todo = todo[i_shard::n_shard]
    model = load_model()
    print(f"{len(todo)} tilted designs whose FE path turned round at its Pc (shard "
          f"{args.shard}); finer continuation {FINER}", flush=True)
    print(f"{'set':>15} {'design':>6} {'held':>4} {'Pc set':>8} {'Pc finer':>8} {'kind':>11} "
          f"{'turned':>6} {'model':>8} {'vs set':>7} {'vs finer':>8}", flush=True)
    table = []
    for name, r, ch in todo:
        ref = refs[name]
        design = int(ref.design[r])
        cell = ref.cell(r)
        finer = stored_fe_path(Path(args.out) / name / f"{design}.npz", name, cell, FINER)
        if finer is None:
            continue
        fch = fe_response(finer, cell, "twisting").characteristic
        resp = model.responses([cell], requested_pressure(name, design, ref.path(r)),
                               fast=True)[0]
        pm = None if isinstance(resp, Exception) else resp.characteristic.critical
        row = {"set": name, "design": design,
               "held_out": bool(ref.holdout[r]) or name == "twisting3",
               "pc_set": ch.critical, "pc_finer": fch.critical, "kind_finer": fch.critical_kind,
               "turned_again": turned_at_critical(finer, fch.critical, fch.critical_kind),
               "pc_model": pm, "finer_wall_time_s": float(finer.get("wall_time", math.nan))}
        table.append(row)
        print(f"{name:>15} {design:>6} {'yes' if row['held_out'] else 'no':>4} "
              f"{_kpa(ch.critical):>8} {_kpa(fch.critical):>8} {fch.critical_kind!s:>11} "
              f"{'yes' if row['turned_again'] else 'no':>6} {_kpa(pm):>8} "
              f"{_pct(pm, ch.critical):>7} {_pct(pm, fch.critical):>8}", flush=True)
    if table:
        moved = [t for t in table if not t["turned_again"]]
        print(f"passed their old end with finer steps: {len(moved)} of {len(table)}", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps({"finer": FINER, "rows": table}, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
