"""Modules in FE against the calibrated model's modules: a 4-cell bending module and a
3-cell stretching module (the done-when check of the calibrated cell model).

Run: python benchmarks/calibrated_modules.py [--out benchmarks/calibrated_modules.json]
     [--fe-only] [--refit]

Each module is meshed whole (half model, 2 elements through every wall, edges d/20, the
data set's settings), clamped at its start and free at its end, inflated to 0.6 μ or
V/V0 = 25; its motion is the end rotation per cell (bending) or the end's axial stretch
(stretching). The calibrated model's module is its cell's response times the cell count
(the module rule of ``multimorph.device``). FE results are cached in the out file (FE takes
minutes); ``--refit`` reruns them. Prints Pc and the motion at 1.5 Pc side by side.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from multimorph.geometry import CellGeometry
from multimorph.materials import Material

MU = 1e5
WALL = Material("gent", {"mu": MU, "jm": 30.0})
BOTTOM = Material("gent", {"mu": 10 * MU, "jm": 30.0})
#: (name, kind, cell, cells): the fe_cell.toml cell and the fe_device.toml seal cell
MODULES = (
    ("bending-4", "bending",
     CellGeometry(20e-3, 10e-3, 8e-3, 1e-3, 2e-3, 2e-3, 2e-3, material=WALL,
                  bottom_material=BOTTOM), 4),
    ("stretching-3", "stretching",
     CellGeometry(20e-3, 20e-3, 12e-3, 1.6e-3, 1.6e-3, 2e-3, 2e-3, material=WALL,
                  symmetric=True), 3),
)


def run_fe(cell: CellGeometry, n: int) -> dict[str, list[float]]:
    from multimorph.fe import FESettings, MeshDensity, simulate_cell

    s = FESettings(mesh=MeshDensity(wall_elements=2, length_fraction=0.05), p_max=0.6 * MU,
                   max_volume_ratio=25.0, max_steps=200)
    t = time.perf_counter()
    res = simulate_cell(cell, s, n_cells=n)
    p = res.response.path
    return {"pressure": p.pressure.tolist(), "bend_angle": p.extra["bend_angle"].tolist(),
            "axial_stretch": p.axial_stretch.tolist(), "volume": p.volume.tolist(),
            "peak_stretch": p.peak_stretch.tolist(), "stable": p.stable.tolist(),
            "nfree": res.stats["nfree"], "points": res.stats["points"],
            "stop_reason": res.stats["stop_reason"], "time": time.perf_counter() - t}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="benchmarks/calibrated_modules.json")
    ap.add_argument("--fe-only", action="store_true")
    ap.add_argument("--refit", action="store_true")
    args = ap.parse_args()
    out = Path(args.out)
    cache = json.loads(out.read_text()) if out.exists() and not args.refit else {}
    for name, _kind, cell, n in MODULES:
        if name not in cache:
            print(f"FE of {name} ...", flush=True)
            cache[name] = run_fe(cell, n)
            out.write_text(json.dumps(cache, indent=1) + "\n")
    if args.fe_only:
        return
    from multimorph.calibrated._validate import compare, fe_response
    from multimorph.models import cell_model

    model = cell_model("calibrated")
    ritz = cell_model("ritz")
    print(f"{'module':<14} {'model':<11} {'Pc FE':>8} {'Pc model':>9} {'ΔPc':>7} "
          f"{'motion@1.5Pc FE':>16} {'model':>8} {'Δ':>7}")
    for name, kind, cell, n in MODULES:
        fe = cache[name]
        path = {k: np.asarray(v) for k, v in fe.items() if isinstance(v, list)}
        path["curvature"] = np.zeros(len(path["pressure"]))
        path["shear"] = np.zeros(len(path["pressure"]))
        fe_resp = fe_response(path, cell, kind, n_cells=n)
        for label, m in (("calibrated", model), ("ritz", ritz)):
            r = m(cell, float(max(path["pressure"])) * 1.2)
            c = compare(r, fe_resp, kind)
            d15 = (c.y15_model - c.y15_fe) / c.y15_fe if c.y15_fe else float("nan")

            def kpa(p: float | None) -> str:
                return "—" if p is None else f"{p / 1e3:.2f}"

            print(f"{name:<14} {label:<11} {kpa(c.pc_fe):>8} {kpa(c.pc_model):>9} "
                  f"{100 * c.pc_error:6.1f}% {c.y15_fe:16.4f} {c.y15_model:8.4f} "
                  f"{100 * d15:6.1f}%")


if __name__ == "__main__":
    main()
