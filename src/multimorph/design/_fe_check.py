"""The 3D FE of a designed device as the checking model of a space-mapped design.

:func:`fe_checker` builds a :data:`~multimorph.design.Checker` that meshes the whole device
of a design (series modules, fingers on their hub, twisting modules on their shaft: the
device FE of :func:`multimorph.fe.simulate_device`), inflates it to the target's maximum
pressure, and measures each stage's module: Pc and Ph on the module's own signal, its
motion at Ph (bend angle in the module frame, twist angle, or axial stretch − 1) and its
peak stretch at the top. The scores use the same rules as the model's
(:func:`~multimorph.design.score_measured`). The device is the one its ``device.toml``
describes (lengths rounded to 0.01 mm).

Resumable: each device's run is keyed by a fingerprint of its layout, the FE settings and
the code version. Its converged points are saved as they come (a killed run resumes from
them) and its measurements are kept in ``<folder>/<key>.json``, so running the same
design again (same target, seed and settings) re-uses every finished FE round.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from multimorph.design._evaluate import Evaluation, Measured, score_measured
from multimorph.design._target import TargetSpec
from multimorph.errors import MultimorphError

__all__ = ["as_written", "fe_checker", "fe_measure"]

FE_CHECK_FORMAT = "multimorph-fe-check/1"


def _module_names(result: Any, stage_name: str) -> list[str]:
    names = [n for n in result.responses if n == stage_name
             or n.startswith(f"{stage_name}#")]
    if not names:
        raise MultimorphError(f"device FE: no module {stage_name!r} in the result "
                              f"({', '.join(sorted(result.responses))})")
    return names


def fe_measure(target: TargetSpec, ev: Evaluation, result: Any) -> list[dict[str, Any]]:
    """Each stage's Pc, Ph, motion at Ph and peak stretch from a device FE result (SI;
    ``None`` where not reached; parallel copies averaged)."""
    pmax = target.constraints.max_pressure
    out = []
    for stage, sr, cell in zip(target.stages, ev.stages, ev.candidate.cells, strict=True):
        starts, ends, mags, peaks = [], [], [], []
        for name in _module_names(result, stage.name):
            pc, ph = result.activation(name)
            pc = pc if pc is not None and pc <= pmax else None
            ph = ph if ph is not None and ph <= pmax else None
            at = result.module_at(name, ph)
            if stage.kind == "bend":
                mag = abs(at["bend_angle"])
            elif stage.kind == "twist":
                mag = abs(at["twist_angle"])
            else:
                mag = at["axial_stretch"] - 1.0
            loading = result.responses[name].loading
            peaks.append(float(np.max(loading.peak_stretch)) if len(loading.pressure) else None)
            starts.append(pc)
            ends.append(ph)
            mags.append(mag)

        def mean(values: list[Any]) -> float | None:
            if any(v is None for v in values):
                return None
            return float(np.mean(values))

        peak = mean(peaks)
        brk = [m.break_stretch for m in (cell.material, cell.bottom_material)
               if m is not None and m.break_stretch]
        out.append({"name": stage.name, "start": mean(starts), "end": mean(ends),
                    "magnitude": float(np.mean(mags)), "n_cells": sr.n_cells,
                    "peak_stretch": peak,
                    "safety_factor": (min(brk) / peak) if (brk and peak) else None,
                    "top_pressure": float(np.max(result.pressure))})
    return out


def _score(target: TargetSpec, ev: Evaluation, rows: Sequence[dict[str, Any]]) -> Evaluation:
    measured = [Measured(r["start"], r["end"], r["magnitude"], int(r["n_cells"]),
                         r["safety_factor"], r["peak_stretch"],
                         traced_to=r.get("top_pressure")) for r in rows]
    return score_measured(target, ev.candidate, measured, device=ev.device)


def as_written(ev: Evaluation) -> Any:
    """The design's device as its ``device.toml`` gives it (lengths rounded to 0.01 mm):
    what the FE checks is what a user builds."""
    import tomllib

    from multimorph.design._report import device_toml
    from multimorph.device import device_from_spec

    return device_from_spec(tomllib.loads(device_toml(ev.device, header="")))


def _fingerprint(ev: Evaluation, options: dict[str, Any]) -> str:
    from multimorph import __version__
    from multimorph.design._report import device_toml

    if ev.device is None:
        raise MultimorphError("device FE: the design has no device layout")
    h = hashlib.sha256(device_toml(ev.device, header="").encode())
    h.update(json.dumps({**options, "version": __version__}, sort_keys=True,
                        default=str).encode())
    return h.hexdigest()[:16]


def fe_checker(folder: str | Path, *, mesh: str = "coarse",
               wall_elements: int | None = None, max_steps: int = 400,
               max_volume_ratio: float = 25.0, dx_max: float = 0.04,
               progress: Callable[[str], None] | None = None,
               records: list[dict[str, Any]] | None = None) -> Callable[..., list[Evaluation]]:
    """A checker (see :func:`~multimorph.design.mapped_design`) that runs the device FE of
    the first design it is given (FE checks one design a round) and scores it.

    Parameters
    ----------
    folder : path
        Where each device's measurements (``<key>.json``) and resume points
        (``<key>.resume``) are kept.
    mesh, wall_elements, max_steps, max_volume_ratio, dx_max
        FE settings (:class:`multimorph.fe.FESettings`); the path stops where a module's
        chambers reach 25 × their volume (as the FE data set's cells: well past every
        hardening knee, before the slow creep of a fully ballooned chamber). The arc-length
        step may move a node 0.04 d (the default 0.01 d took 145 points, 20 min, for the
        jar lifter's seal to reach its limit point at 51k DOF).
    progress : callable, optional
        ``progress(text)`` at the start and end of each FE run and every few points.
    records : list, optional
        Receives one dict per FE run (key, file, wall time, stages measured).
    """
    folder = Path(folder)

    def check(target: TargetSpec, evs: Sequence[Evaluation]) -> list[Evaluation]:
        if not evs:
            return []
        import time

        from multimorph.fe import FESettings, PathCheckpoint, simulate_device

        ev = evs[0]
        pmax = target.constraints.max_pressure
        kw: dict[str, Any] = {"mesh": mesh, "p_max": pmax, "max_steps": max_steps,
                              "max_volume_ratio": max_volume_ratio, "dx_max": dx_max}
        key = _fingerprint(ev, {**kw, "wall_elements": wall_elements})
        if wall_elements is not None:
            from dataclasses import replace as _replace

            from multimorph.fe.mesh import resolve_density

            kw["mesh"] = _replace(resolve_density(mesh), wall_elements=int(wall_elements))
        done = folder / f"{key}.json"
        if done.exists():
            saved = json.loads(done.read_text())
            if saved.get("format") == FE_CHECK_FORMAT:
                if progress is not None:
                    progress(f"device FE {key}: finished earlier, re-used")
                if records is not None:
                    records.append({**saved, "reused": True})
                return [_score(target, ev, saved["stages"])]
        folder.mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        if progress is not None:
            progress(f"device FE {key}: meshing and inflating to {pmax / 1e3:.4g} kPa")
        last = [0.0]

        def tick(p: float, n: int) -> None:
            if progress is not None and time.perf_counter() - last[0] > 30:
                last[0] = time.perf_counter()
                progress(f"device FE {key}: {n} points, {p / 1e3:.4g} kPa, "
                         f"{time.perf_counter() - t0:.0f} s")

        ckpt = PathCheckpoint(folder / f"{key}.resume", key)
        result = simulate_device(as_written(ev), FESettings(**kw), progress=tick,
                                 checkpoint=ckpt)
        rows = fe_measure(target, ev, result)
        saved = {"format": FE_CHECK_FORMAT, "key": key, "settings": kw,
                 "wall_time_s": time.perf_counter() - t0, "points": len(result.pressure),
                 "top_pressure": float(np.max(result.pressure)),
                 "stats": {k: v for k, v in result.stats.items()
                           if isinstance(v, (int, float, str, bool)) or v is None},
                 "stages": rows}
        tmp = done.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(saved, indent=1, default=_jsonable))
        tmp.replace(done)
        ckpt.clear()
        if progress is not None:
            progress(f"device FE {key}: done in {saved['wall_time_s']:.0f} s, "
                     f"{saved['points']} points")
        if records is not None:
            records.append({**saved, "reused": False})
        return [_score(target, ev, rows)]

    return check


def _jsonable(v: Any) -> Any:
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return str(v)
