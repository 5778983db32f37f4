"""Plate ends against mirror ends on the same designs of the FE reference data set.

    python benchmarks/mirror_ends.py [--json FILE]

For every design finished in both a set and its ``_mirror`` twin (the same Sobol designs
and FE settings; the twin's cell has mirror ends, ``multimorph.fe.CELL_ENDS``), the ratio of
Pc and of Ph (mirror / plate, read on the kind's signal as the calibration reads them:
bending on the end rotation per cell, stretching on the axial stretch). Prints the ratios'
median and spread per set pair and, for bending, how they split by the bottom layer's
stiffness (mu_b/mu): the plate's rigid sections stiffen cells whose bottom layer and
partitions would stretch sideways.
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from multimorph.calibrated._dataset import REFERENCE_SETS, load_reference
from multimorph.calibrated._validate import fe_response

PAIRS = [(name.removesuffix("_mirror"), name) for name in REFERENCE_SETS
         if name.endswith("_mirror")]


def ratios(sets: dict, plate: str, mirror: str) -> list[dict]:
    a, b = sets[plate], sets[mirror]
    kind = REFERENCE_SETS[plate]
    index_a = {int(d): i for i, d in enumerate(a.design)}
    rows = []
    for j, d in enumerate(b.design):
        i = index_a.get(int(d))
        if i is None or not (a.ok[i] and b.ok[j]):
            continue
        ca, cb = (fe_response(s.path(k), s.cell(k), kind).characteristic
                  for s, k in ((a, i), (b, j)))
        cell = b.cell(j)
        row = {"design": int(d), "mu_b/mu": cell.bottom_material.shear_modulus / cell.mu
               if cell.bottom_material is not None else 1.0}
        for key, x, y in (("pc", ca.critical, cb.critical), ("ph", ca.hardening, cb.hardening)):
            row[key + "_plate"], row[key + "_mirror"] = x, y
            row[key + "_ratio"] = (y / x if x and y and math.isfinite(x) and math.isfinite(y)
                                   else math.nan)
        rows.append(row)
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="write the per-design ratios here")
    args = ap.parse_args(argv)
    sets = dict(load_reference())
    out = {}
    print(f"{'plate set':<18} {'mirror set':<26} {'n':>4} {'Pc ratio: median':>17} "
          f"{'p10':>6} {'p90':>6} {'Ph ratio: median':>17} {'p10':>6} {'p90':>6}")
    for plate, mirror in PAIRS:
        if plate not in sets or mirror not in sets:
            continue
        rows = ratios(sets, plate, mirror)
        out[mirror] = rows
        if not rows:
            continue
        line = f"{plate:<18} {mirror:<26} {len(rows):>4}"
        for key in ("pc", "ph"):
            r = np.array([x[key + "_ratio"] for x in rows], float)
            r = r[np.isfinite(r)]
            line += (f" {np.median(r):>17.3f} {np.percentile(r, 10):>6.3f} "
                     f"{np.percentile(r, 90):>6.3f}" if len(r) else f" {'-':>17} {'':>6} {'':>6}")
        print(line)
        if REFERENCE_SETS[plate] == "bending":
            for lo, hi in ((0.0, 1.5), (1.5, 4.0), (4.0, math.inf)):
                r = np.array([x["pc_ratio"] for x in rows if lo <= x["mu_b/mu"] < hi], float)
                r = r[np.isfinite(r)]
                if len(r):
                    print(f"{'':<18}   mu_b/mu in [{lo:g}, {hi:g}): n {len(r)}, Pc ratio median "
                          f"{np.median(r):.3f}, range {r.min():.3f}-{r.max():.3f}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
