"""Benchmark: wall time and model evaluations of a two-stage inverse design (issue 6).

Run from the repository root (prints a table; ``--json`` for machines)::

    python benchmarks/bench_design.py                        # gripper target, default budget
    python benchmarks/bench_design.py --target examples/target_jar_lifter.toml --budget 800

Rows:

- ``warm-up``: one batched call of the reduced model at the optimiser's batch shape (JIT
  compilation of the vmapped path tracer; paid once per process, and per batch shape), and
  one path sensitivity of each stage's cell (JIT of the IFT kernel of the gradient stage);
- ``design``: the whole search (reachability check, differential evolution, gradient
  refinement, compass search) after the warm-up, with the number of cell-model evaluations
  and batched calls, and the time spent in each phase;
- ``robustness``: the Monte Carlo of the best design (``--samples`` samples).

The target of issue 6 is a two-stage design in under 60 s on this 2-core machine; the
compilation is reported separately because a long-running session pays it once.
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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--target", default=str(ROOT / "examples" / "target_gripper.toml"))
    ap.add_argument("--budget", type=int, default=1200)
    ap.add_argument("--population", type=int, default=24)
    ap.add_argument("--samples", type=int, default=64)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--vectorised", action="store_true",
                    help="vmapped ROM batches (default: loop of single-design traces)")
    ap.add_argument("--no-graded", dest="graded", action="store_false",
                    help="one module per stage (default: wide bands become graded parts)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)

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
