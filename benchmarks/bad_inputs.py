"""Run the bad-input corpus through the real command line and classify every outcome.

The reproduction of issue 20: each case of ``tests/bad_inputs/cases.py`` (one mutation of a
shipped example or data file) runs as a separate ``multimorph`` process with the real model,
in its own folder, under a memory limit and a time limit, and is classified as

``clean``
    exit 2 (or the case's documented code), exactly one line on stderr that contains the
    field, option or file and line the case names, no traceback, nothing written;
``vague``
    refused without a traceback, but the message does not name the field, or takes more
    than one line, or the exit code is not the documented one;
``traceback``
    a Python traceback on stderr;
``silent``
    exit 0: the bad input was accepted (and a result written);
``killed``
    killed by a signal or by the memory limit (MemoryError);
``timeout``
    still running at the time limit (the bad input was accepted and is being computed);
``files-left``
    refused, but something was written (the run folder is not as before).

Two more cases are valid inputs answered wrongly before (issue 20, item 1): traced to a
pressure below the real Pc, the JSON must give Pc as ``null``; ``clean`` when it does,
``silent`` when it reports a number.

Two ways to run:

``--mode in-process`` (default, minutes)
    one Python process imports ``multimorph`` from ``--src`` once and runs every case through
    its console entry point (``multimorph.cli.main``) with the models replaced by a stub that
    raises: reaching a model on bad input is ``silent`` (the input was accepted and the
    computation would start), an exception escaping the command is ``traceback``, a
    MemoryError (address space limited to ``--memory-gb``) is ``killed``. The two result
    cases run the real reduced model.
``--mode subprocess`` (hours on a busy machine)
    every case is a fresh ``multimorph`` process with the real model, a memory limit and
    ``--timeout``; it shows what a user sees, time included (a run refused only after its
    computation is ``clean`` here but slow: see the seconds in ``--json``).

Usage::

    python benchmarks/bad_inputs.py [--src SRC] [--mode in-process|subprocess] [-j 2]
        [--timeout 300] [--only cell/] [--json results.json]

``--src`` is the ``src`` folder whose ``multimorph`` to run (default: this checkout's), so
the same corpus measures an older commit: ``git archive <commit> src | tar -x -C /tmp/old``
then ``--src /tmp/old/src``. Counts and timings are in ``benchmarks/README.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from bad_inputs.cases import Case, all_cases, prepare, snapshot  # noqa: E402

OUTCOMES = ("clean", "vague", "traceback", "silent", "killed", "timeout", "files-left")

_MAIN = "from multimorph.cli import main; main()"
_HOLD = """
import sys, time
from multimorph.io import claim_output
with claim_output(sys.argv[1]):
    print("held", flush=True)
    time.sleep(600)
