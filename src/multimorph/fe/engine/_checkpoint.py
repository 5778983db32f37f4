"""Resumable FE paths: every converged point is kept on disk as it is found.

A long FE run (a device takes minutes) that is interrupted keeps what it had: each converged
path point (displacement vector, pressure, iterations, stability, how it was found) is saved
to its own file, written atomically, in a checkpoint folder. A later run with the same key
(the caller's fingerprint of spec and settings) and the same number of free DOF replays the
saved points through its recorder, which is cheap (measurements only, no solves), and
traces on from the last one. A folder whose key or DOF count differs is discarded, and
:attr:`PathCheckpoint.discarded` says why.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from multimorph.fe.engine._solve import PathPoint

__all__ = ["PathCheckpoint"]

_META = "checkpoint.json"


class PathCheckpoint:
    """The converged points of one FE path in ``folder``, valid for ``key`` only.

    Parameters
    ----------
    folder : path
        Created on the first saved point; :meth:`clear` removes it (after the results are
        written).
    key : str
        Fingerprint of everything that defines the path (spec, mesh, settings, version):
        points saved under another key are never reused.
    """

    def __init__(self, folder: str | os.PathLike[str], key: str) -> None:
        self.folder = Path(folder)
        self.key = str(key)
        self.resumed = 0
        self.discarded: str | None = None
        self._nfree: int | None = None
        self._count = 0

    @classmethod
    def beside(cls, output: str | os.PathLike[str], source: bytes,
               options: Mapping[str, Any]) -> PathCheckpoint:
        """The checkpoint of a run that writes into the folder ``output``: the folder
        ``<output>.resume`` beside it, keyed to the ``source`` (a spec file's bytes), the
        ``options`` and the package version."""
        from multimorph import __version__

        key = hashlib.sha256(source)
        key.update(json.dumps({**options, "version": __version__}, sort_keys=True,
                              default=str).encode())
        output = Path(output)
        return cls(output.with_name(output.name + ".resume"), key.hexdigest())

    def load(self, nfree: int) -> list[PathPoint]:
        """The saved points of this key and DOF count, in path order (empty if none).

        A folder saved under another key or DOF count, or one whose index is unreadable,
        is removed (:attr:`discarded` gives the reason); a point file missing or unreadable
        ends the list there (the points before it are kept).
        """
        self._nfree = int(nfree)
        meta_file = self.folder / _META
        if not self.folder.exists():
            return []
        try:
            meta = json.loads(meta_file.read_text())
            ok_key, ok_n = meta.get("key") == self.key, int(meta.get("nfree", -1)) == nfree
        except (OSError, ValueError, TypeError):
            ok_key, ok_n = False, False
            meta = None
        if not (ok_key and ok_n):
            self.discarded = ("its index is unreadable" if meta is None else
                              "the spec or settings changed" if not ok_key else
                              "the mesh changed")
            shutil.rmtree(self.folder, ignore_errors=True)
            return []
        points: list[PathPoint] = []
        for i in range(int(meta.get("points", 0))):
            try:
                with np.load(self.folder / f"point_{i:05d}.npz") as z:
                    x = np.array(z["x"], dtype=float)
                    if x.shape != (nfree,):
                        break
                    stable = None if int(z["stable"]) < 0 else bool(int(z["stable"]))
                    points.append(PathPoint(float(z["pressure"]), x, int(z["iterations"]),
                                            stable, str(z["method"])))
            except (OSError, KeyError, ValueError):
                break
        self._count = len(points)
        self.resumed = len(points)
        return points

    def save(self, pt: PathPoint) -> None:
        """Append one converged point (its file first, then the index: both atomic)."""
        if self._nfree is None:
            self._nfree = len(pt.x)
        self.folder.mkdir(parents=True, exist_ok=True)
        i = self._count
        name = self.folder / f"point_{i:05d}.npz"
        tmp = self.folder / f".point_{i:05d}.tmp.npz"
        stable = -1 if pt.stable is None else int(bool(pt.stable))
        np.savez(tmp, x=np.asarray(pt.x, dtype=float), pressure=float(pt.pressure),
                 iterations=int(pt.iterations), stable=stable, method=str(pt.method))
        os.replace(tmp, name)
        self._count = i + 1
        self._write_index()

    def _write_index(self) -> None:
        meta = {"key": self.key, "nfree": self._nfree, "points": self._count}
        tmp_meta = self.folder / f".{_META}.tmp"
        tmp_meta.write_text(json.dumps(meta))
        os.replace(tmp_meta, self.folder / _META)

    def truncate(self, n: int) -> None:
        """Keep the first ``n`` saved points only (the later files are overwritten by the
        next saves; the index says ``n`` at once)."""
        self._count = min(int(n), self._count)
        if self.folder.exists():
            self._write_index()

    @property
    def saved(self) -> int:
        """Points on disk (resumed plus saved by this run)."""
        return self._count

    def clear(self) -> None:
        """Remove the folder (the run finished and its results are written)."""
        shutil.rmtree(self.folder, ignore_errors=True)
        self._count = 0
