"""The Ritz training table: Ritz features of many designs over the calibrated box.

The calibrated model reads the Ritz features of a cell from an emulator (a GP over the
groups) instead of tracing the Ritz model (~30 ms a curve). Its training designs are a
scrambled Sobol sample over each box, computed here in chunks and saved after every chunk
(``data/ritz_table.npz``), so the computation resumes where it stopped.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import time
from pathlib import Path

import numpy as np

from multimorph.calibrated._box import GROUP_NAMES, Box, cell_groups
from multimorph.calibrated._dataset import DATA_DIR, reference_spec
from multimorph.calibrated._ritz import TABLE_NAMES, path_table

__all__ = ["RITZ_TABLE", "TABLE_KINDS", "build_ritz_table", "load_ritz_table"]

RITZ_TABLE = DATA_DIR / "ritz_table.npz"
#: Emulator families: the bending box (bending and tilted cells share the straight cell's
#: Ritz features) and the stretching box.
TABLE_KINDS = {"bending": "bending", "stretching": "stretching"}
SEED = 7


def load_ritz_table(path: Path = RITZ_TABLE) -> dict[str, dict[str, np.ndarray]]:
    """``{kind: {"groups": (n, k), "table": (n, 25)}}`` of the saved table ({} if none):
    the groups and the Ritz path's :data:`~._ritz.TABLE_NAMES` of every design."""
    if not path.exists():
        return {}
    out: dict[str, dict[str, np.ndarray]] = {}
    with np.load(path, allow_pickle=False) as z:
        for kind in TABLE_KINDS:
            if f"{kind}/groups" in z.files:
                out[kind] = {"groups": z[f"{kind}/groups"], "table": z[f"{kind}/table"]}
    return out


def _save(table: dict[str, dict[str, np.ndarray]], path: Path) -> None:
    arrays = {f"{k}/{n}": v for k, d in table.items() for n, v in d.items()}
    arrays["table_names"] = np.array(TABLE_NAMES)
    tmp = path.with_name(f".{path.stem}.tmp.npz")
    np.savez_compressed(tmp, **arrays)
    os.replace(tmp, path)


def build_ritz_table(samples: int = 2048, chunk: int = 256, path: Path = RITZ_TABLE,
                     kinds: tuple[str, ...] = tuple(TABLE_KINDS)) -> None:
    """Compute (or continue) the table: ``samples`` Sobol designs per kind's box."""
    table = load_ritz_table(path)
    for kind in kinds:
        spec = dataclasses.replace(reference_spec(kind), samples=samples, seed=SEED,
                                   min_chamber=0.05)
        cells = [c for c in spec.design_table().cells if c is not None]
        box = Box.from_spec(kind, reference_spec(kind))
        have = len(table.get(kind, {}).get("groups", []))
        t0 = time.monotonic()
        for start in range(have, len(cells), chunk):
            part = cells[start:start + chunk]
            rows = path_table(part)
            groups = np.array([box.values_of(cell_groups(c)) for c in part])
            old = table.get(kind, {"groups": np.zeros((0, len(GROUP_NAMES[kind]))),
                                   "table": np.zeros((0, len(TABLE_NAMES)))})
            table[kind] = {"groups": np.vstack([old["groups"], groups]),
                           "table": np.vstack([old["table"], rows])}
            _save(table, path)
            print(f"[ritz table] {kind}: {start + len(part)}/{len(cells)} designs, "
                  f"{(time.monotonic() - t0) / 60:.1f} min", file=sys.stderr, flush=True)
