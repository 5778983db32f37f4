"""Fit the calibrated cell model (and compute what it needs) from the shipped data.

    python -m multimorph.calibrated.fit ritz-table [--samples 2048]   # Ritz features (resumable)
    python -m multimorph.calibrated.fit model [--emulators] [--kinds K ...]  # data/model.npz
    python -m multimorph.calibrated.fit twist-shear                    # tilted cells' shear factor
    python -m multimorph.calibrated.fit signal [--kinds bending]       # the signal GP alone
    python -m multimorph.calibrated.fit log-signal [--kinds twisting]  # the log signal GP alone
    python -m multimorph.calibrated.fit pressure [--kinds bending]     # the pressure GP alone
    python -m multimorph.calibrated.fit path [--kinds bending]         # the path GP alone
    python -m multimorph.calibrated.fit anchors [--kinds bending]      # the Pc and Ph GPs alone
    python -m multimorph.calibrated.fit law-map                        # how Yeoh walls are placed

The FE reference data set comes first (``python -m multimorph.calibrated.build_dataset``).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any


def fit_twist_shear(form: str = "volume") -> dict[str, Any]:
    """Fit the tilted cells' strip shear (:mod:`._shear`: the factor on the Ritz rule and
    the volume law) on the shipped model and data and write it into the model's manifest
    (``twisting_shear``); returns it. ``form``: the model's form, ``"volume"`` (the default
    since stop 40; taken only where the law beats the factor in leave-one-out, median and
    p90) or ``"factor"``."""
    from multimorph.calibrated._fit import MODEL_MANIFEST
    from multimorph.calibrated._model import load_model
    from multimorph.calibrated._shear import VOLUME_SOURCE, fit_shear_factor, shear_samples

    load_model.cache_clear()
    model = load_model()
    model.twisting_shear = None                 # sample the bare rule
    samples = shear_samples(model)
    fit = fit_shear_factor(samples, form)
    # the volume the law is read at does not depend on the law (FE's, or the tilted
    # cell's own path since stop 41: stops 39-40 read it on the straight path placed on
    # anchors that the shear's knees moved, and sampled twice)
    fit["volume_source"] = VOLUME_SOURCE
    manifest = json.loads(MODEL_MANIFEST.read_text())
    manifest["twisting_shear"] = fit
    MODEL_MANIFEST.write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    load_model.cache_clear()
    print(f"[calibrate] twist shear factor: {fit['training_designs']} tilted designs; "
          "shear error past Pc "
         f"(median, p90): rule {fit['rule_error']['median']:.3g} {fit['rule_error']['p90']:.3g}"
         f", factor (leave-one-out) {fit['leave_one_out_error']['median']:.3g} "
         f"{fit['leave_one_out_error']['p90']:.3g}"
         + (f", held out {fit['holdout_error']['median']:.3g} {fit['holdout_error']['p90']:.3g}"
            f" (rule {fit['holdout_rule_error']['median']:.3g})"
            if "holdout_error" in fit else ""), file=sys.stderr, flush=True)
    law = fit.get("volume_law")
    if law:
        used = "the form used" if fit.get("form") == "volume" else "not used"
        print(f"[calibrate] twist shear volume law ({used}): leave-one-out "
              f"{law['leave_one_out_error']['median']:.3g} "
              f"{law['leave_one_out_error']['p90']:.3g}"
              + (f", held out {law['holdout_error']['median']:.3g} "
                 f"{law['holdout_error']['p90']:.3g}" if "holdout_error" in law else ""),
              file=sys.stderr, flush=True)
    return fit


def fit_law_map_into_model(fast: bool = True) -> dict[str, Any] | None:
    """Fit how a wall of another law is placed (:mod:`._law`: the effective Gent wall of a
    Yeoh-like wall, on the training designs of ``yeoh2_mirror`` against the shipped
    bending kind) and write it into the model's manifest (``law_map``); returns it (None
    where the data set has no such set)."""
    from multimorph.calibrated._dataset import load_reference
    from multimorph.calibrated._fit import MODEL_MANIFEST
    from multimorph.calibrated._law import LAW_MAP_SET
    from multimorph.calibrated._law_fit import (
        fit_law_map,
        fit_ph_shift,
        law_map_costs,
        law_map_spread,
    )
    from multimorph.calibrated._model import load_model

    if LAW_MAP_SET not in load_reference():
        return None
    load_model.cache_clear()
    model = load_model()
    model.law_map = None
    fit = fit_law_map(law_map_costs(model, fast=fast))
    fit["variant"] = "calibrated-fast" if fast else "calibrated"
    model.law_map = fit
    fit["ph_shift"] = fit_ph_shift(model, fast=fast)   # read before it is applied
    fit["spread"] = law_map_spread(model, fast=fast)
    manifest = json.loads(MODEL_MANIFEST.read_text())
    manifest["law_map"] = fit
    MODEL_MANIFEST.write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    load_model.cache_clear()
    print(f"[calibrate] law map on {fit['training_designs']} Yeoh-walled designs "
          f"(c20/c10 {fit['shape_range'][0]:.3g}-{fit['shape_range'][1]:.3g}): ln s = "
          f"{fit['log_mu_factor'][0]:.3f} + {fit['log_mu_factor'][1]:.3f} ln k, ln Jm = "
          f"{fit['log_jm'][0]:.3f} + {fit['log_jm'][1]:.3f} ln k; cost median "
          f"{fit['cost']['median']:.3f} (each design's own best "
          f"{fit['cost']['each_design_own_best_median']:.3f}); spread of log Pc, log Ph on "
          f"them {fit['spread']['sigma_log_pc']:.3f}, {fit['spread']['sigma_log_ph']:.3f}; "
          f"Ph × {math.exp(fit['ph_shift']['log_factor']):.3f} on a bending cell whose wall's "
          f"membrane does not snap ({fit['ph_shift']['training_designs']} designs)",
          file=sys.stderr, flush=True)
    return fit


def _refit_part(part: str, kinds: tuple[str, ...]) -> int:
    """``fit signal|log-signal|pressure|path|anchors``: one GP of ``kinds`` into the shipped model
    (``_fit.add_part``), then what reads it: the twisting kind after a bending pressure or
    anchor refit (its inputs are the bending kind's log P and its Pc anchor), the
    strip-shear factor after a pressure, path or anchor refit of bending or twisting (its
    rule reads the straight cells' calibrated paths and the tilted cells' anchors)."""
    from multimorph.calibrated._fit import add_part, fit_and_save
    from multimorph.calibrated._model import straight_of

    try:
        add_part(part, kinds, straight_of=straight_of)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if part in ("pressure", "anchors") and "bending" in kinds and "twisting" not in kinds:
        fit_and_save(kinds=("twisting",), straight_of=straight_of)
    if part not in ("signal", "log_signal") and {"bending", "twisting"} & set(kinds):
        fit_twist_shear()
    if "bending" in kinds:
        fit_law_map_into_model()
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="what", required=True)
    rt = sub.add_parser("ritz-table", help="Ritz features over the calibrated boxes")
    rt.add_argument("--samples", type=int, default=2048)
    rt.add_argument("--chunk", type=int, default=256)
    md = sub.add_parser("model", help="fit the calibrated model to the FE reference data")
    md.add_argument("--emulators", action="store_true",
                    help="also emulate the Ritz features from the Ritz table (faster at run "
                         "time, less accurate); default: exact Ritz features at run time")
    md.add_argument("--kinds", nargs="+", metavar="KIND",
                    help="refit only these kinds (bending, stretching, twisting) into the "
                         "shipped model, keeping the others and its emulators")
    ts = sub.add_parser("twist-shear", help="fit the tilted cells' strip-shear factor on "
                        "the shipped model (also done by 'model', unless its --kinds leave "
                        "out bending and twisting)")
    ts.add_argument("--form", choices=("factor", "volume"), default="volume",
                    help="the shear's form in the model: the volume law where it beats the "
                         "factor in leave-one-out (default, since stop 40), or the factor "
                         "on the Ritz rule (calibrated._shear)")
    helps = {
        "signal": "fit the signal GP (a kernel of its own past the snap) of these kinds into "
                  "the shipped model, keeping its other GPs (also done by 'model')",
        "log-signal": "fit the log signal GP (log of the signal over t, tilted cells only) "
                      "of the twisting kind into the shipped model, keeping its other GPs "
                      "(also done by 'model')",
        "pressure": "fit the pressure GP (log P on the grid, designs stopped at their "
                    "pressure limit as censored data) of these kinds into the shipped model "
                    "on every current training design, keeping its other GPs; a bending "
                    "refit refits the twisting kind that reads it, and the strip-shear "
                    "factor (also done by 'model')",
        "path": "fit the path GP (every grid quantity, one kernel) of these kinds into the "
                "shipped model on every current training design, on its feature scaling, "
                "keeping its other GPs; a bending refit refits the strip-shear factor (also "
                "done by 'model')",
        "anchors": "fit the Pc and Ph GPs (the anchors; bending with a robust likelihood) "
                   "of these kinds into the shipped model on every current training design, "
                   "on its feature scaling, keeping its other GPs; a bending refit refits "
                   "the twisting kind that reads it, and the strip-shear factor (also done "
                   "by 'model')"}
    for part, text in helps.items():
        sub.add_parser(part, help=text).add_argument(
            "--kinds", nargs="+", metavar="KIND",
            default=["twisting"] if part == "log-signal" else ["bending"])
    sub.add_parser("law-map", help="fit how a wall of another law (Yeoh-like) is placed in "
                   "the model, on the Yeoh-walled FE cells of yeoh2_mirror against the "
                   "shipped bending kind (also done by 'model' and every bending refit)")
    args = ap.parse_args(argv)
    if args.what in helps:
        return _refit_part(args.what.replace("-", "_"), tuple(args.kinds))
    if args.what == "law-map":
        return 0 if fit_law_map_into_model() is not None else 2
    if args.what == "ritz-table":
        from multimorph.calibrated._ritz_table import build_ritz_table

        build_ritz_table(args.samples, args.chunk)
        return 0
    if args.what == "twist-shear":
        fit_twist_shear(args.form)
        return 0
    from multimorph.calibrated._fit import fit_and_save
    from multimorph.calibrated._model import straight_of

    try:
        fit_and_save(emulators=args.emulators,
                     kinds=tuple(args.kinds) if args.kinds else None, straight_of=straight_of)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    # the strip-shear factor reads the tilted cells and their straight (bending) cells: a
    # refit of other kinds alone keeps it (stop 37: `--kinds stretching` had refitted it)
    if not args.kinds or {"bending", "twisting"} & set(args.kinds):
        fit_twist_shear()
    if not args.kinds or "bending" in args.kinds:
        fit_law_map_into_model()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
