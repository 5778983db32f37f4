"""Pc/μ and Ph/μ of the example cell for three top-wall thicknesses, by the default cell
model (calibrated-fast: the Ritz model corrected against 3D FE; held-out error in
docs/validation.md) and, beside it, the Ritz model alone (about twice as stiff as FE).

Run: python examples/cell_sweep_ht.py
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from multimorph.geometry import CellGeometry
from multimorph.io import load_toml
from multimorph.models import DEFAULT_MODEL, batch_model


def main() -> list[dict[str, float | str | None]]:
    spec = load_toml(Path(__file__).with_name("cell.toml"))
    base = CellGeometry.from_spec(spec["cell"])
    cells = [replace(base, top_wall=t) for t in (0.6e-3, 0.8e-3, 1.0e-3)]
    rows: list[dict[str, float | str | None]] = []
    for model in (DEFAULT_MODEL, "ritz"):
        for c, r in zip(cells, batch_model(model)(cells, 1.2 * base.mu), strict=True):
            if isinstance(r, Exception):
                raise r
            ch = r.characteristic
            rows.append({"model": model, "ht/d": c.top_wall / c.length,
                         "Pc/mu": ch.critical / c.mu,
                         "Ph/mu": None if ch.hardening is None else ch.hardening / c.mu})
    for row in rows:
        print(f"{row['model']:<16}" + "  ".join(
            f"{k} = {v:.3f}" if v is not None else f"{k} = -"
            for k, v in row.items() if k != "model"))
    return rows


if __name__ == "__main__":
    main()
