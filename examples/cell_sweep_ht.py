"""Reduced cell model: κd vs P/μ, Pc and Ph of the example cell for three top-wall thicknesses.

Run: python examples/cell_sweep_ht.py
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from multimorph.geometry import CellGeometry
from multimorph.io import load_toml
from multimorph.rom import solve_batch


def main() -> list[dict[str, float | None]]:
    spec = load_toml(Path(__file__).with_name("cell.toml"))
    base = CellGeometry.from_spec(spec["cell"])
    cells = [replace(base, top_wall=t) for t in (0.6e-3, 0.8e-3, 1.0e-3)]
    batch = solve_batch(cells, 1.2 * base.mu)          # one vectorised call
    rows = []
    for i, c in enumerate(cells):
        ch = batch.response(i).characteristic
        row = {"ht/d": c.top_wall / c.length, "Pc/mu": ch.critical / c.mu,
               "Ph/mu": None if ch.hardening is None else ch.hardening / c.mu}
        rows.append(row)
        print("  ".join(f"{k} = {v:.3f}" if v is not None else f"{k} = -"
                        for k, v in row.items()))
    return rows


if __name__ == "__main__":
    main()
