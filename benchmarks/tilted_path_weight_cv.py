"""The tilted cells' path weights by cross-validation: how far a tilted cell's reported Pc and
Ph should move from their anchors towards the path's own readings (``_anchor.PATH_WEIGHT``).

Run: python benchmarks/tilted_path_weight_cv.py [--folds 5] [--seed 59]
     [--weights 0 0.25 0.5 0.75 1] [--fixed-pc 0.25] [--fixed-ph 0.25]
     [--factors 2 3 5 1e9] [--straight current|v1]

The twisting kind's training designs are split into folds (a fixed seed). For each fold
the kind's fast variant (its path, pressure, signal, log-signal and anchor GPs) is refitted
in memory on the other folds' designs (``_fit._fit_one``, resumable through
``$MULTIMORPH_FIT_RESUME``, by default a folder under the system's temp dir), and every
design of the fold is answered through the whole chain (``CalibratedModel.responses``,
its straight cell from the shipped bending kind) with each weight in turn: Ph's weight
swept with Pc's at ``--fixed-pc``, then Pc's swept with Ph's at ``--fixed-ph``; with
``--factors``, the disagreement rule's factor instead (``_anchor.MAX_FACTOR_BY_KIND``: an
anchor further than it from the path's own reading is left out), both weights fixed. Prints
the median / p90 of |ΔPc|/Pc and |ΔPh|/Ph against the designs' FE per setting, and the
share of their curves within 10 % of FE's range as graphs. ``--straight v1`` fits the folds
on the straight-cell features of a model before stop 62 (``_fit.STRAIGHT_FEATURES_V1``)
instead of the current ones. Stop 59 chose 0.25 on both weights with it, stop 62 the factor
3 and the straight cell's signal and bottom strain as inputs (three ``--seed``s each way;
docs/validation.md §4). Under a minute once the fold fits are kept; the first run fits them
(about 15 s a fold on this machine).
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import tempfile
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--folds", type=int, default=5)
    ap.add_argument("--seed", type=int, default=59)
    ap.add_argument("--weights", type=float, nargs="+", default=[0.0, 0.25, 0.5, 0.75, 1.0])
    ap.add_argument("--fixed-pc", type=float, default=0.25)
    ap.add_argument("--fixed-ph", type=float, default=0.25)
    ap.add_argument("--factors", type=float, nargs="+", default=None,
                    help="sweep the disagreement factor (the weights fixed) instead")
    ap.add_argument("--straight", choices=("current", "v1"), default="current",
                    help="the straight-cell features the folds are fitted on")
    args = ap.parse_args()
    os.environ.setdefault("MULTIMORPH_FIT_RESUME",
                          str(Path(tempfile.gettempdir()) / "multimorph-tilted-cv"))

    from multimorph.calibrated import CalibrationWarning
    from multimorph.calibrated import _fit as fit
    from multimorph.calibrated._anchor import MAX_FACTOR_BY_KIND, PATH_WEIGHT
    from multimorph.calibrated._box import Box
    from multimorph.calibrated._dataset import load_reference, reference_spec
    from multimorph.calibrated._gp import MultiOutputGP
    from multimorph.calibrated._model import CalibratedModel, straight_of
    from multimorph.calibrated._validate import fe_response, graph_error
    from multimorph.calibrated.validate import at_end_of, requested_pressure

    warnings.simplefilter("ignore", CalibrationWarning)
    with np.load(fit.MODEL_FILE, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    manifest = json.loads(fit.MODEL_MANIFEST.read_text())
    # the fast variant's inputs, as `fit model` builds them
    emu = (MultiOutputGP.from_arrays(arrays, "emulator/bending/"),
           Box.from_spec("bending", reference_spec("bending")))
    data = fit.fe_training_data("twisting", load_reference())
    data = replace(data, features=fit.emulated_features(*emu, data.cells, data.features))
    names = fit.STRAIGHT_FEATURES if args.straight == "current" else fit.STRAIGHT_FEATURES_V1
    data = replace(data, straight=straight_of(arrays, manifest, data, True, names),
                   straight_names=tuple(names))
    usable = ~data.holdout & np.all(np.isfinite(fit.data_features(data)), axis=1)
    rows = np.flatnonzero(usable)
    fold = np.random.default_rng(args.seed).permutation(len(rows)) % args.folds
    fes = [fe_response(data.paths[r], data.cells[r], "twisting")
           for r in range(len(data.cells))]
    fe = [f.characteristic for f in fes]

    # each setting: (Pc's weight, Ph's weight, the disagreement factor)
    factor = MAX_FACTOR_BY_KIND.get("twisting")
    if args.factors:
        sweeps = [("factor", (args.fixed_pc, args.fixed_ph, f)) for f in args.factors]
    else:
        sweeps = [("Ph", (args.fixed_pc, w, factor)) for w in args.weights]
        sweeps += [("Pc", (w, args.fixed_ph, factor)) for w in args.weights]
    errors: dict[tuple[float, float, float | None], dict[str, list[float]]] = {
        pw: {"Pc": [], "Ph": [], "graph": []} for _, pw in sweeps}
    saved = PATH_WEIGHT.get("twisting")
    t0 = time.perf_counter()
    try:
        for f in range(args.folds):
            test = rows[fold == f]
            held = data.holdout.copy()
            held[test] = True
            arr, man = dict(arrays), copy.deepcopy(manifest)
            fit._fit_one("twisting", replace(data, holdout=held), "fast/", arr,
                         man["fast_kinds"])
            model = CalibratedModel(arr, man)
            for pw in errors:
                PATH_WEIGHT["twisting"] = pw[:2]
                if pw[2] is None:
                    MAX_FACTOR_BY_KIND.pop("twisting", None)
                else:
                    MAX_FACTOR_BY_KIND["twisting"] = pw[2]
                for r in test:
                    name, design = str(data.set_name[r]), int(data.design[r])
                    m, _ = at_end_of(model, "twisting", name)
                    resp = m.responses([data.cells[r]], requested_pressure(
                        name, design, data.paths[r]), fast=True)[0]
                    if isinstance(resp, Exception):
                        continue
                    ch = resp.characteristic
                    for key, a, b in (("Pc", ch.critical, fe[r].critical),
                                      ("Ph", ch.hardening, fe[r].hardening)):
                        if a is not None and b is not None and b > 0:
                            errors[pw][key].append(abs(a / b - 1.0))
                    g = graph_error(resp, fes[r], "twisting")
                    if np.isfinite(g):
                        errors[pw]["graph"].append(g)
            print(f"fold {f + 1}/{args.folds} done, {time.perf_counter() - t0:.0f} s",
                  flush=True)
    finally:
        if saved is None:
            PATH_WEIGHT.pop("twisting", None)
        else:
            PATH_WEIGHT["twisting"] = saved
        if factor is None:
            MAX_FACTOR_BY_KIND.pop("twisting", None)
        else:
            MAX_FACTOR_BY_KIND["twisting"] = factor

    def cell(v: list[float]) -> str:
        e = np.asarray(v)
        return f"{100 * np.median(e):.1f} / {100 * np.percentile(e, 90):.1f} % ({len(e)})"

    def share(v: list[float]) -> str:
        e = np.asarray(v)
        return f"{100 * np.mean(e <= 0.1):.1f} % ({len(e)})"

    print(f"\n{args.folds}-fold cross-validation (seed {args.seed}) on {len(rows)} tilted "
          f"training designs, {args.straight} straight features (calibrated-fast; |ΔP|/P "
          "median / p90, designs; graphs within 10 % of FE's range)")
    print(f"{'swept':<7} {'weights (Pc, Ph)':<18} {'factor':>7} {'Pc':>24} {'Ph':>24} "
          f"{'graphs':>14}")
    for key, pw in sweeps:
        f = "none" if pw[2] is None or pw[2] >= 1e6 else f"{pw[2]:g}"
        print(f"{key:<7} {pw[:2]!s:<18} {f:>7} {cell(errors[pw]['Pc']):>24} "
              f"{cell(errors[pw]['Ph']):>24} {share(errors[pw]['graph']):>14}")


if __name__ == "__main__":
    main()
