"""Regenerate ``materials/data/library.json`` from the shipped test data (deterministic).

Usage::

    python -m multimorph.materials.build_library            # rewrite the library file
    python -m multimorph.materials.build_library --check    # exit 1 if it would change
    python -m multimorph.materials.build_library --out x.json

Every Marechal et al. (2021) silicone is fitted by :func:`~multimorph.materials.fit_material`
over the design range λ ≤ 4 with relative residuals, for each model in :data:`MODELS`.
Treloar's (1944) natural rubber gets our joint UT + ET + PS fits and Ogden's 1972 set;
Elastosil M4601 gets the Yeoh set of Polygerinos et al. (2015).
"""

from __future__ import annotations

import argparse
import json
import sys
from importlib import resources
from pathlib import Path
from typing import Any

from multimorph.materials._fit import FitResult, fit_material
from multimorph.materials._material import Provenance
from multimorph.materials._readers import TestData, read_test_data

__all__ = ["MARECHAL", "MODELS", "STRETCH_MAX", "build", "main"]

#: Upper end of the design range the library is fitted over (-).
STRETCH_MAX = 4.0
#: Models fitted to every silicone (Gent first: the default). No Ogden: uniaxial data alone
#: do not determine its six parameters (the fits end on bounds with huge standard errors).
MODELS = ("gent", "yeoh", "reduced-polynomial-6", "neo-hooke", "mooney-rivlin")

MARECHAL_DOI = "10.1089/soro.2019.0115"
MARECHAL_SOURCE = ("Marechal et al., Toward a Common Framework and Database of Materials for "
                   "Soft Robotics, Soft Robotics 8(3) (2021); Soft Robotics Materials Database")
MARECHAL_LICENCE = "ODbL 1.0 (database), DbCL 1.0 (contents)"
MARECHAL_NOTE = ("uniaxial pull to failure, ASTM D412 die C, crosshead ('global') strain: "
                 "the softest grades look about 2x softer than their datasheets")

#: file stem -> (library name, display title, aliases)
MARECHAL: dict[str, tuple[str, str, tuple[str, ...]]] = {
    "bodydouble_silk": ("body-double-silk", "Body Double SILK", ()),
    "dragon_skin_10_medium": ("dragon-skin-10", "Dragon Skin 10 Medium",
                              ("dragon-skin-10-medium",)),
    "dragon_skin_20": ("dragon-skin-20", "Dragon Skin 20", ()),
    "dragon_skin_30": ("dragon-skin-30", "Dragon Skin 30", ()),
    "dragon_skin_fx_pro": ("dragon-skin-fx-pro", "Dragon Skin FX-Pro", ()),
    "dragon_skin_fx_pro_slacker": ("dragon-skin-fx-pro-slacker",
                                   "Dragon Skin FX-Pro with Slacker", ()),
    "ecoflex_00-10": ("ecoflex-00-10", "Ecoflex 00-10", ()),
    "ecoflex_00-30": ("ecoflex-00-30", "Ecoflex 00-30", ()),
    "ecoflex_00-35_fast": ("ecoflex-00-35-fast", "Ecoflex 00-35 FAST", ("ecoflex-00-35",)),
    "ecoflex_00-50": ("ecoflex-00-50", "Ecoflex 00-50", ()),
    "mold_star_16_fast": ("mold-star-16", "Mold Star 16 FAST", ("mold-star-16-fast",)),
    "mold_star_20t": ("mold-star-20t", "Mold Star 20T", ()),
    "platsil_gel_10": ("platsil-gel-10", "PlatSil Gel-10", ()),
    "psycho_paint": ("psycho-paint", "Psycho Paint", ()),
    "rebound_25": ("rebound-25", "Rebound 25", ()),
    "rtv615": ("rtv615", "RTV615", ("rtv-615",)),
    "soloplast_150318": ("soloplast-150318", "SOLOPLAST 150318", ()),
    "sortaclear_40": ("sortaclear-40", "SortaClear 40", ()),
    "wagnersil_20_nf": ("wagnersil-20-nf", "WAGNERSIL 20 NF", ()),
}


def data_dir() -> Path:
    """Folder of the shipped data files (``multimorph/materials/data``)."""
    return Path(str(resources.files("multimorph") / "materials" / "data"))


def _round(x: Any, digits: int = 10) -> Any:
    """Round floats to ``digits`` significant digits (stable JSON across platforms);
    fit statistics (under ``stats``) to 6."""
    if isinstance(x, float):
        return float(f"{x:.{digits}g}")
    if isinstance(x, dict):
        return {k: _round(v, 6 if k == "stats" else digits) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_round(v, digits) for v in x]
    return x


def _model_entry(res: FitResult) -> dict[str, Any]:
    d = res.material.to_dict()
    d.pop("name", None)
    d.pop("break_stretch", None)
    d["stats"] = {
        "status": res.status,
        "relative_rms": res.relative_rms,
        "median_relative_error": res.median_relative_error,
        "r2": {k: v.r2 for k, v in res.per_case.items()},
        "n_points": res.n_points,
        "n_excluded": res.n_excluded,
        "stderr": dict(res.stderr),
        "drucker_stable": res.stability.stable,
        "drucker_range": list(res.stability.stretch_range),
    }
    return d


def fit_marechal(stem: str, models: tuple[str, ...] = MODELS,
                 stretch_max: float = STRETCH_MAX) -> tuple[TestData, dict[str, FitResult]]:
    """Fit the shipped Marechal file ``stem`` with each model over λ ≤ ``stretch_max``."""
    rel = f"materials/data/marechal2021/{stem}.csv"
    data = read_test_data(data_dir() / "marechal2021" / f"{stem}.csv")
    prov = Provenance(source=MARECHAL_SOURCE, doi=MARECHAL_DOI, licence=MARECHAL_LICENCE,
                      data_file=rel, note=MARECHAL_NOTE)
    name = MARECHAL[stem][0]
    out: dict[str, FitResult] = {}
    for law_name in models:
        res = fit_material(law_name, data, stretch_range=stretch_max, residual="relative",
                           name=name, provenance=prov)
        if res.success:
            out[res.material.model] = res
    return data, out


