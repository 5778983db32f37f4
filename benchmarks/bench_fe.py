"""Benchmark: a full FE unit-cell path (ballooning into hardening) on this machine.

Prints a table: DOF, path points, Newton iterations per point, cutbacks, total time, time in
assembly vs linear solve, the solver used. The default case is the reference cell (20 × 10 ×
8 mm, 1 mm top wall, Gent walls μ = 100 kPa, Jm = 30, a 10× stiffer bottom layer), half
model, inflated to P = 0.5 μ (pressure steps, then arc-length continuation past the stall).

    python benchmarks/bench_fe.py                      # fine mesh (~10k DOF), auto solver
    python benchmarks/bench_fe.py --mesh coarse medium fine --solver pardiso superlu
    python benchmarks/bench_fe.py --chord 0 1e-3           # without / with chord steps

Columns: free DOF, converged points, Newton iterations (and per point), cutbacks, numerical
factorisations, chord steps (continuation iterations on the previous iterate's tangent),
wall time, shares of assembly and linear solve, Pc and Ph.
"""

from __future__ import annotations

import argparse
import itertools
import time

from multimorph.fe import FESettings, simulate_cell
from multimorph.fe.engine import pardiso_available
from multimorph.geometry import CellGeometry
from multimorph.materials import Material

MU = 1.0e5


def reference_cell() -> CellGeometry:
    return CellGeometry(20e-3, 10e-3, 8e-3, 1e-3, 2e-3, 2e-3, 2e-3,
                        material=Material("gent", {"mu": MU, "jm": 30.0}),
                        bottom_material=Material("gent", {"mu": 10 * MU, "jm": 30.0}))


def run(mesh: str, solver: str, chord: float) -> dict[str, object]:
    t = time.perf_counter()
    r = simulate_cell(reference_cell(), FESettings(mesh=mesh, p_max=0.5 * MU, solver=solver,
                                                   chord=chord))
    wall = time.perf_counter() - t
    s = r.stats
    c = r.response.characteristic
    return {
        "mesh": mesh, "dof": s["nfree"], "points": s["points"],
        "newton": s["newton_iterations"], "its/pt": s["newton_iterations"] / s["points"],
        "cutbacks": s["cutbacks"], "fact": s["factorisations"], "chord": s["chord_steps"],
        "time": wall, "assembly": s["assembly_time"] / wall,
        "solve": s["solve_time"] / wall, "solver": s["solver"],
        "Pc/mu": (c.critical or float("nan")) / MU, "Ph/mu": (c.hardening or float("nan")) / MU,
        "status": s["stop_reason"] or s["status"],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mesh", nargs="+", default=["fine"])
    ap.add_argument("--solver", nargs="+", default=["auto"])
    ap.add_argument("--chord", nargs="+", type=float, default=[1e-3],
                    help="chord ratios (FESettings.chord); 0 assembles every tangent")
    args = ap.parse_args()
    print(f"pypardiso available: {pardiso_available()}")
    head = (f"{'mesh':7} {'DOF':>6} {'pts':>4} {'Newton':>6} {'its/pt':>6} {'cut':>4} "
            f"{'fact':>5} {'chord':>5} {'time s':>7} {'asm %':>6} {'solve %':>7} "
            f"{'Pc/mu':>6} {'Ph/mu':>6}  solver")
    print(head)
    print("-" * len(head))
    for mesh, solver, chord in itertools.product(args.mesh, args.solver, args.chord):
        r = run(mesh, solver, chord)
        print(f"{r['mesh']:7} {r['dof']:6d} {r['points']:4d} {r['newton']:6d} "
              f"{r['its/pt']:6.1f} {r['cutbacks']:4d} {r['fact']:5d} {r['chord']:5d} "
              f"{r['time']:7.1f} {100 * r['assembly']:6.0f} {100 * r['solve']:7.0f} "
              f"{r['Pc/mu']:6.3f} {r['Ph/mu']:6.3f}  {r['solver']} ({r['status']})", flush=True)


if __name__ == "__main__":
    main()
