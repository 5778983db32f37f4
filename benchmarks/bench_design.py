"""Benchmark: inverse design of every shipped target, seeds 0-4 (issue 19), and the
wall time of one Ritz design in detail (issue 6).

Run from the repository root (prints a table; ``--json`` for machines)::

    python benchmarks/bench_design.py                     # every examples/target_*.toml, seeds 0-4
    python benchmarks/bench_design.py --seeds 0 --targets gripper,jar_lifter
    python benchmarks/bench_design.py --model ritz --target examples/target_gripper.toml

Default (``--model calibrated``, what ``multimorph design`` runs): the search on the fast
calibrated variant inside the calibrated box, its best designs scored by the calibrated
model and the targets corrected by space mapping (``--rounds``). One row per target and
seed: met or not (by the calibrated model), wall time, search evaluations, calibrated
evaluations, rounds. The warm-up row (loading the model, the first calibrated call:
compiling the Ritz tracer the calibrated features need, cached on disk for later
processes) is paid once per process and reported apart. The target is: every row met,
each ≤ 60 s on the 2-core machine.

``--model ritz``: the old detail of one search on the reduced model (rows ``warm-up``,
``design`` with its phases, ``robustness``).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def targets_table(args: argparse.Namespace) -> int:
    """Every shipped target × seeds on the calibrated model (the CLI's default design)."""
    from multimorph.design import (
        GRADED_RATIO_CALIBRATED,
        DesignSettings,
        run_design,
        target_from_spec,
    )
    from multimorph.io import load_toml
    from multimorph.models import batch_model

    names = (args.targets.split(",") if args.targets else
             sorted(p.stem.removeprefix("target_") for p in
                    (ROOT / "examples").glob("target_*.toml")))
    seeds = [int(s) for s in args.seeds.split(",")]
    model = batch_model(args.model, fallback=False)
    search = (batch_model("calibrated-fast", fallback=False) if args.model == "calibrated"
              else None)
    # warm-up: the model files, the fast variant and the Ritz tracer behind exact features
    t0 = time.perf_counter()
    spec = target_from_spec(load_toml(ROOT / "examples" / f"target_{names[0]}.toml"))
    from multimorph.design import SearchSpace

    fn = search if search is not None else model
    space = SearchSpace(spec, boxes=fn.support_boxes())
    import numpy as np

    cells = [c for x in np.random.default_rng(0).random((2, space.dim))
             for c in space.decode(x).cells]
    fn(cells, spec.constraints.max_pressure)
    if search is not None:
        model(cells, spec.constraints.max_pressure)
    t_warm = time.perf_counter() - t0
    rows = []
    for name in names:
        target = target_from_spec(load_toml(ROOT / "examples" / f"target_{name}.toml"))
        for seed in seeds:
            settings = DesignSettings(budget=args.budget, population=args.population,
                                      seed=seed, graded_ratio=GRADED_RATIO_CALIBRATED)
            t0 = time.perf_counter()
            run = run_design(target, settings, model=model, search_model=search,
                             rounds=args.rounds, robustness_samples=0)
            dt = time.perf_counter() - t0
            res = run.result
            rows.append({"target": name, "seed": seed, "met": bool(res.feasible),
                         "wall_time_s": dt, "search_evaluations": res.evaluations,
                         "rounds": max(len(res.rounds) - 1, 0),
                         "objective": None if res.best is None else res.best.objective,
                         "checked_designs": len(res.designs),
                         "why": [] if res.feasible else res.explanation[:3]})
            if not args.json:
                r = rows[-1]
                print(f"{name:<18} {seed:>4}  {'met' if r['met'] else 'NOT met':<8} "
                      f"{dt:7.1f}s {r['search_evaluations']:>8} {r['rounds']:>6}"
                      + ("" if r["met"] else "  " + "; ".join(r["why"])[:160]), flush=True)
    machine = f"{platform.machine()} {os.cpu_count()} cores, {platform.python_version()}"
    out = {"model": args.model, "search_model": "calibrated-fast" if search else args.model,
           "budget": args.budget, "population": args.population, "warmup_s": t_warm,
           "machine": machine, "rows": rows,
           "met": sum(r["met"] for r in rows), "runs": len(rows),
           "max_wall_time_s": max(r["wall_time_s"] for r in rows)}
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        print(f"met {out['met']}/{out['runs']}; slowest {out['max_wall_time_s']:.1f} s; "
              f"warm-up (once per process) {t_warm:.1f} s; {machine}")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="calibrated",
                    choices=("calibrated", "calibrated-fast", "ritz"))
    ap.add_argument("--targets", default="",
                    help="comma-separated target names (default: every examples/target_*.toml)")
    ap.add_argument("--seeds", default="0,1,2,3,4")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--target", default=str(ROOT / "examples" / "target_gripper.toml"),
                    help="--model ritz: the target of the detailed run")
    ap.add_argument("--budget", type=int, default=None,
                    help="default 4000 (calibrated), 1200 (ritz)")
    ap.add_argument("--population", type=int, default=None,
                    help="default 48 (calibrated), 24 (ritz)")
    ap.add_argument("--samples", type=int, default=64)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--vectorised", action="store_true",
                    help="vmapped ROM batches (default: loop of single-design traces)")
    ap.add_argument("--no-graded", dest="graded", action="store_false",
                    help="one module per stage (default: wide bands become graded parts)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    calibrated = args.model != "ritz"
    if args.budget is None:
        args.budget = 4000 if calibrated else 1200
    if args.population is None:
        args.population = 48 if calibrated else 24
    if calibrated:
        print(f"{'target':<18} {'seed':>4}  {'result':<8} {'time':>8} {'evals':>8} "
              f"{'rounds':>6}", flush=True) if not args.json else None
        return targets_table(args)

    import numpy as np

    from multimorph.design import (
        CountingModel,
        DesignSettings,
        SearchSpace,
        design,
        evaluate_population,
        graded_target,
        robustness,
        rom_batch_model,
        target_from_spec,
    )
    from multimorph.io import load_toml

    target = target_from_spec(load_toml(args.target))
    if len(target.stages) != 2:
        print(f"note: {args.target} has {len(target.stages)} stages", file=sys.stderr)
    settings = DesignSettings(budget=args.budget, population=args.population, seed=args.seed,
                              graded=args.graded)
    # the stages that are searched (a wide band becomes graded modules in series)
    space = SearchSpace(graded_target(target, settings.graded_ratio) if args.graded else target)
    model = CountingModel(rom_batch_model(args.vectorised),
                          pad_to=settings.population * space.n_stages)
    t0 = time.perf_counter()
    warm = evaluate_population(space, np.random.default_rng(0).random((settings.population,
                                                                       space.dim)), model)
    if settings.gradient:
        from multimorph.response import Response
        from multimorph.rom import path_sensitivity

        for ev in warm:
            if all(isinstance(r, Response) for r in ev.responses):
                for cell, r in zip(ev.candidate.cells, ev.responses, strict=True):
                    path_sensitivity(cell, r.path)
                break
    t_warm = time.perf_counter() - t0

    phases: dict[str, float] = {}
    clock = [time.perf_counter()]

    def progress(done: int, budget: int, phase: str) -> None:
        now = time.perf_counter()
        phases[phase] = phases.get(phase, 0.0) + now - clock[0]
        clock[0] = now

    t0 = clock[0] = time.perf_counter()
    result = design(target, model=model, settings=settings, progress=progress)
    t_design = time.perf_counter() - t0

    t_rob = None
    rob = None
    if result.best is not None and args.samples > 0:
        t0 = time.perf_counter()
        rob = robustness(result.target, result.best, n_samples=args.samples, seed=args.seed,
                         model=model)
        t_rob = time.perf_counter() - t0

    row = {
        "target": target.name,
        "modules": space.n_stages,
        "machine": f"{platform.machine()} {os.cpu_count()} cores, {platform.python_version()}",
        "warmup_s": t_warm,
        "design_s": t_design,
        "evaluations": result.evaluations,
        "model_calls": result.model_calls,
        "evaluations_per_s": result.evaluations / t_design if t_design > 0 else None,
        "feasible": result.feasible,
        "objective": None if result.best is None else result.best.objective,
        "phases_s": phases,
        "robustness_s": t_rob,
        "robustness_samples": args.samples,
        "p_order": None if rob is None else rob.p_order,
    }
    if args.json:
        print(json.dumps(row, indent=2))
        return 0
    print(f"{'what':<12} {'wall time':>10}  notes")
    print(f"{'warm-up':<12} {t_warm:9.1f}s  JIT of the batched ROM at the optimiser's shape")
    print(f"{'design':<12} {t_design:9.1f}s  {result.evaluations} cell evaluations in "
          f"{result.model_calls} batched calls ({row['evaluations_per_s']:.0f}/s); "
          f"feasible = {result.feasible}; {space.n_stages} modules searched")
    print(f"{'':<12} {'':>10}  phases: " + ", ".join(f"{k} {v:.1f}s" for k, v in phases.items())
          + (f"; best objective {row['objective']:.3g}" if row["objective"] is not None else ""))
    if t_rob is not None:
        print(f"{'robustness':<12} {t_rob:9.1f}s  {args.samples} Monte Carlo samples, "
              f"P(order holds) = {rob.p_order:.0%}")
    print(f"machine: {row['machine']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
