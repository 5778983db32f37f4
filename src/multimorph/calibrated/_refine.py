"""FE paths of the data set that end where the continuation turned round: traced again.

A cell's FE Pc is read on its signal (the shared definitions of
:mod:`multimorph.response`; a tilted cell's strip shear): a limit point where one exists.
On some paths that limit point is where the arc-length continuation turned round: past it
the chamber volume never grows (by :data:`VOLUME_GROWTH` or more), the path walks back or
stays instead of going on. Such an end is either a critical point of the cell (the
equilibrium it was on stops being stable) or a step the continuation could not take.
Traced again with half the step limits (:data:`REFINEMENT`), a label that was the
continuation's shows: stop 55 (``benchmarks/fe_tilted_critical.py``) found 10 of 23 such
tilted paths passing their old end, 4 with another Pc (one 30.0 kPa -> 15.8 kPa).

The refinement is a step of the data set's build (``build_dataset --refine``): the set's
own sweep runs those designs again with :data:`REFINEMENT` (``run_sweep(designs=...,
options=...)``) into ``<set folder>/refined/``, and :func:`overlay_refined` lays each
refined path over the original when the set is collected:

* the refined run finished: its path replaces the original, and its ``meta`` gains
  ``refinement``: why, the step limits, the original's Pc, kind of Pc, points, status and
  time, the refined Pc and whether the refined path turned round again (then the end is
  the cell's: two step sizes stop at the same point);
* the refined run failed: the original path stays, its ``meta`` gains ``refinement`` with
  the error;
* the refined path reads no Pc where the original read one: the original path stays,
  ``refinement.kept`` says so (stop 56: ``bending_mirror`` #109, whose finer path read
  none because a lone unstable flag at its steepest rise cut its loading curve; with
  definitions version 4, stop 57, both paths read a max-slope Pc, 16.14 and 16.18 kPa,
  and the original stays the label; ``stretching2_mirror`` #17).

A design whose ``meta`` holds ``refinement`` is never a candidate again, so a build seeded
from the shipped archive (whose records carry it) does not run it again.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["REFINED_KINDS", "REFINEMENT", "VOLUME_GROWTH", "candidates",
           "ended_by_continuation", "overlay_refined", "refine_set", "turned_at_critical"]

#: Cell kinds whose paths are checked: all three (a limit point of the strip shear, the
#: end rotation or the axial stretch; stop 56: 25 tilted paths, 22 bending and stretching
#: paths of 3,000 or so).
REFINED_KINDS = ("bending", "stretching", "twisting")
#: The finer continuation: half the FE's default step limits (``dx_max`` 0.01,
#: ``dp_max`` 0.02) and steps enough to trace the same path with them (the tilted sets'
#: specs allow 150).
REFINEMENT: dict[str, Any] = {"dx_max": 0.005, "dp_max": 0.01, "max_steps": 350}
#: Past a critical point the chamber volume has to grow by this fraction for the path to
#: have gone on (else the continuation turned round there).
VOLUME_GROWTH = 0.02
#: The sub-folder of a set's sweep folder that holds the refined runs.
REFINED_FOLDER = "refined"
KEPT_NO_PC = "original: the finer path reads no Pc"
REASON = (f"the FE path ended at its limit point: past it the chamber volume never grew by "
          f"{VOLUME_GROWTH:.0%} (the continuation turned round); traced again with finer "
          "steps")


def turned_at_critical(path: Mapping[str, np.ndarray], pc: float | None,
                       kind: str | None) -> bool:
    """Whether the path's Pc is a limit point past which its chamber volume never grows
    by :data:`VOLUME_GROWTH` (the continuation turned round there)."""
    if kind != "limit_point" or pc is None or not math.isfinite(pc):
        return False
    P = np.asarray(path["pressure"], float)
    V = np.asarray(path["volume"], float)
    i = int(np.argmin(np.abs(P - pc)))
    return bool(np.nanmax(V[i:]) < (1.0 + VOLUME_GROWTH) * V[i])


def ended_by_continuation(meta: Mapping[str, Any]) -> bool:
    """Whether a run ended for a reason of the continuation's (stalled, out of steps, or
    retraced its path), not at a limit of the traced range (its pressure, its volume)."""
    return (meta.get("status") in ("stalled", "max_steps")
            or str(meta.get("stop_reason", "")).startswith("retraced"))


def _critical(path: Mapping[str, np.ndarray], cell: Any, kind: str,
              ) -> tuple[float | None, str | None]:
    from multimorph.calibrated._validate import fe_response

    ch = fe_response(dict(path), cell, kind).characteristic
    return ch.critical, ch.critical_kind


def candidates(ref: Any) -> list[int]:
    """Design indices of ``ref`` (a :class:`~._dataset.ReferenceSet`) whose FE path
    turned round at its Pc, ended for a reason of the continuation's
    (:func:`ended_by_continuation`) and has not been refined yet (none for a kind outside
    :data:`REFINED_KINDS`)."""
    if ref.kind not in REFINED_KINDS:
        return []
    out = []
    for r in np.flatnonzero(ref.ok):
        if "refinement" in ref.meta[r] or not ended_by_continuation(ref.meta[r]):
            continue
        path = ref.path(int(r))
        pc, kind = _critical(path, ref.cell(int(r)), ref.kind)
        if turned_at_critical(path, pc, kind):
            out.append(int(ref.design[r]))
    return out


def _row_path(cols: Mapping[str, np.ndarray], j: int) -> dict[str, np.ndarray]:
    n = int(cols["n_points"][j])
    out = {k[len("curve_"):]: np.asarray(v[j, :n], float) for k, v in cols.items()
           if k.startswith("curve_") and k != "curve_stable"}
    out["stable"] = np.asarray(cols["curve_stable"][j, :n], bool)
    return out


def _fill(dtype: np.dtype) -> Any:
    return False if dtype.kind == "b" else "" if dtype.kind == "O" else (
        0 if dtype.kind in "iu" else np.nan)


def _blank(like: np.ndarray, n: int, width: int | None) -> np.ndarray:
    shape = (n,) if like.ndim == 1 else (n, width)
    return np.full(shape, _fill(like.dtype), dtype=like.dtype)


def overlay_refined(cols: Mapping[str, np.ndarray], refined: Mapping[str, np.ndarray],
                    cell_of: Callable[[int], Any], kind: str) -> dict[str, np.ndarray]:
    """The columns of a set (``collect_parts``) with its refined runs laid over them.

    Parameters
    ----------
    cols, refined : mapping
        Columns of the set's sweep folder and of its ``refined/`` folder (one row per
        design, ``design`` ascending).
    cell_of : callable
        Design index -> the cell (to read Pc on a path).
    kind : str
        The set's kind of cell.

    Returns
    -------
    dict
        New columns (the inputs are not changed); see the module docstring.
    """
    if not refined or not len(refined.get("design", ())):
        return dict(cols)
    n = len(cols["design"])
    width = max([v.shape[1] for c in (cols, refined) for v in c.values()
                 if np.ndim(v) == 2] + [1])
    out: dict[str, np.ndarray] = {}
    for k in sorted(set(cols) | set(refined)):
        src = cols.get(k)
        like = np.asarray(src if src is not None else refined[k])
        if like.dtype.kind in "US":
            like = like.astype(object)
        arr = _blank(like, n, width)
        if src is not None:
            src = np.asarray(src)
            if arr.ndim == 2:
                arr[:, :src.shape[1]] = src
            else:
                arr[:] = src
        out[k] = arr
    pos = {int(d): j for j, d in enumerate(out["design"])}
    for r, d in enumerate(np.asarray(refined["design"], dtype=np.int64)):
        j = pos.get(int(d))
        if j is None or str(out["status"][j]) != "ok":
            continue  # only a finished original is refined
        meta = json.loads(str(out["meta"][j]) or "{}")
        if "refinement" in meta:
            continue
        cell = cell_of(int(d))
        old_path = _row_path(out, j)
        pc_old, kind_old = _critical(old_path, cell, kind)
        rmeta = json.loads(str(refined["meta"][r]) or "{}") if "meta" in refined else {}
        note: dict[str, Any] = {
            "reason": REASON, "options": rmeta.get("continuation", dict(REFINEMENT)),
            "previous": {"critical_pressure": pc_old, "critical_kind": kind_old,
                         "points": meta.get("points"), "status": meta.get("status"),
                         "stop_reason": meta.get("stop_reason"),
                         "wall_time": meta.get("wall_time")}}
        if str(refined["status"][r]) != "ok":
            note["error"] = str(refined["error"][r])
            meta["refinement"] = note
            out["meta"][j] = json.dumps(meta, sort_keys=True)
            continue
        new_path = _row_path(refined, r)
        pc_new, kind_new = _critical(new_path, cell, kind)
        note.update(critical_pressure=pc_new, critical_kind=kind_new,
                    turned_again=turned_at_critical(new_path, pc_new, kind_new))
        if pc_new is None and pc_old is not None:
            # the finer path reads no Pc where the coarser read one (it wanders past the
            # old limit point, through more folds than the reading resolves): the old
            # path's first fold stays the label
            note["kept"] = KEPT_NO_PC
            meta["refinement"] = note
            out["meta"][j] = json.dumps(meta, sort_keys=True)
            continue
        for k, v in refined.items():
            if k == "design":
                continue
            v = np.asarray(v)
            if out[k].ndim == 2:
                out[k][j] = _fill(out[k].dtype)
                out[k][j, :v.shape[1]] = v[r]
            else:
                out[k][j] = v[r]
        for k in set(out) - set(refined) - {"design"}:  # only the original had it: gone
            out[k][j] = _fill(out[k].dtype)
        rmeta["refinement"] = note
        out["meta"][j] = json.dumps(rmeta, sort_keys=True)
    return out


def refine_set(spec: Any, ref: Any, folder: str | Path, *, workers: int | None = None,
               progress: Callable[[int, int], None] | None = None) -> Any:
    """Run the candidates of a set (its sweep spec ``spec``, collected as ``ref``) again
    with :data:`REFINEMENT` into ``<folder>/refined/`` (resumable, like any sweep). Returns
    the :class:`~multimorph.sweep.SweepSummary`, or None when no design is a candidate."""
    from multimorph.sweep import run_sweep

    todo = candidates(ref)
    if not todo:
        return None
    return run_sweep(spec, Path(folder) / REFINED_FOLDER, designs=todo, options=REFINEMENT,
                     workers=workers, progress=progress)
