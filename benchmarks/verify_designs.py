"""Benchmark: the shipped design targets designed and checked in 3D FE (issue 19).

Run from the repository root (prints a table; ``--json`` for machines)::

    python benchmarks/verify_designs.py                           # every examples/target_*.toml
    python benchmarks/verify_designs.py --targets jar_lifter --fe-rounds 2
    python benchmarks/verify_designs.py --table-only              # the table of what is there
    python benchmarks/verify_designs.py --table-only --publish    # verified -> examples/designed

Each target runs as a user runs it: ``multimorph design examples/target_<name>.toml
--fe-rounds N --out benchmarks/runs/verify/<name>`` (default seed, the calibrated model, the
``modules`` FE route; another ``--seed N`` runs into ``<name>-seedN``). Its FE runs are
kept in ``benchmarks/runs/verify/<name>.fe`` (commit
them: the next run re-uses every finished module, and an interrupted one resumes from its
saved points). The table gives, per target, FE round and stage: the wanted start and end
pressure and magnitude, the calibrated model's and the FE's, and whether the round's FE
meets the target (pressures within the target's pressure tolerance, magnitudes within its
magnitude tolerance, the stage order kept).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RUNS = ROOT / "benchmarks" / "runs" / "verify"


def _kpa(v: float | None) -> str:
    return "—" if v is None else f"{v / 1e3:.1f}"


def _mag(kind: str, v: float | None) -> str:
    if v is None:
        return "—"
    return f"{100 * v:.0f} %" if kind == "stretch" else f"{v * 57.29577951308232:.0f}°"


def run_name(name: str, seed: int) -> str:
    """The run folder of a target and seed: ``<name>`` for seed 0 (the default), else
    ``<name>-seed<N>`` (so another seed's run does not replace seed 0's)."""
    return name if seed == 0 else f"{name}-seed{seed}"


def rows_of(name: str, seed: int = 0) -> list[dict[str, Any]]:
    """The per-stage rows of every FE round of a finished run's report.json."""
    name = run_name(name, seed)
    report = RUNS / name / "report.json"
    if not report.exists():
        return []
    r = json.loads(report.read_text())
    out = []
    for rd in r.get("fe_rounds", []):
        for st in rd["stages"]:
            out.append({"target": name, "round": rd["round"], "stage": st["name"],
                        "kind": st["kind"], "wanted": st["wanted"],
                        "model": st["search_model"], "fe": st["check_model"],
                        "meets": rd["meets_targets"]})
    return out


def run(name: str, fe_rounds: int, seed: int) -> dict[str, Any]:
    out = RUNS / run_name(name, seed)
    cmd = [sys.executable, "-m", "multimorph.cli", "design",
           str(ROOT / "examples" / f"target_{name}.toml"), "--fe-rounds", str(fe_rounds),
           "--seed", str(seed), "--out", str(out), "--json"]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if proc.returncode not in (0, 3):
        print(proc.stderr[-2000:], file=sys.stderr)
        return {"target": name, "ok": False, "wall_time_s": dt, "exit": proc.returncode}
    report = json.loads(proc.stdout)
    return {"target": name, "ok": True, "wall_time_s": dt, "feasible": report["feasible"],
            "fe_verified": report.get("fe_verified"), "fe_route": report.get("fe_route"),
            "fe_rounds": len(report.get("fe_rounds", []))}


DESIGNED = ROOT / "examples" / "designed"
#: The device example each target's verified design becomes (issue 19).
EXAMPLE_OF = {"gripper": "gripper", "jar_lifter": "jar_lifter",
              "double_curvature": "double_curvature"}


