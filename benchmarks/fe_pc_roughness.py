"""How smooth is FE's Pc in the design? FE at ±δ of the top wall around held-out designs.

    python benchmarks/fe_pc_roughness.py --set twisting3 [--worst 10] [--typical 4]
                                         [--delta 0.02] [--json FILE]

A fast model is a smooth function of the design; the labels it is checked against are
functionals of FE curves (Pc: the limit point of the loading path, or where its signal
rises fastest; Ph: the knee after it), and a functional can jump where the curve has two
nearly equal candidates. Where it does, no smooth model meets a tight p90. This measures it:
for the held-out designs of a set where the default model (``calibrated-fast``) misses FE's
Pc most (``--worst``) and, as a control, some with a typical error (``--typical``, about the
median), FE runs again with the top wall (``top_wall``) ×(1 − δ) and ×(1 + δ), everything
else as the set's spec and mesh. Per design it prints FE's Pc at −δ, 0, +δ, the roughness

    r = |ln Pc(0) − (ln Pc(−δ) + ln Pc(+δ)) / 2|

(the centre's distance from the chord of its neighbours: O(δ²), a fraction of a per cent,
for a smooth Pc; a jump between the neighbours shows as r up to half the jump), the spread
|ln Pc(+δ) − ln Pc(−δ)|, the same for Ph, and the model's error at the centre. Measured in
stop 44 (docs/validation.md §3.2).

Each FE run is kept in ``benchmarks/runs/fe_pc_roughness/<set>/<design>_<m|p>.npz``: an
interrupted run resumes where it stopped (finished runs are read back, not rerun).
"""

from __future__ import annotations

import argparse
import json
import math
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

#: The design directions ``--direction`` perturbs: the top wall's thickness, or the wall
#: elastomer's Gent Jm (its strain hardening; μ kept).
DIRECTIONS = ("top_wall", "jm")


def perturbed(cell, factor: float, direction: str = "top_wall"):
    """``cell`` (straight or tilted) with its top wall (or its wall's Gent Jm) × ``factor``."""
    if hasattr(cell, "tilt"):
        return replace(cell, cell=perturbed(cell.cell, factor, direction))
    if direction == "jm":
        from multimorph.materials import Material

        m = cell.material
        if m.model != "gent":
            raise ValueError(f"--direction jm needs a Gent wall, not {m.model}")
        wall = Material("gent", {**m.params, "jm": m.params["jm"] * factor})
        same = cell.bottom_material is m or cell.bottom_material == m
        return replace(cell, material=wall, bottom_material=wall if same
                       else cell.bottom_material)
    return replace(cell, top_wall=cell.top_wall * factor)


def fe_path(out: Path, set_name: str, cell, tag: str) -> dict[str, np.ndarray] | None:
    """FE path of ``cell`` with the set's spec (run now, or read back from ``out``)."""
    from fe_mesh_curves import stored_fe_path

    return stored_fe_path(out / f"{tag}.npz", set_name, cell)


