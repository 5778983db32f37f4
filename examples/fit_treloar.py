"""Fit Gent and a 3-term Ogden law to Treloar's (1944) rubber data; compare with Ogden (1972).

Run: ``python examples/fit_treloar.py`` (prints a table; ``--plot DIR`` also saves PNGs).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from multimorph.materials import Material, fit_material, read_test_data
from multimorph.materials.build_library import data_dir

#: Ogden's published set (Proc. R. Soc. A 326 (1972) 565), 1972 convention, Pa.
OGDEN_1972 = Material("ogden", {"mu1": 0.63e6, "mu2": 0.0012e6, "mu3": -0.01e6,
                                "alpha1": 1.3, "alpha2": 5.0, "alpha3": -2.0},
                      name="ogden-1972")


def median_errors(material: Material, curves) -> dict[str, float]:
    """Median relative error of the nominal stress per load case (-)."""
    return {c.case: float(np.median(np.abs(material.nominal_stress(c.case, c.stretch)
                                           - c.stress) / c.stress)) for c in curves}


def main(plot_dir: Path | None = None) -> dict[str, dict[str, float]]:
    folder = data_dir() / "treloar1944"
    curves = [read_test_data(folder / f"{c}.csv").curves[0]
              for c in ("uniaxial", "equibiaxial", "pure_shear")]
    gent_ut = fit_material("gent", curves[0])              # relative residuals (default)
    ogden = fit_material("ogden", curves, order=3)         # joint UT + ET + PS
    rows = {"Ogden 1972 (published)": median_errors(OGDEN_1972, curves),
            "Ogden-3, our joint fit": median_errors(ogden.material, curves)}
    print("median relative error of nominal stress per load case")
    print(f"{'parameter set':28s} {'UT':>7s} {'ET':>7s} {'PS':>7s}")
    for name, e in rows.items():
        print(f"{name:28s} " + " ".join(f"{100 * e[c]:6.2f}%" for c in
                                        ("uniaxial", "equibiaxial", "pure_shear")))
    print("our Ogden-3 parameters (1972 convention): "
          + ", ".join(f"{k} = {v:.4g}" for k, v in ogden.params.items()))
    print(f"Gent fit to uniaxial data: mu = {gent_ut.params['mu'] / 1e6:.3f} MPa, "
          f"Jm = {gent_ut.params['jm']:.1f}, relative RMS {gent_ut.relative_rms:.3f} "
          f"({gent_ut.residual} residuals)")
    if plot_dir is not None:
        from multimorph.viz._fitplot import plot_fit

        plot_dir.mkdir(parents=True, exist_ok=True)
        plot_fit(ogden, curves, plot_dir / "treloar_ogden.png")
        plot_fit(gent_ut, curves[:1], plot_dir / "treloar_gent_ut.png")
    return {**rows, "gent": {"mu": gent_ut.params["mu"], "jm": gent_ut.params["jm"]}}


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plot", type=Path, default=None, help="folder for PNG plots")
    main(ap.parse_args().plot)
