"""The 3D FE of a designed device as the checking model of a space-mapped design.

:func:`fe_checker` builds a :data:`~multimorph.design.Checker` that inflates a design in 3D
FE to the target's maximum pressure and measures each stage's module: Pc and Ph on the
module's own signal, its motion at Ph (bend angle in the module frame, twist angle, or
axial stretch − 1) and its peak stretch at the top. The scores use the same rules as the
model's (:func:`~multimorph.design.score_measured`). The device is the one its
``device.toml`` describes (lengths rounded to 0.01 mm). Two routes (:data:`FE_ROUTES`):

``modules`` (the default)
    Each stage's module on its own, clamped at its start, on the common pressure: a bending
    or stretching module as its cells in series (:func:`multimorph.fe.simulate_cell` with
    ``n_cells``, the FE reference data set's mesh: 2 elements through every wall, in-plane
    edges d/20; its far end tied to a rigid plate where the device joins it to the next
    module or a hub, free at a tip: :func:`module_end`). A twisting module (``twist``,
    :data:`TWIST_ROUTES`) as one tilted cell of its strips in FE, as inside a strip (the
    tilted FE data set's cell: full model, its far end tied to a rigid plate, in-plane edges
    d/16), whose in-plane strip shear γ(P) the module's shaft kinematics turn into its twist
    (τ = γ / R, :func:`multimorph.device.path_strains`, as the cell models' twisting
    modules do) — ``"strip"``, the default — or as its strips around the shaft in one FE
    problem (:func:`multimorph.fe.simulate_twisting_module`, ``"shaft"``: the shaft's
    torsion and the strips' ends in FE too, but on this 2-core machine hours for one
    module: the gripper's twister took 7 min to mesh and 11 min for its first 3 points).
    On one pressure line
    each module's state is its own equilibrium at that pressure; its neighbours move its
    base as a rigid body (series) or not at all (fingers on a hub), so the stages are those
    of the device up to the coupling through the shared end walls, which this route
    leaves out.
``device``
    The whole device as one problem (series modules, fingers on their hub, twisting
    modules on their shaft: :func:`multimorph.fe.simulate_device`). Under pressure control
    a device snaps at its first module's limit point, and the arc-length path of the whole
    device stops there: measured on the jar lifter, it stalled at the sealer's 68.9 kPa
    (coarse mesh) or turned back at a branch point (medium mesh), so the later stages got
    no FE reading. Use it where no module has a limit point before the last stage.

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
from multimorph.response import DEFINITIONS_VERSION

__all__ = ["FE_ROUTES", "TWIST_ROUTES", "as_written", "fe_checker", "fe_measure",
           "module_end", "module_measure", "strip_twist_response"]

FE_CHECK_FORMAT = "multimorph-fe-check/1"
#: How :func:`fe_checker` inflates a design (see the module docstring); the first is the
#: default.
FE_ROUTES = ("modules", "device")
#: How the ``modules`` route inflates a twisting module (see the module docstring); the
#: first is the default.
TWIST_ROUTES = ("strip", "shaft")


def _module_names(result: Any, stage_name: str) -> list[str]:
    names = [n for n in result.responses if n == stage_name
             or n.startswith(f"{stage_name}#")]
    if not names:
        raise MultimorphError(f"device FE: no module {stage_name!r} in the result "
                              f"({', '.join(sorted(result.responses))})")
    return names


def _stage_row(stage: Any, sr: Any, cell: Any, starts: list[Any], ends: list[Any],
               mags: list[float], peaks: list[Any], top: float) -> dict[str, Any]:
    def mean(values: list[Any]) -> float | None:
        if any(v is None for v in values):
            return None
        return float(np.mean(values))

    peak = mean(peaks)
    brk = [m.break_stretch for m in (cell.material, cell.bottom_material)
           if m is not None and m.break_stretch]
    return {"name": stage.name, "start": mean(starts), "end": mean(ends),
            "magnitude": float(np.mean(mags)), "n_cells": sr.n_cells, "peak_stretch": peak,
            "safety_factor": (min(brk) / peak) if (brk and peak) else None,
            "top_pressure": top}


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
        out.append(_stage_row(stage, sr, cell, starts, ends, mags, peaks,
                              float(np.max(result.pressure))))
    return out


def module_measure(kind: str, response: Any, length: float, p_max: float,
                   ) -> tuple[float | None, float | None, float, float | None]:
    """(Pc, Ph, motion at Ph, peak stretch) of one module's FE response on its own (the
    ``modules`` route): Pc and Ph as the device FE reads them (:func:`multimorph.fe.
    analyses.activation`; ``None`` above ``p_max`` or not reached), the motion at Ph — or at
    the top of the stable loading curve where there is no Ph — as the bend angle κL, the
    twist angle (twist rate × L) or the axial stretch − 1 (``kind``: bend, twist, stretch)."""
    from multimorph.fe.analyses import activation

    pc, ph = activation(response)
    pc = pc if pc is not None and pc <= p_max else None
    ph = ph if ph is not None and ph <= p_max else None
    lo = response.loading
    P = np.asarray(lo.pressure, float)
    if not len(P):
        return pc, ph, 0.0, None
    at = float(ph) if ph is not None else float(P[-1])
    keep = np.concatenate([[True], np.diff(P) > 0])

    def value(y: Any) -> float:
        return float(np.interp(at, P[keep], np.asarray(y, float)[keep]))

    if kind == "bend":
        mag = abs(value(lo.curvature)) * length
    elif kind == "twist":
        mag = abs(value(lo.twist_rate)) * length
    else:
        mag = value(lo.axial_stretch) - 1.0
    return pc, ph, mag, float(np.max(lo.peak_stretch))


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


#: The ``modules`` route's mesh of bending and stretching modules: the FE reference data
#: set's (2 elements through every wall, in-plane edges d/20; Pc within 3 % of a finer
#: mesh, docs/validation.md), so that the check and the calibration see the same FE.
MODULE_WALL_ELEMENTS = 2
MODULE_LENGTH_FRACTION = 0.05
#: The ``strip`` twist route's in-plane edge (a fraction of d): the tilted FE data set's.
STRIP_LENGTH_FRACTION = 0.0625
#: The ``modules`` route's most continuation points per module (the data set's 150 with
#: room for the longer paths of modules of several cells).
MODULE_MAX_STEPS = 250


#: The ``modules`` route inflates a bending or stretching module of more cells by this
#: many of them (see :func:`fe_checker`): the jar lifter's 25-cell lifter (156k free DOF)
#: had not finished its ballooning after 73 min.
MODULE_FE_MAX_CELLS = 3

#: Chamber volume ratio at which a module's FE path stops (see :func:`fe_checker`).
MODULE_MAX_VOLUME_RATIO = 25.0
#: The same for the whole device in one FE problem (any of its modules' chambers).
DEVICE_MAX_VOLUME_RATIO = 60.0


def fe_checker(folder: str | Path, *, mesh: str = "coarse",
               wall_elements: int | None = None, max_steps: int = 400,
               max_volume_ratio: float | None = None, dx_max: float = 0.04,
               route: str = "modules", twist: str = "strip",
               progress: Callable[[str], None] | None = None,
               records: list[dict[str, Any]] | None = None) -> Callable[..., list[Evaluation]]:
    """A checker (see :func:`~multimorph.design.mapped_design`) that runs the FE of the
    first design it is given (FE checks one design a round) and scores it.

    Parameters
    ----------
    folder : path
        Where each design's measurements (``<key>.json``) and resume points
        (``<key>.resume``; on the ``modules`` route each module's in ``<key>.modules/``)
        are kept.
    route : {"modules", "device"}
        Each stage's module on its own, or the whole device as one problem
        (:data:`FE_ROUTES`, the module docstring says why ``modules`` is the default).
    twist : {"strip", "shaft"}
        On the ``modules`` route, a twisting module as one tilted cell of its strips with
        the module's shaft kinematics, or as its strips on the shaft in one FE problem
        (:data:`TWIST_ROUTES`).
    mesh, wall_elements, max_steps, max_volume_ratio, dx_max
        FE settings of the ``device`` route and of twisting modules
        (:class:`multimorph.fe.FESettings`); bending and stretching modules on the
        ``modules`` route take the data set's mesh (:data:`MODULE_WALL_ELEMENTS`, or
        ``wall_elements``, and :data:`MODULE_LENGTH_FRACTION`) and at most
        :data:`MODULE_MAX_STEPS` points; one of more than :data:`MODULE_FE_MAX_CELLS` cells
        is inflated as that many of its cells with the module's end (its motion per
        length is the module's; the run's statistics say ``fe_cells`` of
        ``module_cells``). The path stops where a module's
        chambers reach ``max_volume_ratio`` × their volume; by default 25 on the
        ``modules`` route (as the FE data set's cells: well past every hardening knee,
        before the slow creep of a fully ballooned chamber) and
        :data:`DEVICE_MAX_VOLUME_RATIO` on the ``device`` route, where the first module
        to activate passes 25 long before a later one hardens (a small two-stage device:
        its seal at 25 × at 23.4 kPa, its stalk activated at 21.5 kPa and not yet at its
        knee). The arc-length
        step may move a node 0.04 d (the default 0.01 d took 145 points, 20 min, for the
        jar lifter's seal to reach its limit point at 51k DOF).
    progress : callable, optional
        ``progress(text)`` at the start and end of each FE run and every few points.
    records : list, optional
        Receives one dict per FE run (key, file, wall time, stages measured).
    """
    folder = Path(folder)
    if route not in FE_ROUTES:
        raise MultimorphError(f"--fe-route: expected one of {', '.join(FE_ROUTES)}, got "
                              f"{route!r}")
    if twist not in TWIST_ROUTES:
        raise MultimorphError(f"--fe-twist: expected one of {', '.join(TWIST_ROUTES)}, got "
                              f"{twist!r}")

    def check(target: TargetSpec, evs: Sequence[Evaluation]) -> list[Evaluation]:
        if not evs:
            return []
        import time

        from multimorph.fe import FESettings, PathCheckpoint, simulate_device

        ev = evs[0]
        pmax = target.constraints.max_pressure
        ratio = max_volume_ratio if max_volume_ratio is not None else (
            DEVICE_MAX_VOLUME_RATIO if route == "device" else MODULE_MAX_VOLUME_RATIO)
        kw: dict[str, Any] = {"mesh": mesh, "p_max": pmax, "max_steps": max_steps,
                              "max_volume_ratio": ratio, "dx_max": dx_max}
        # (the modules route's measure: since stop 27 a free tip's bend is read without the
        # edge under its end wall; earlier results are not re-used)
        options = {**kw, "wall_elements": wall_elements, "definitions": DEFINITIONS_VERSION,
                   **({"route": route, "tip": "inner-edge",
                       **({"twist": twist} if twist != "shaft" else {})}
                      if route != "device" else {})}
        key = _fingerprint(ev, options)
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
        ckpt = None
        if route == "modules":
            rows, stats = _modules_route(target, ev, kw, folder, key, progress,
                                         wall_elements, twist, options)
            label = "module FE"
            points = sum(int(st["points"]) for st in stats.values())
            top = min(r["top_pressure"] for r in rows)
            done_text = f"{len(rows)} modules"
        else:
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
            stats = {k: v for k, v in result.stats.items()
                     if isinstance(v, (int, float, str, bool)) or v is None}
            label = "device FE"
            points = len(result.pressure)
            top = float(np.max(result.pressure))
            done_text = f"{points} points"
        saved = {"format": FE_CHECK_FORMAT, "key": key, "route": route, "settings": kw,
                 "wall_time_s": time.perf_counter() - t0, "points": points,
                 "top_pressure": top, "stats": stats, "stages": rows}
        _save(done, saved)
        if ckpt is not None:
            ckpt.clear()
        if progress is not None:
            progress(f"{label} {key}: done in {saved['wall_time_s']:.0f} s, {done_text}")
        if records is not None:
            records.append({**saved, "reused": False})
        return [_score(target, ev, rows)]

    return check


def _save(path: Path, saved: dict[str, Any]) -> None:
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(saved, indent=1, default=_jsonable))
    tmp.replace(path)


def _modules_route(target: TargetSpec, ev: Evaluation, kw: dict[str, Any], folder: Path,
                   key: str, progress: Callable[[str], None] | None,
                   wall_elements: int | None = None, twist: str = "strip",
                   options: dict[str, Any] | None = None,
                   ) -> tuple[list[dict[str, Any]], dict[str, dict[str, Any]]]:
    """Each stage's module inflated on its own (the ``modules`` route): its rows as
    :func:`fe_measure` gives them and each run's statistics. Every finished module is kept
    in ``modules/<module key>.json`` (the key: the module as written, its end and the FE
    settings, :func:`module_key`; another design with the same module re-uses it) and a
    running one's points beside it (``<module key>.resume``), so an interrupted check
    resumes module by module. Modules of earlier runs, kept per design in
    ``<key>.modules/<module>.json``, are re-used too."""
    import time
    from dataclasses import replace

    from multimorph.fe import (
        FESettings,
        MeshDensity,
        PathCheckpoint,
        simulate_cell,
        simulate_twisting_module,
    )

    device = as_written(ev)
    pmax = target.constraints.max_pressure
    rows, stats = [], {}
    for stage, sr, cell in zip(target.stages, ev.stages, ev.candidate.cells, strict=True):
        module = device.module(stage.name)
        end = module_end(device, stage.name)
        if module.kind == "twisting":
            end = "strip" if twist == "strip" else "shaft"
        legacy = folder / f"{key}.modules" / f"{_slug(stage.name)}-{end}.json"
        described = module_description(module, end)
        mkey = module_key(described, options if options is not None else kw)
        part = folder / "modules" / f"{mkey}.json"
        part.parent.mkdir(parents=True, exist_ok=True)
        found = next((f for f in (part, legacy) if f.exists()), None)
        if found is not None:
            saved = json.loads(found.read_text())
            rows.append({**saved["row"], "name": stage.name})
            stats[stage.name] = saved["stats"]
            if progress is not None:
                progress(f"module FE {mkey if found is part else key}: {stage.name} "
                         "finished earlier, re-used")
            continue
        t0 = time.perf_counter()
        last = [0.0]

        def tick(p: float, n: int, name: str = stage.name, t0: float = t0,
                 last: list[float] = last) -> None:
            if progress is not None and time.perf_counter() - last[0] > 30:
                last[0] = time.perf_counter()
                progress(f"module FE {key}: {name}: {n} points, {p / 1e3:.4g} kPa, "
                         f"{time.perf_counter() - t0:.0f} s")

        if progress is not None:
            progress(f"module FE {key}: {stage.name} ({module.kind}, {module.n_cells} cells) "
                     f"to {pmax / 1e3:.4g} kPa")
        ckpt = PathCheckpoint(part.with_suffix(".resume"), mkey)
        if module.kind == "twisting" and twist == "strip":
            settings = FESettings(**{**kw, "half": False,
                                     "max_steps": min(kw["max_steps"], MODULE_MAX_STEPS),
                                     "mesh": MeshDensity(
                                         wall_elements=wall_elements or MODULE_WALL_ELEMENTS,
                                         length_fraction=STRIP_LENGTH_FRACTION)})
            res = simulate_cell(module.cell, settings, n_cells=1, tilt=module.tilt,
                                progress=tick, checkpoint=ckpt, end="plate")
            response, length = strip_twist_response(module, res.response), module.length
        elif module.kind == "twisting":
            res = simulate_twisting_module(replace(module, start=0.0), FESettings(**kw),
                                           p_max=pmax, progress=tick, checkpoint=ckpt)
            response, length = res.response, module.length
        else:
            settings = FESettings(**{**kw, "max_steps": min(kw["max_steps"],
                                                            MODULE_MAX_STEPS),
                                     "mesh": MeshDensity(
                                         wall_elements=wall_elements or MODULE_WALL_ELEMENTS,
                                         length_fraction=MODULE_LENGTH_FRACTION)})
            # a long module by a few of its cells: cells in series bend and stretch alike
            # (the 4-cell bending module's FE Pc is within 0.3 % of one cell's as inside a
            # module), its end held as the whole module's; the motion per length is the
            # module's, read on the module's length
            res = simulate_cell(module.cell, settings,
                                n_cells=min(module.n_cells, MODULE_FE_MAX_CELLS),
                                progress=tick, checkpoint=ckpt, end=end)
            response, length = res.response, module.length
        pc, ph, mag, peak = module_measure(stage.kind, response, length, pmax)
        top = float(np.max(response.loading.pressure))
        row = _stage_row(stage, sr, cell, [pc], [ph], [mag], [peak], top)
        st = {k: v for k, v in res.stats.items()
              if isinstance(v, (int, float, str, bool)) or v is None}
        st["wall_time_s"] = time.perf_counter() - t0
        st["end"] = end
        st["fe_cells"] = (min(module.n_cells, MODULE_FE_MAX_CELLS)
                          if module.kind != "twisting" else 1 if twist == "strip" else
                          module.n_cells)
        st["module_cells"] = module.n_cells
        _save(part, {"format": FE_CHECK_FORMAT, "key": mkey, "device_key": key,
                     "module": stage.name, "description": described, "row": row,
                     "stats": st})
        ckpt.clear()
        rows.append(row)
        stats[stage.name] = st
    return rows, stats


def strip_twist_response(module: Any, cell_response: Any) -> Any:
    """A twisting module's response from the FE of one tilted cell of its strips
    (:func:`multimorph.fe.simulate_cell` with ``tilt``, a full model): the strip's in-plane
    shear γ in the sense of the tilt, turned into the module's twist rate |τ| = γ / R by the
    module's shaft kinematics (:func:`multimorph.device.path_strains`), on the module's
    length; Pc and Ph read on it are the strip shear's (a constant factor does not move
    them)."""
    from dataclasses import replace

    from multimorph.device import path_strains
    from multimorph.response import build_response

    path = cell_response.path
    extra = dict(path.extra or {})
    if "shear" not in extra:
        raise MultimorphError("strip FE: the tilted cell's path has no strip shear (a full "
                              "model records it)")
    sense = -math.copysign(1.0, module.tilt)  # the FE shear's sign against the tilt's sense
    gamma = sense * np.asarray(extra["shear"], float)
    extra["shear"] = gamma
    tau = path_strains(module, replace(path, extra=extra))["twist"]
    twist = math.copysign(1.0, module.tilt) * np.asarray(tau, float)  # in the tilt's sense
    return build_response(replace(path, twist_rate=twist, extra=extra), length=module.length,
                          shear_modulus=cell_response.shear_modulus, backend="fe",
                          break_stretch=module.cell.material.break_stretch,
                          signal="twist_rate",
                          meta={**cell_response.meta, "module": module.name,
                                "kind": module.kind, "fe_twist": "strip"})


#: The cell's lengths a module's FE depends on (with its materials, kind, count and end).
_CELL_LENGTHS = ("length", "width", "height", "top_wall", "bottom_wall", "side_wall",
                 "end_wall")


def module_description(module: Any, end: str) -> dict[str, Any]:
    """What a module's FE on the ``modules`` route depends on, as plain data (SI): its
    cell's lengths and materials (law, parameters, stretch at break), its kind and cell
    count, its end (:func:`module_end`; ``strip``/``shaft`` for a twisting module) and a
    twisting module's tilt, shaft radius and strips. Kept with each module's FE result, so
    a later fit can read the FE-checked cells (the tilted ones are the FE data set's cell:
    one tilted cell tied to a plate, its mesh)."""
    c = module.cell
    mats = []
    for m in (c.material, c.bottom_material):
        mats.append(None if m is None else {
            "name": m.name, "model": m.model,
            "params": {k: float(v) for k, v in sorted(m.params.items())},
            "break_stretch": None if m.break_stretch is None else float(m.break_stretch)})
    out: dict[str, Any] = {"kind": module.kind, "cells": int(module.n_cells), "end": end,
                           "cell": {k: float(getattr(c, k)) for k in _CELL_LENGTHS},
                           "material": mats[0], "bottom_material": mats[1]}
    if module.kind == "twisting":
        out.update(tilt=float(module.tilt), shaft_radius=float(module.shaft_radius),
                   strips=int(module.strips))
    return out


def module_key(description: dict[str, Any], options: dict[str, Any]) -> str:
    """The key of one module's FE (:func:`module_description` and the FE settings)."""
    from multimorph import __version__

    h = hashlib.sha256(json.dumps(description, sort_keys=True).encode())
    h.update(json.dumps({**options, "version": __version__}, sort_keys=True,
                        default=str).encode())
    return "m" + h.hexdigest()[:15]


def module_end(device: Any, name: str) -> str:
    """How module ``name``'s far end is held when it is inflated on its own
    (:data:`multimorph.fe.analyses.CELL_ENDS`): ``"plate"`` where the device joins it to
    something there — the next module of its branch, or a branch (a hub of fingers) that
    starts at its end: that body holds the end face plane while it moves and turns — and
    ``"free"`` at a tip, where the end wall can bulge on its own."""
    module = device.module(name)
    branch = device.branches()[module.branch]
    if branch[-1].name != module.name:
        return "plate"
    return "plate" if any(m.attach_to == module.name for m in device.modules) else "free"


def _slug(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name)


def _jsonable(v: Any) -> Any:
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return str(v)
