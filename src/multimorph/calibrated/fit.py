"""Fit the calibrated cell model (and compute what it needs) from the shipped data.

    python -m multimorph.calibrated.fit ritz-table [--samples 2048]   # Ritz features (resumable)
    python -m multimorph.calibrated.fit model [--emulators]            # fit data/model.npz
    python -m multimorph.calibrated.fit twist-shear                    # tilted cells' shear factor

The FE reference data set comes first (``python -m multimorph.calibrated.build_dataset``).
"""

from __future__ import annotations

import argparse


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
    sub.add_parser("twist-shear", help="fit the tilted cells' strip-shear factor on the "
                   "shipped model (also done by 'model')")
    args = ap.parse_args(argv)
    if args.what == "ritz-table":
        from multimorph.calibrated._ritz_table import build_ritz_table

        build_ritz_table(args.samples, args.chunk)
        return 0
    if args.what == "twist-shear":
        from multimorph.calibrated._fit import fit_twist_shear

        fit_twist_shear()
        return 0
    from multimorph.calibrated._fit import fit_and_save

    fit_and_save(emulators=args.emulators)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
