"""Timings of material fits and stress evaluation; prints a table.

Run: ``python benchmarks/bench_materials.py`` (``--repeat N`` warm repeats, default 5).

For each model and data set: the first fit (includes JAX compilation of the kernels and of the
Drucker check), then the median of warm repeats, the function evaluations and the fit error.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time

import numpy as np

from multimorph.materials import fit_material, get_material, read_test_data
from multimorph.materials.build_library import data_dir

MODELS = ("neo-hooke", "gent", "mooney-rivlin", "yeoh", "reduced-polynomial-6", "ogden-3")


def datasets() -> dict[str, tuple[object, float | None]]:
    tre = data_dir() / "treloar1944"
    return {
        "dragon-skin-30 UT, λ≤4": (read_test_data(data_dir() / "marechal2021" /
                                                  "dragon_skin_30.csv"), 4.0),
        "Treloar UT+ET+PS": ([read_test_data(tre / f"{c}.csv").curves[0]
                              for c in ("uniaxial", "equibiaxial", "pure_shear")], None),
    }


def bench_fits(repeat: int) -> list[tuple[str, ...]]:
    rows = []
    for label, (data, rng) in datasets().items():
        for model in MODELS:
            t0 = time.perf_counter()
            res = fit_material(model, data, stretch_range=rng)
            first = time.perf_counter() - t0
            warm = []
            for _ in range(repeat):
                t0 = time.perf_counter()
                fit_material(model, data, stretch_range=rng)
                warm.append(time.perf_counter() - t0)
            rows.append((label, model, f"{first:.2f}", f"{1e3 * statistics.median(warm):.0f}",
                         str(res.nfev), str(res.n_starts), f"{100 * res.relative_rms:.1f} %",
                         res.status))
    return rows


def bench_stress() -> list[tuple[str, ...]]:
    rows = []
    lam = np.linspace(1.01, 3.9, 100_000)
    for name in ("dragon-skin-30", "dragon-skin-30:reduced-polynomial"):
        m = get_material(name)
        m.nominal_stress("uniaxial", lam)  # compile
        t0 = time.perf_counter()
        for _ in range(5):
            m.nominal_stress("uniaxial", lam)
        dt = (time.perf_counter() - t0) / 5
        rows.append((m.model, f"{lam.size}", f"{1e3 * dt:.1f}", f"{1e9 * dt / lam.size:.0f}"))
    return rows


def _table(header: tuple[str, ...], rows: list[tuple[str, ...]]) -> str:
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    line = "  ".join(h.ljust(w) for h, w in zip(header, widths, strict=True))
    out = [line, "-" * len(line)]
    out += ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)) for r in rows]
    return "\n".join(out)


def main(repeat: int = 5) -> None:
    print(f"multimorph material benchmarks ({platform.processor() or platform.machine()}, "
          f"Python {platform.python_version()})\n")
    print(_table(("data", "model", "first fit (s)", "warm fit (ms)", "nfev", "starts",
                  "rel. RMS", "status"), bench_fits(repeat)))
    print()
    print(_table(("model", "stretches", "uniaxial stress (ms)", "ns/point"), bench_stress()))


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    main(ap.parse_args().repeat)