def _treloar() -> dict[str, Any]:
    folder = data_dir() / "treloar1944"
    curves = [read_test_data(folder / f"{c}.csv").curves[0]
              for c in ("uniaxial", "equibiaxial", "pure_shear")]
    prov = Provenance(
        source="Treloar, Stress-strain data for vulcanised rubber under various types of "
               "deformation, Trans. Faraday Soc. 40 (1944) 59-70",
        doi="10.1039/tf9444000059", data_file="materials/data/treloar1944/*.csv",
        note="vulcanised natural rubber (8 % sulphur); joint UT + ET + PS fit")
    models: dict[str, Any] = {}
    for law_name in ("gent", "yeoh"):
        res = fit_material(law_name, curves, residual="relative", name="treloar-1944",
                           provenance=prov)
        models[res.material.model] = _model_entry(res)
    models["ogden-3"] = {
        "model": "ogden-3",
        "convention": "ogden1972",
        "params": {"mu1": 0.63e6, "mu2": 0.0012e6, "mu3": -0.01e6,
                   "alpha1": 1.3, "alpha2": 5.0, "alpha3": -2.0},
        "provenance": Provenance(
            source="Ogden, Large deformation isotropic elasticity, Proc. R. Soc. A 326 (1972) "
                   "565-584 (fit to Treloar 1944; 6.3, 0.012, -0.1 kg/cm^2)",
            doi="10.1098/rspa.1972.0026",
            note="literature set, 1972 convention W = sum mu_p/alpha_p (...)").to_dict(),
    }
    return {
        "title": "Natural rubber (Treloar 1944)",
        "supplier": None,
        "aliases": ["treloar", "natural-rubber"],
        "source": prov.to_dict(),
        "break_stretch": None,
        "default_model": "ogden-3",
        "models": models,
    }


def _elastosil() -> dict[str, Any]:
    prov = Provenance(
        source="Polygerinos et al., Modeling of soft fiber-reinforced bending actuators, "
               "IEEE Trans. Robotics 31(3) (2015) 778-789",
        doi="10.1109/TRO.2015.2428504",
        note="Yeoh C10 = 0.11 MPa, C20 = 0.02 MPa (literature set, not fitted by multimorph; "
             "quoted from memory of the paper, widely repeated). Break stretch 8 from the "
             "datasheet's 700 % elongation (third-party summary).")
    return {
        "title": "Elastosil M4601 (Wacker)",
        "supplier": "Wacker",
        "aliases": ["elastosil", "elastosil-m-4601"],
        "source": prov.to_dict(),
        "break_stretch": 8.0,
        "default_model": "yeoh",
        "models": {"yeoh": {"model": "yeoh", "params": {"c10": 0.11e6, "c20": 0.02e6,
                                                        "c30": 0.0},
                            "provenance": prov.to_dict()}},
    }


def build(models: tuple[str, ...] = MODELS) -> dict[str, Any]:
    """The library as a JSON-ready dict (deterministic for a given set of dependencies)."""
    materials: dict[str, Any] = {}
    for stem in sorted(MARECHAL):
        name, title, aliases = MARECHAL[stem]
        data, fits = fit_marechal(stem, models)
        prov = next(iter(fits.values())).material.provenance if fits else None
        materials[name] = {
            "title": title,
            "supplier": data.metadata.get("Material supplier") or None,
            "aliases": list(aliases),
            "source": Provenance(source=MARECHAL_SOURCE, doi=MARECHAL_DOI,
                                 licence=MARECHAL_LICENCE,
                                 data_file=prov.data_file if prov else None,
                                 note=MARECHAL_NOTE).to_dict(),
            "break_stretch": data.break_stretch,
            "default_model": "gent",
            "models": {k: _model_entry(v) for k, v in fits.items()},
        }
    materials["elastosil-m4601"] = _elastosil()
    materials["treloar-1944"] = _treloar()
    lib = {
        "format": 1,
        "generated_by": "python -m multimorph.materials.build_library",
        "fit_settings": {"stretch_max": STRETCH_MAX, "residual": "relative",
                         "toe_filter": 0.1, "models": list(models)},
        "licence_note": "Parameters derived from the Marechal et al. 2021 database are made "
                        "available under the ODbL 1.0 (contents DbCL 1.0), like the data; "
                        "see materials/data/marechal2021/README.md.",
        "materials": dict(sorted(materials.items())),
    }
    return _round(lib)


def dumps(lib: dict[str, Any]) -> str:
    return json.dumps(lib, indent=1, ensure_ascii=True, allow_nan=False) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Command-line entry: rewrite (or ``--check``) the library file."""
    ap = argparse.ArgumentParser(prog="python -m multimorph.materials.build_library",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=None,
                    help="write here instead of materials/data/library.json")
    ap.add_argument("--check", action="store_true",
                    help="do not write; exit 1 if the shipped library differs")
    args = ap.parse_args(argv)
    text = dumps(build())
    target = args.out or data_dir() / "library.json"
    if args.check:
        same = target.is_file() and target.read_text(encoding="utf-8") == text
        print(f"{target}: {'up to date' if same else 'differs from a rebuild'}")
        return 0 if same else 1
    tmp = target.with_suffix(".json.tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(target)
    n = len(json.loads(text)["materials"])
    print(f"wrote {target} ({n} materials)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
