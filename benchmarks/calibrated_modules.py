"""Modules in FE against the calibrated model's modules: a 4-cell bending module and a
3-cell stretching module (the done-when check of the calibrated cell model).

Run: python benchmarks/calibrated_modules.py [--out benchmarks/calibrated_modules.json]
     [--fe-only] [--refit]

Each module is meshed whole (half model, 2 elements through every wall, edges d/20, the
data set's settings), clamped at its start and free at its end, inflated to 0.6 μ or
V/V0 = 25; its motion is the end rotation per cell (bending) or the end's axial stretch
(stretching). The calibrated model's module is its cell's response times the cell count
(the module rule of ``multimorph.device``). FE results are cached in the out file (FE takes
minutes); ``--refit`` reruns them. Prints Pc, Ph, the motion at 1.5 Pc and the graph error
(docs/validation.md §3: the largest distance of FE's loading curve up to 1.5 Pc from the
model's, in P / Pc and the motion over FE's range) side by side.

Each module's cell alone in FE (mirror ends, the cell as inside a module; cached as
``<module>/cell``) is printed beside the module's Pc too: module / cell is the module
rule's error (cell × count), the calibrated cell against it the cell model's.

Where a module's trace ends before 1.5 Pc, it has no motion there to compare: the
stretching module's cells balloon past 25 times their volume (the data set's and the
model's end) at 1.03 Pc, on the plateau after their snap. For such a module the motion is
compared at equal chamber volumes (V/V0 = 2, 5, 10, 15, 20, 25), the reading that stays
well-posed along a plateau, where a pressure a per cent off moves the motion by a half;
the extension (stretch − 1) against FE's, and that difference over FE's range along its
path (the curve criterion's measure), beside the module's cell alone in FE (mirror ends,
cached as ``<module>/cell``): where the model follows that cell and the module departs
from both, the difference is the module rule's (cell × count), not the cell model's.
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


def run_fe(cell: CellGeometry, n: int, end: str = "free") -> dict[str, list[float]]:
    from multimorph.fe import FESettings, MeshDensity, simulate_cell

    s = FESettings(mesh=MeshDensity(wall_elements=2, length_fraction=0.05), p_max=0.6 * MU,
                   max_volume_ratio=25.0, max_steps=200)
    t = time.perf_counter()
    res = simulate_cell(cell, s, n_cells=n, end=end)
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
        if f"{name}/cell" not in cache:
            # the module's cell alone, as inside a module (mirror ends): says whether a
            # difference is the cell model's or the module rule's (cell × count)
            print(f"FE of {name}'s cell ...", flush=True)
            cache[f"{name}/cell"] = run_fe(cell, 1, end="mirror")
            out.write_text(json.dumps(cache, indent=1) + "\n")
    if args.fe_only:
        return
    from multimorph.calibrated._validate import compare, fe_response
    from multimorph.models import cell_model

    model = cell_model("calibrated")
    ritz = cell_model("ritz")
    print(f"{'module':<14} {'model':<11} {'Pc FE':>8} {'Pc model':>9} {'ΔPc':>7} "
          f"{'Ph FE':>8} {'Ph model':>9} {'ΔPh':>7} "
          f"{'motion@1.5Pc FE':>16} {'model':>8} {'Δ':>7} {'graph err':>10}")
    by_volume, cells = [], []
    for name, kind, cell, n in MODULES:
        path = cached_path(cache[name])
        fe_resp = fe_response(path, cell, kind, n_cells=n)
        for label, m in (("calibrated", model), ("ritz", ritz)):
            r = m(cell, float(max(path["pressure"])) * 1.2)
            c = compare(r, fe_resp, kind)
            d15 = (c.y15_model - c.y15_fe) / c.y15_fe if c.y15_fe else float("nan")
            dpc, dph = signed(c.pc_model, c.pc_fe), signed(c.ph_model, c.ph_fe)

            def kpa(p: float | None) -> str:
                return "—" if p is None else f"{p / 1e3:.2f}"

            print(f"{name:<14} {label:<11} {kpa(c.pc_fe):>8} {kpa(c.pc_model):>9} "
                  f"{100 * dpc:+6.1f}% {kpa(c.ph_fe):>8} {kpa(c.ph_model):>9} "
                  f"{100 * dph:+6.1f}% {c.y15_fe:16.4f} {c.y15_model:8.4f} "
                  f"{100 * d15:+6.1f}% {100 * c.graph_error:9.1f}%")
            if not (np.isfinite(c.y15_fe) and np.isfinite(c.y15_model)):
                by_volume.append((name, kind, label, path, r, n, c))
        cells.append((name, kind, cell, fe_resp))
    # the module's cell alone in FE: how far the module rule (cell × count) is from the
    # module, apart from the cell model's own error
    print(f"\n{'module':<14} {'Pc FE module':>13} {'Pc FE cell':>11} {'module/cell':>12} "
          f"{'Pc calibrated cell':>19} {'vs FE cell':>11}")
    for name, kind, cell, fe_resp in cells:
        alone = cached_path(cache[f"{name}/cell"])
        pc_cell = fe_response(alone, cell, kind).characteristic.critical
        pc_mod = fe_resp.characteristic.critical
        pc_cal = model(cell, float(max(alone["pressure"])) * 1.2).characteristic.critical
        print(f"{name:<14} {pc_mod / 1e3:13.2f} {pc_cell / 1e3:11.2f} "
              f"{100 * signed(pc_mod, pc_cell):+11.1f}% {pc_cal / 1e3:19.2f} "
              f"{100 * signed(pc_cal, pc_cell):+10.1f}%")
    for name, kind, label, path, r, n, c in by_volume:
        pc = c.pc_fe or float("nan")
        print(f"\n{name} ({label}): no motion at 1.5 Pc to compare (FE's path ends at "
              f"{c.top_fe / pc:.2f} Pc, the model's at {c.top_model / pc:.2f} Pc, FE's Pc "
              f"{pc / 1e3:.2f} kPa); the motion at equal chamber volumes:")
        print(f"{'V/V0':>6} {'P FE':>7} {'P model':>8} {'motion FE':>10} {'model':>8} {'Δ':>7} "
              f"{'Δ / FE range':>13} {'FE cell alone':>14}")
        vf = path["volume"] / path["volume"][0]
        vm = np.asarray(r.path.volume, float) / float(r.path.volume[0])
        yf = module_motion(path, kind, n)
        ym = module_motion({k: np.asarray(getattr(r.path, k)) for k in
                            ("pressure", "axial_stretch")}
                           | {"bend_angle": bend_of(r)}, kind, n)
        rows = [v for v in (2.0, 5.0, 10.0, 15.0, 20.0, 25.0)
                if vf[0] <= v <= vf.max() * (1 + 1e-6) and vm[0] <= v <= vm.max() * (1 + 1e-6)]
        if not rows:
            print("  (the two paths share no chamber volume past V/V0 = 2)")
        span = float(np.max(yf) - np.min(yf))
        alone = cached_path(cache[f"{name}/cell"])
        vc = alone["volume"] / alone["volume"][0]
        yc = module_motion(alone | {"bend_angle": alone["bend_angle"] * n}, kind, n)
        for v in rows:
            a, b = float(np.interp(v, vf, yf)), float(np.interp(v, vm, ym))
            c = f"{np.interp(v, vc, yc):14.4f}" if v <= vc.max() * (1 + 1e-6) else f"{'—':>14}"
            print(f"{v:6.0f} {np.interp(v, vf, path['pressure']) / 1e3:7.2f} "
                  f"{np.interp(v, vm, r.path.pressure) / 1e3:8.2f} {a:10.4f} {b:8.4f} "
                  f"{100 * (b - a) / a:+6.1f}% {100 * (b - a) / span:+12.1f}% {c}")


def cached_path(entry: dict[str, object]) -> dict[str, np.ndarray]:
    """A cached FE run's path arrays, with the zero curvature and shear ``fe_response``
    reads (the runs store the end rotation, ``bend_angle``, instead)."""
    path = {k: np.asarray(v) for k, v in entry.items() if isinstance(v, list)}
    path["curvature"] = np.zeros(len(path["pressure"]))
    path["shear"] = np.zeros(len(path["pressure"]))
    return path


def signed(model: float | None, fe: float | None) -> float:
    """(model − FE) / FE; NaN where either is missing."""
    return (model - fe) / fe if model is not None and fe else float("nan")


def module_motion(path: dict[str, np.ndarray], kind: str, n: int) -> np.ndarray:
    """The module's motion along a path: its extension, axial stretch − 1 (stretching), or
    its end rotation per cell (bending, rad), as the table above reads it."""
    if kind == "stretching":
        return np.asarray(path["axial_stretch"], float) - 1.0
    return np.asarray(path["bend_angle"], float) / n


def bend_of(r: object) -> np.ndarray:
    """A model path's end rotation per cell (κ × cell length)."""
    return np.asarray(r.path.curvature, float) * float(r.length)


if __name__ == "__main__":
    main()