def publish(name: str, seed: int = 0) -> list[Path]:
    """Copy an FE-verified run into ``examples/designed``: ``<name>.toml`` (the device, its
    header saying how it was designed and verified), ``<name>.fe.json`` (the FE
    verification: every round, model vs FE per stage) and ``<name>.fe.png``; and, for a
    reference device, make ``examples/<example>.toml`` that design where the calibrated
    model keeps its stage order (the examples are held to the model; a design the FE
    verified through a corrected model may sit a per cent on the other side of a hand-over
    on the model alone). Nothing for a run that is not FE-verified."""
    run_dir = RUNS / run_name(name, seed)
    report_file = run_dir / "report.json"
    if not report_file.exists():
        return []
    r = json.loads(report_file.read_text())
    # the device this run wrote (its report lists it), never one an earlier run left
    if not r.get("fe_verified") or "device.toml" not in r.get("files", []):
        return []
    DESIGNED.mkdir(parents=True, exist_ok=True)
    rounds = r.get("fe_rounds", [])
    lines = [f"# FE-verified design of examples/target_{name}.toml (issue 19).",
             f"# Designed on the {r.get('model')} cell model (seed {r.get('seed')}), then "
             f"checked in 3D FE: route {r.get('fe_route')}"
             + (f", twisting modules by {r.get('fe_twist')}"
                if r.get("fe_twist") and any(st.get("kind") == "twist" for rd in
                                             r.get("fe_rounds", [])
                                             for st in rd.get("stages", [])) else "")
             + f"; {len(rounds)} FE round(s). Per stage, wanted / model / FE "
             "(benchmarks/verify_designs.py):"]
    last = rounds[-1] if rounds else None
    for st in (last or {}).get("stages", []):
        w, m, f = st["wanted"], st["search_model"], st["check_model"]
        lines.append(f"#   {st['name']}: Pc {_kpa(w['start_pressure'])} / "
                     f"{_kpa(m['start_pressure'])} / {_kpa(f['start_pressure'])} kPa, "
                     f"Ph {_kpa(w['end_pressure'])} / {_kpa(m['end_pressure'])} / "
                     f"{_kpa(f['end_pressure'])} kPa, motion {_mag(st['kind'], w['magnitude'])}"
                     f" / {_mag(st['kind'], m['magnitude'])} / {_mag(st['kind'], f['magnitude'])}")
    order = model_order(run_dir / "device.toml")
    wanted = [st["name"] for st in r.get("stages", [])]
    if order != wanted:
        lines.append(f"# On the calibrated model alone the stages come in the order "
                     f"{' → '.join(order)}: the FE corrected the model (space mapping), and "
                     "the hand-over sits within the model's error of it; FE has them in the "
                     "target's order.")
    body = (run_dir / "device.toml").read_text()
    text = "\n".join(lines) + "\n" + body
    out = [DESIGNED / f"{name}.toml", DESIGNED / f"{name}.fe.json"]
    out[0].write_text(text)
    keep = {k: r.get(k) for k in ("target", "model", "seed", "fe_verified", "fe_route",
                                  "fe_twist", "fe_rounds", "fe", "tolerance")}
    out[1].write_text(json.dumps(keep, indent=1) + "\n")
    if (run_dir / "fe_verification.png").exists():
        out.append(DESIGNED / f"{name}.fe.png")
        out[-1].write_bytes((run_dir / "fe_verification.png").read_bytes())
    if name in EXAMPLE_OF:
        if order == wanted:
            example = ROOT / "examples" / f"{EXAMPLE_OF[name]}.toml"
            example.write_text(f"# The FE-verified design of examples/target_{name}.toml: "
                               f"examples/designed/{name}.toml (its header has the FE "
                               "table).\n" + text)
            out.append(example)
        else:
            print(f"{name}: examples/{EXAMPLE_OF[name]}.toml kept: on the calibrated model "
                  f"the FE-verified design's stages come in the order {' → '.join(order)}, "
                  f"not {' → '.join(wanted)} (an example is held to the model: "
                  "tests/test_device_examples.py)", file=sys.stderr)
    return out


def model_order(device_file: Path) -> list[str]:
    """The stage order (modules by Pc) of a device on the calibrated model, as
    ``multimorph simulate --model calibrated`` gives it."""
    from multimorph.device import device_from_spec, simulate_device
    from multimorph.io import load_toml
    from multimorph.models import cell_model

    device = device_from_spec(load_toml(device_file))
    return list(simulate_device(device, cell_model=cell_model("calibrated")).sequence.order)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--targets", default="", help="comma-separated target names")
    ap.add_argument("--fe-rounds", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--table-only", action="store_true")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--publish", action="store_true",
                    help="copy every FE-verified design into examples/designed (and make the "
                         "reference device examples those designs)")
    args = ap.parse_args(argv)
    names = (args.targets.split(",") if args.targets else
             sorted(p.stem.removeprefix("target_") for p in
                    (ROOT / "examples").glob("target_*.toml")))
    runs = [] if args.table_only else [run(n, args.fe_rounds, args.seed) for n in names]
    rows = [row for n in names for row in rows_of(n, args.seed)]
    published = {n: [str(p.relative_to(ROOT)) for p in publish(n, args.seed)] for n in names} \
        if args.publish else {}
    if args.json:
        print(json.dumps({"runs": runs, "rows": rows, "published": published}, indent=2))
        return 0
    for r in runs:
        print(f"{r['target']}: " + (f"exit {r['exit']}" if not r["ok"] else
              f"designed {'feasible' if r['feasible'] else 'INFEASIBLE'}, "
              f"{'FE-verified' if r['fe_verified'] else 'NOT FE-verified'} after "
              f"{r['fe_rounds']} FE round(s) ({r['fe_route']} route), "
              f"{r['wall_time_s'] / 60:.1f} min"))
    for n, files in published.items():
        print(f"{n}: " + (f"published {', '.join(files)}" if files else
                          "not FE-verified: nothing published"))
    print(f"{'target':<17} {'rnd':>3} {'stage':<9} {'Pc want/model/FE (kPa)':>24} "
          f"{'Ph want/model/FE (kPa)':>24} {'motion want/model/FE':>22} FE meets")
    for r in rows:
        w, m, f = r["wanted"], r["model"], r["fe"]
        pc = f"{_kpa(w['start_pressure'])}/{_kpa(m['start_pressure'])}/{_kpa(f['start_pressure'])}"
        ph = f"{_kpa(w['end_pressure'])}/{_kpa(m['end_pressure'])}/{_kpa(f['end_pressure'])}"
        mg = (f"{_mag(r['kind'], w['magnitude'])}/{_mag(r['kind'], m['magnitude'])}/"
              f"{_mag(r['kind'], f['magnitude'])}")
        print(f"{r['target']:<17} {r['round']:>3} {r['stage']:<9} {pc:>24} {ph:>24} "
              f"{mg:>22} {'yes' if r['meets'] else 'no'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
