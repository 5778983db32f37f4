"""FE against a finer FE mesh on held-out designs, with the calibrated model's curve metrics.

    python benchmarks/fe_mesh_curves.py [--set bending_mirror] [--n 8] [--json FILE]
        [--designs 44,112,...]

What a curve criterion can ask of any model: the data set's FE (2 elements through every
wall, in-plane edges d/20) is itself within 1-3 % of a finer mesh on Pc. Where a cell snaps
(a limit point: κ jumps at Pc), the issue's curve measure (``_validate.compare``: the largest
vertical distance |y_model(P) − y_FE(P)| over the FE pressures up to 1.5 Pc, over the FE
range) counts a 1 % shift of the jump as an error of the jump's whole height. This runs the
first ``--n`` held-out designs of a set (FE time in the data set ≤ ``--max-time`` s) again
on the fine mesh (4 elements through every wall, edges d/24, everything else as the set's
spec) and prints, per design, the fine mesh's Pc and Ph against the set's, and both curve
measures of the set's FE against the fine FE (the fine FE standing where the model stands
in the validation): the vertical one and the graph distance (``_validate.graph_error``).
Any set of the data set: bending (the signal κd), stretching (the axial stretch) or tilted
cells (``--set twisting``: the strip shear; their set's edges are d/16). Measured:
``bending_mirror`` 16 designs, ``twisting`` 8 (docs/validation.md §3.1).

Each fine run is kept in ``benchmarks/runs/fe_mesh_curves/<set>/<design>.npz``: an
interrupted run resumes where it stopped (the finished designs are read back, not rerun).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FINE = {"wall_elements": 4, "length_fraction": 1.0 / 24.0}


#: The path arrays a stored FE run keeps.
PATH_KEYS = ("pressure", "curvature", "peak_stretch", "axial_stretch", "volume", "bend_angle",
             "shear", "twist_rate", "stable")


def stored_fe_path(f: Path, set_name: str, cell, options: dict | None = None,
                   ) -> dict[str, np.ndarray] | None:
    """FE path of ``cell`` with set ``set_name``'s spec (its options updated by
    ``options``), read back from ``f`` (.npz) if it is there, else run and stored there
    (written whole or not at all, so an interrupted run resumes). None: the FE failed."""
    from multimorph.calibrated._dataset import reference_spec
    from multimorph.sweep._backends import FeBackend

    if f.exists():
        with np.load(f) as z:
            return {k: z[k] for k in z.files}
    spec = reference_spec(set_name)
    t0 = time.perf_counter()
    rec = FeBackend().evaluate_batch([cell], spec.pmax, ("characteristic", "curves"),
                                     {**dict(spec.options), **(options or {})})[0]
    if isinstance(rec, Exception):
        print(f"  {f.stem}: FE failed: {rec}", flush=True)
        return None
    path = {k: np.asarray(rec[k]) for k in PATH_KEYS if k in rec}
    path["wall_time"] = np.array(time.perf_counter() - t0)
    f.parent.mkdir(parents=True, exist_ok=True)
    tmp = f.with_suffix(".tmp.npz")
    np.savez(tmp, **path)
    tmp.replace(f)
    return path


def _fine_path(out: Path, ref, row: int) -> dict[str, np.ndarray] | None:
    """The fine mesh's path of ``row`` (run now, or read back from ``out``)."""
    return stored_fe_path(out / f"{int(ref.design[row])}.npz", ref.name, ref.cell(row), FINE)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", default="bending_mirror")
    ap.add_argument("--n", type=int, default=8)
    ap.add_argument("--max-time", type=float, default=80.0,
                    help="only designs whose data-set FE took at most this (s)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "runs" / "fe_mesh_curves"))
    ap.add_argument("--json", default=None, help="write the rows to this file")
    ap.add_argument("--designs", default=None,
                    help="comma-separated design numbers to run (in place of the first --n "
                         "held-out ones), e.g. the designs the model misses most")
    args = ap.parse_args(argv)

    from multimorph.calibrated._dataset import REFERENCE_SETS, load_reference
    from multimorph.calibrated._validate import compare, fe_response, graph_error

    kind = REFERENCE_SETS[args.set]
    ref = load_reference()[args.set]
    if args.designs:
        wanted = [int(d) for d in args.designs.split(",")]
        missing = sorted(set(wanted) - {int(d) for d in ref.design[ref.ok]})
        if missing:
            ap.error(f"--designs: {missing} are not designs of {args.set} with an FE path")
        rows = [int(np.flatnonzero((ref.design == d) & ref.ok)[0]) for d in wanted]
    else:
        rows = [r for r in np.flatnonzero(ref.ok & ref.holdout)
                if float(ref.meta[r].get("wall_time", math.inf)) <= args.max_time
                and math.isfinite(ref.scalars["critical_pressure"][r])][: args.n]
    out = Path(args.out) / args.set
    print(f"{args.set}: {len(rows)} held-out designs, fine mesh {FINE}", flush=True)
    print(f"{'design':>6} {'Pc fine':>9} {'Pc set':>9} {'dPc':>7} {'dPh':>7} "
          f"{'vertical':>9} {'graph':>7} {'fine s':>7}", flush=True)
    table = []
    for r in rows:
        fine = _fine_path(out, ref, int(r))
        if fine is None:
            continue
        cell = ref.cell(int(r))
        f_fine = fe_response(fine, cell, kind)
        f_set = fe_response(ref.path(int(r)), cell, kind)
        c = compare(f_set, f_fine, kind, args.set, int(ref.design[r]))
        g = graph_error(f_set, f_fine, kind)
        row = {"design": int(ref.design[r]), "pc_fine": c.pc_fe, "pc_set": c.pc_model,
               "pc_error": c.pc_error, "ph_error": c.ph_error, "curve_vertical": c.curve_error,
               "curve_graph": g, "fine_wall_time_s": float(fine.get("wall_time", math.nan))}
        table.append(row)
        print(f"{row['design']:>6} {_kpa(c.pc_fe):>9} {_kpa(c.pc_model):>9} "
              f"{_pct(c.pc_model, c.pc_fe):>7} {_pct(c.ph_model, c.ph_fe):>7} "
              f"{c.curve_error:>9.3f} {g:>7.3f} {row['fine_wall_time_s']:>7.0f}", flush=True)
    if table:
        v = np.array([t["curve_vertical"] for t in table], float)
        g = np.array([t["curve_graph"] for t in table], float)
        print(f"within 10 %: vertical {np.sum(v <= 0.1)}/{np.isfinite(v).sum()}, graph "
              f"{np.sum(g <= 0.1)}/{np.isfinite(g).sum()}; |dPc| median "
              f"{np.nanmedian([t['pc_error'] for t in table]) * 100:.1f} %")
    if args.json:
        Path(args.json).write_text(json.dumps({"set": args.set, "fine_mesh": FINE,
                                               "rows": table}, indent=2))
    return 0


def _kpa(x: float | None) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x / 1e3:.2f}"


def _pct(a: float | None, b: float | None) -> str:
    if a is None or b is None or not (math.isfinite(a) and math.isfinite(b)) or b == 0:
        return "-"
    return f"{(a / b - 1) * 100:+.1f}%"


if __name__ == "__main__":
    raise SystemExit(main())