def chosen_designs(set_name: str, worst: int, typical: int) -> list[tuple[int, float, str]]:
    """(row, model Pc error, "worst"|"typical") of the held-out designs to perturb."""
    from multimorph.calibrated import load_model
    from multimorph.calibrated._dataset import REFERENCE_SETS, load_reference
    from multimorph.calibrated._validate import fe_response
    from multimorph.calibrated.validate import at_end_of, requested_pressure, unseen_designs

    kind = REFERENCE_SETS[set_name]
    ref = load_reference()[set_name]
    model, _ = at_end_of(load_model(), kind, set_name)
    rows = np.flatnonzero(ref.ok)
    unseen = unseen_designs(model.manifest, kind, set_name, ref.design[rows],
                            np.asarray(ref.holdout, bool)[rows])
    errs = []
    for r in rows[unseen]:
        fe = fe_response(ref.path(int(r)), ref.cell(int(r)), kind)
        pcf = fe.characteristic.critical
        if pcf is None:
            continue
        pm = requested_pressure(set_name, int(ref.design[r]), ref.path(int(r)))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = model.responses([ref.cell(int(r))], pm, fast=True)[0]
        if isinstance(m, Exception) or m.characteristic.critical is None:
            continue
        errs.append((int(r), m.characteristic.critical / pcf - 1.0))
    errs.sort(key=lambda e: -abs(e[1]))
    out = [(r, e, "worst") for r, e in errs[:worst]]
    rest = sorted(errs[worst:], key=lambda e: abs(e[1]))
    if typical and rest:
        mid = len(rest) // 2
        lo = max(0, mid - typical // 2)
        out += [(r, e, "typical") for r, e in rest[lo:lo + typical]]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", default="twisting3")
    ap.add_argument("--worst", type=int, default=10)
    ap.add_argument("--typical", type=int, default=4)
    ap.add_argument("--delta", type=float, default=0.02)
    ap.add_argument("--direction", choices=DIRECTIONS, default="top_wall")
    ap.add_argument("--part", default="0/1", help="K/N: run every N-th design from K "
                    "(two processes share a list: 0/2 and 1/2)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "runs" / "fe_pc_roughness"))
    ap.add_argument("--json", default=None, help="write the rows to this file")
    args = ap.parse_args(argv)

    from multimorph.calibrated._dataset import REFERENCE_SETS, load_reference
    from multimorph.calibrated._validate import fe_response

    kind = REFERENCE_SETS[args.set]
    ref = load_reference()[args.set]
    sub = f"d{args.delta:g}" + ("" if args.direction == "top_wall" else f"_{args.direction}")
    out = Path(args.out) / args.set / sub
    chosen = chosen_designs(args.set, args.worst, args.typical)
    k, n = (int(v) for v in args.part.split("/"))
    print(f"{args.set}: {len(chosen)} held-out designs, {args.direction} ×(1 ± {args.delta:g})",
          flush=True)
    print(f"{'design':>6} {'which':>8} {'model':>7} {'Pc−':>7} {'Pc0':>7} {'Pc+':>7} "
          f"{'r':>6} {'spread':>7} {'Ph−':>7} {'Ph0':>7} {'Ph+':>7} {'r Ph':>6}", flush=True)
    table = []
    for i, (r, err, which) in enumerate(chosen):
        cell = ref.cell(r)
        design = int(ref.design[r])
        ch0 = fe_response(ref.path(r), cell, kind).characteristic
        if i % n != k:
            continue
        chs = []
        for sign, tag in ((-1, "m"), (1, "p")):
            c = perturbed(cell, 1.0 + sign * args.delta, args.direction)
            p = fe_path(out, args.set, c, f"{design}_{tag}")
            chs.append(None if p is None else fe_response(p, c, kind).characteristic)
        if any(c is None for c in chs):
            continue
        row = {"design": design, "which": which, "model_pc_error": err,
               "pc": [chs[0].critical, ch0.critical, chs[1].critical],
               "ph": [chs[0].hardening, ch0.hardening, chs[1].hardening],
               "pc_kind": [chs[0].critical_kind, ch0.critical_kind, chs[1].critical_kind]}
        row["pc_roughness"], row["pc_spread"] = _rough(row["pc"])
        row["ph_roughness"], _ = _rough(row["ph"])
        table.append(row)
        print(f"{design:>6} {which:>8} {err * 100:>+6.1f}% " + " ".join(
            f"{_kpa(v):>7}" for v in row["pc"]) + f" {_pct(row['pc_roughness']):>6} "
            f"{_pct(row['pc_spread']):>7} " + " ".join(f"{_kpa(v):>7}" for v in row["ph"])
            + f" {_pct(row['ph_roughness']):>6}", flush=True)
    for which in ("worst", "typical"):
        r = np.array([t["pc_roughness"] for t in table if t["which"] == which], float)
        if r.size:
            print(f"{which}: Pc smooth (r ≤ 1 %) on {int(np.sum(r <= 0.01))} of {r.size} "
                  f"({int(np.sum(~np.isfinite(r)))} with no Pc on one side)", flush=True)
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps({"set": args.set, "delta": args.delta,
                                               "direction": args.direction,
                                               "rows": table}, indent=2))
    return 0


def _rough(v: list[float | None]) -> tuple[float, float]:
    if any(x is None or not math.isfinite(x) or x <= 0 for x in v):
        return math.nan, math.nan
    lm, l0, lp = (math.log(x) for x in v)
    return abs(l0 - 0.5 * (lm + lp)), abs(lp - lm)


def _kpa(x: float | None) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x / 1e3:.2f}"


def _pct(x: float) -> str:
    return "-" if not math.isfinite(x) else f"{x * 100:.1f}%"


if __name__ == "__main__":
    raise SystemExit(main())
