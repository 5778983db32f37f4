"""Build (or resume) the FE reference data set and write it into the package.

    python -m multimorph.calibrated.build_dataset [--sets grid24 stretching twisting bending]
        [--work dataset] [--workers 2] [--export-every 300] [--limit N] [--refine] [--check]

Each set is a ``multimorph sweep`` (``fe`` backend, Dask LocalCluster, resumable) into
``<work>/<set>/``. Before a set runs, its sweep folder is seeded with the designs the
shipped archive already holds (same spec hash), so a fresh machine resumes from what is
committed, not from scratch. While a set runs, the archive
(``multimorph/calibrated/data/fe_reference.npz`` and its ``.json`` manifest) is rewritten
every ``--export-every`` seconds and at the end. Progress goes to stderr as plain lines.
Interrupt it at any time (Ctrl-C, SIGKILL, the end of a session): the same command resumes.
``--refine`` then traces again, with finer continuation steps, the paths of a set whose
Pc is where the continuation turned round (:mod:`multimorph.calibrated._refine`), into
``<work>/<set>/refined/``, and lays them over the originals in the archive.
``--check`` prints what the archive and the work folders hold and exits.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from multimorph.calibrated._dataset import (
    REFERENCE_SETS,
    ReferenceSet,
    collect_set,
    load_reference,
    records_of,
    reference_spec,
    write_reference,
)

ORDER = ("grid24", "yeoh", "bending_narrow", "stretching_narrow", "bending_single",
         "bending_single2",
         "stretching", "twisting", "bending", "stretching_mirror", "stretching_narrow_mirror",
         "bending_single2_mirror", "grid24_mirror", "yeoh_mirror", "bending_mirror",
         "bending_single_mirror", "bending_narrow_mirror", "twisting2", "stretching2_mirror",
         "twisting_narrow", "twisting3", "bending_lowjm_mirror",
         "bending2_mirror", "bending3_mirror", "bending_softbottom_mirror", "yeoh2_mirror",
         "yeoh_stretching_mirror", "yeoh_twisting", "yeoh3_mirror", "bending_lowbt_mirror",
         "bending_single3_mirror")


def _log(msg: str) -> None:
    print(f"[{time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def _shipped() -> dict[str, ReferenceSet]:
    try:
        return dict(load_reference())
    except Exception:  # no archive yet
        return {}


def seed(set_name: str, folder: Path, shipped: dict[str, ReferenceSet]) -> int:
    """Write the shipped designs of ``set_name`` into the sweep folder (those it lacks)."""
    from multimorph.sweep import SweepStore

    ref = shipped.get(set_name)
    spec = reference_spec(set_name)
    if ref is None or ref.spec_hash != spec.spec_hash or not len(ref):
        return 0
    store = SweepStore(folder, spec, spec.design_table())
    with store.locked():
        store.prepare()
        have = set(store.finished().tolist())
        idx, recs = records_of(ref)
        new = [(i, r) for i, r in zip(idx, recs, strict=True) if i not in have]
        for i, r in new:
            store.write_part([i], [r])
    return len(new)


def export(work: Path, shipped: dict[str, ReferenceSet]) -> dict[str, ReferenceSet]:
    """Rewrite the archive from the work folders (and shipped sets not run here)."""
    sets = {}
    for name in REFERENCE_SETS:
        folder = work / name
        got = collect_set(name, folder) if (folder / "parts").is_dir() else None
        if got is None and name in shipped:
            got = shipped[name]
        if got is not None:
            sets[name] = got
    if sets:
        write_reference(sets)
    return sets


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", nargs="+", default=list(ORDER), choices=list(REFERENCE_SETS))
    ap.add_argument("--work", default="dataset", help="folder of the sweep folders")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--export-every", type=float, default=300.0, help="seconds")
    ap.add_argument("--limit", type=int, default=None,
                    help="run at most this many pending designs of each set in this pass")
    ap.add_argument("--refine", action="store_true",
                    help="then trace again, with finer steps, the paths that end where the "
                         "continuation turned round")
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--retry-failed", action="store_true",
                    help="evaluate designs that failed in an earlier run again")
    args = ap.parse_args(argv)
    work = Path(args.work)
    shipped = _shipped()
    if args.check:
        for name in REFERENCE_SETS:
            spec = reference_spec(name)
            ref = shipped.get(name)
            folder = work / name
            run = collect_set(name, folder) if (folder / "parts").is_dir() else None
            print(f"{name:10s} spec {spec.spec_hash[:12]}: {spec.n_designs} designs; archive "
                  f"{len(ref) if ref else 0} finished ({int(ref.ok.sum()) if ref else 0} ok)"
                  f"; work folder {len(run) if run else 0} finished"
                  f"{_refined_note(ref)}")
        return 0
    from multimorph.sweep import run_sweep

    for name in args.sets:
        folder = work / name
        n = seed(name, folder, shipped)
        if n:
            _log(f"{name}: seeded {n} finished designs from the shipped archive")
        last = [time.monotonic()]
        t0 = time.monotonic()

        def progress(done: int, total: int, name: str = name, t0: float = t0,
                     last: list[float] = last) -> None:
            el = time.monotonic() - t0
            _log(f"{name}: {done}/{total} designs this run, {el / 60:.1f} min")
            if time.monotonic() - last[0] > args.export_every:
                last[0] = time.monotonic()
                export(work, shipped)
                _log("archive rewritten")

        summary = run_sweep(reference_spec(name), folder, workers=args.workers,
                            progress=progress, limit=args.limit,
                            retry_failed=args.retry_failed)
        _log(f"{name}: {summary.n_ok} ok, {summary.n_failed} failed, {summary.n_invalid} "
             f"invalid of {summary.n_designs}; this run {summary.n_run} in "
             f"{summary.elapsed / 60:.1f} min")
        export(work, shipped)
        _log("archive rewritten")
        if args.refine:
            refine(name, folder, args.workers, work, shipped)
    return 0


def _refined_note(ref: ReferenceSet | None) -> str:
    if ref is None:
        return ""
    notes = [m["refinement"] for m in ref.meta if "refinement" in m]
    if not notes:
        return ""
    moved = sum(1 for x in notes
                if "error" not in x and "kept" not in x and not x.get("turned_again"))
    return f"; {len(notes)} refined ({moved} passed their old end)"


def refine(name: str, folder: Path, workers: int, work: Path,
           shipped: dict[str, ReferenceSet]) -> None:
    """Trace again the set's paths that end where the continuation turned round."""
    from multimorph.calibrated._refine import candidates, refine_set

    ref = collect_set(name, folder)
    if ref is None or not candidates(ref):
        _log(f"{name}: no path to refine")
        return
    t0 = time.monotonic()

    def progress(done: int, total: int) -> None:
        _log(f"{name}: refined {done}/{total}, {(time.monotonic() - t0) / 60:.1f} min")
        if done:
            export(work, shipped)
            _log("archive rewritten")

    summary = refine_set(reference_spec(name), ref, folder, workers=workers,
                         progress=progress)
    export(work, shipped)
    got = collect_set(name, folder)
    _log(f"{name}: refined {summary.n_run} paths in {summary.elapsed / 60:.1f} min "
         f"({summary.n_failed} failed){_refined_note(got)}; archive rewritten")


if __name__ == "__main__":
    raise SystemExit(main())