"""


def _no_pc(doc: dict) -> bool:
    mods = doc.get("modules")
    if mods is None:
        return doc.get("critical_pressure", 0) is None
    return all(m.get("critical_pressure", 0) is None for m in mods.values())


#: Inputs that are valid but were answered wrongly (issue 20, item 1): the run must succeed
#: and its JSON must say "not reached" (null) for a Pc above the traced range.
RESULT_CASES = (
    Case("cell/result/pc-above-pmax", "cell", "result",
         ("cell", "{spec}", "--pmax", "60 kPa", "--json", "--out", "{out}"), "",
         (("cell.toml", (ROOT / "examples" / "cell.toml").read_bytes()),), code=0),
    Case("simulate/result/pc-above-pmax", "simulate", "result",
         ("simulate", "{spec}", "--pmax", "60 kPa", "--json", "--frames", "0", "--out",
          "{out}"), "",
         (("jar.toml", (ROOT / "examples" / "jar_lifter.toml").read_bytes()),), code=0),
)


def classify(case: Case, rc: int | None, err: str, changed: bool, out: str = "") -> str:
    """The outcome of one run (see the module docstring)."""
    if rc is None:
        return "timeout"
    if rc < 0 or "MemoryError" in err:
        return "killed"
    if "Traceback (most recent call last)" in err:
        return "traceback"
    if case.kind == "result":
        try:
            ok = rc == 0 and _no_pc(json.loads(out))
        except ValueError:
            ok = False
        return "clean" if ok else ("silent" if rc == 0 else "vague")
    if rc == 0:
        return "silent"
    if changed:
        return "files-left"
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if rc == case.code and len(lines) == 1 and case.expect in lines[0]:
        return "clean"
    return "vague"


def _limit_memory(limit: int) -> None:
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))


def run_case(case: Case, src: Path, timeout: float, memory: int) -> dict[str, object]:
    """Run one case in a fresh folder; its outcome, exit code, stderr and time."""
    folder = Path(tempfile.mkdtemp(prefix="mm-bad-"))
    env = {**os.environ, "PYTHONPATH": str(src), "COLUMNS": "200", "NO_COLOR": "1"}
    holder = None
    try:
        argv, out = prepare(case, folder)
        if case.setup == "locked":
            holder = subprocess.Popen([sys.executable, "-c", _HOLD, str(out)], env=env,
                                      stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                      text=True)
            holder.stdout.readline()  # "held", or "" when this version has no lock
        if case.setup == "out-readonly" and os.geteuid() == 0:
            return {"id": case.id, "outcome": "skipped", "rc": None,
                    "stderr": "root ignores permissions", "seconds": 0.0}
        before = snapshot(folder)
        t0 = time.perf_counter()
        try:
            proc = subprocess.run([sys.executable, "-c", _MAIN, *argv], cwd=folder,
                                  env=env, capture_output=True, text=True, timeout=timeout,
                                  preexec_fn=lambda: _limit_memory(memory))
            rc, err, stdout = proc.returncode, proc.stderr, proc.stdout
        except subprocess.TimeoutExpired as exc:
            rc, stdout = None, ""
            err = exc.stderr.decode() if isinstance(exc.stderr, bytes) else (exc.stderr or "")
        seconds = time.perf_counter() - t0
        changed = snapshot(folder) != before
        return {"id": case.id, "outcome": classify(case, rc, err, changed, stdout), "rc": rc,
                "stderr": err.strip()[-2000:], "seconds": round(seconds, 2)}
    finally:
        if holder is not None:
            holder.kill()
            holder.wait()
        for p in folder.rglob("*"):
            if p.is_dir():
                p.chmod(0o755)
        shutil.rmtree(folder, ignore_errors=True)


class ModelRan(Exception):
    """A model was called: the bad input was accepted (in-process mode)."""


def _stub_models() -> list[tuple[object, str, object]]:
    """Replace the models by a stub that raises :class:`ModelRan`; returns what to restore."""
    import importlib

    def ran(*args: object, **kwargs: object) -> None:
        raise ModelRan

    saved = []
    for module, name in (("multimorph.rom", "solve_cell"),
                         ("multimorph.device._simulate", "default_cell_model"),
                         ("multimorph.design", "design"),
                         ("multimorph.materials", "fit_material"),
                         ("multimorph.sweep._run", "_run_local"),
                         ("multimorph.sweep._run", "_run_distributed")):
        mod = importlib.import_module(module)
        saved.append((mod, name, getattr(mod, name)))
        setattr(mod, name, ran)
    return saved


def run_in_process(case: Case) -> dict[str, object]:
    """Run one case through ``multimorph.cli.main`` in this process (see the docstring)."""
    import contextlib
    import io
    import traceback

    from multimorph.cli import main as cli_main

    folder = Path(tempfile.mkdtemp(prefix="mm-bad-"))
    here = os.getcwd()
    try:
        argv, out = prepare(case, folder)
        if case.setup == "out-readonly" and os.geteuid() == 0:
            return {"id": case.id, "outcome": "skipped", "rc": None,
                    "stderr": "root ignores permissions", "seconds": 0.0}
        hold: contextlib.AbstractContextManager[object] = contextlib.nullcontext()
        if case.setup == "locked":
            try:
                from multimorph.io import claim_output
            except ImportError:  # this version has no lock: nobody is told
                pass
            else:
                hold = claim_output(out)
        before = snapshot(folder)
        os.chdir(folder)
        err, std = io.StringIO(), io.StringIO()
        t0 = time.perf_counter()
        rc: int | None = 0
        outcome = None
        with hold, contextlib.redirect_stdout(std), contextlib.redirect_stderr(err):
            sys.argv = ["multimorph", *argv]
            try:
                cli_main()
            except SystemExit as exc:
                rc = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            except ModelRan:
                outcome = "silent"
            except MemoryError:
                outcome = "killed"
            except BaseException:  # what a user would see as a traceback
                traceback.print_exc()
                rc = 1
        seconds = time.perf_counter() - t0
        os.chdir(here)
        changed = snapshot(folder) != before
        text = err.getvalue()
        if outcome is None:
            outcome = classify(case, rc, text, changed, std.getvalue())
        return {"id": case.id, "outcome": outcome, "rc": rc, "stderr": text.strip()[-2000:],
                "seconds": round(seconds, 2)}
    finally:
        os.chdir(here)
        for p in folder.rglob("*"):
            if p.is_dir():
                p.chmod(0o755)
        shutil.rmtree(folder, ignore_errors=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--src", type=Path, default=ROOT / "src")
    ap.add_argument("--mode", choices=("in-process", "subprocess"), default="in-process")
    ap.add_argument("-j", "--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=300.0)
    ap.add_argument("--memory-gb", type=float, default=6.0)
    ap.add_argument("--only", default="", help="run only the cases whose id starts so")
    ap.add_argument("--no-results", action="store_true",
                    help="leave out the two result cases (they run the real model)")
    ap.add_argument("--json", type=Path, help="write every result to this file")
    args = ap.parse_args(argv)
    cases = [c for c in (*all_cases(), *(() if args.no_results else RESULT_CASES))
             if c.id.startswith(args.only)]
    memory = int(args.memory_gb * 2**30)
    t0 = time.perf_counter()
    if args.mode == "in-process":
        sys.path.insert(0, str(args.src.resolve()))
        import multimorph

        if not Path(multimorph.__file__).resolve().is_relative_to(args.src.resolve()):
            raise SystemExit(f"multimorph came from {multimorph.__file__}, not {args.src}")
        _limit_memory(memory)
        bad = [c for c in cases if c.kind != "result"]
        good = [c for c in cases if c.kind == "result"]
        saved = _stub_models()
        results = [run_in_process(c) for c in bad]
        for mod, name, value in saved:  # the result cases run the real model
            setattr(mod, name, value)
        results += [run_in_process(c) for c in good]
        cases = bad + good
    else:
        with ThreadPoolExecutor(args.jobs) as pool:
            results = list(pool.map(lambda c: run_case(c, args.src, args.timeout, memory),
                                    cases))
    for r in results:
        if r["outcome"] != "clean":
            tail = str(r["stderr"]).splitlines()[-1:] or [""]
            print(f"{r['outcome']:>10}  {r['id']}  rc={r['rc']}  {tail[0][:150]}")
    counts = Counter(str(r["outcome"]) for r in results)
    print(f"tried {len(results)}: " + ", ".join(f"{k} {counts.get(k, 0)}" for k in OUTCOMES)
          + (f", skipped {counts['skipped']}" if counts.get("skipped") else "")
          + f" ({time.perf_counter() - t0:.0f} s)")
    per: dict[str, Counter[str]] = {}
    for c, r in zip(cases, results, strict=True):
        per.setdefault(c.command, Counter())[str(r["outcome"])] += 1
    for cmd, cnt in per.items():
        print(f"  {cmd:<13} " + ", ".join(f"{k} {v}" for k, v in sorted(cnt.items())))
    if args.json:
        args.json.write_text(json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
