"""Atomic output folders and JSON serialisation.

Every command writes its files into a temporary sibling folder and renames it into place only
when everything succeeded, so a failed or interrupted run leaves nothing half-written.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, is_dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["atomic_output_dir", "to_jsonable", "write_json"]


@contextmanager
def atomic_output_dir(path: str | os.PathLike[str], *, overwrite: bool = True,
                      stale: Sequence[str] = ()) -> Iterator[Path]:
    """Yield a temporary folder; on success move its files into ``path`` (created if needed).

    Files are written to ``<parent>/.<name>.tmp-XXXX`` and each is renamed into ``path`` at
    the end (``os.replace``, atomic on one filesystem). On any exception the temporary folder
    is removed and ``path`` is left as it was. ``stale``: file names (relative to ``path``)
    that an earlier run may have left there and this one did not write; they are removed on
    success (a design run that ends infeasible must not leave an old ``device.toml``).
    """
    final = Path(path)
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.tmp-", dir=final.parent))
    try:
        yield tmp
        final.mkdir(parents=True, exist_ok=True)
        written = {p.relative_to(tmp).as_posix() for p in tmp.rglob("*") if p.is_file()}
        for item in sorted(tmp.rglob("*")):
            rel = item.relative_to(tmp)
            dest = final / rel
            if item.is_dir():
                dest.mkdir(parents=True, exist_ok=True)
            else:
                if dest.exists() and not overwrite:
                    raise FileExistsError(dest)
                dest.parent.mkdir(parents=True, exist_ok=True)
                os.replace(item, dest)
        for name in stale:
            if name not in written:
                (final / name).unlink(missing_ok=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def to_jsonable(obj: Any) -> Any:
    """Convert numpy/JAX scalars and arrays, dataclasses, paths and non-finite floats.

    NaN and ±inf become ``None`` (JSON has no such numbers).
    """
    if is_dataclass(obj) and not isinstance(obj, type):
        if hasattr(obj, "to_dict"):
            return to_jsonable(obj.to_dict())
        return to_jsonable(asdict(obj))
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, Path):
        return str(obj)
    if hasattr(obj, "__array__") and not isinstance(obj, str | bytes):
        arr = np.asarray(obj)
        if arr.ndim == 0:
            return to_jsonable(arr.item())
        return [to_jsonable(v) for v in arr.tolist()]
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, np.generic):
        return to_jsonable(obj.item())
    return obj


def write_json(path: str | os.PathLike[str], data: Any) -> None:
    """Write ``data`` as indented JSON (via :func:`to_jsonable`)."""
    Path(path).write_text(json.dumps(to_jsonable(data), indent=2) + "\n")
