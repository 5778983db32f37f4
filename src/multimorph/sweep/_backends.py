"""Sweep backends: the small interface a model implements to be swept, and the registry.

A backend evaluates a *batch* of designs at once::

    backend.evaluate_batch(designs, pmax, outputs, options) -> list[Response | Mapping | Exception]

one entry per design, in order: a :class:`~multimorph.response.Response`, a mapping already in
record form (see :func:`record_from_response`), or an exception instance for a design that
failed (its message is stored; the sweep goes on). ``batch_size`` is the backend's preferred
number of designs per Dask task (large for the batched reduced model, 1 for FE).

Built in: ``"rom"`` (the batched reduced-order model, :mod:`multimorph.rom`) and ``"fe"`` (the
finite-element model, :mod:`multimorph.fe`, one design per task). Other backends (for example
a test-only analytic model) are added with :func:`register_backend`. Backend objects travel to
Dask workers by pickling, so they must be picklable (plain classes at module level are).
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np

from multimorph.errors import MultimorphError, SpecError
from multimorph.geometry import CellGeometry, TiltedCell

__all__ = ["CURVE_VARS", "ENTRY_POINT_GROUP", "EXTRA_CURVE_VARS", "FE_EXTRA_OPTIONS", "SCALAR_VARS",
           "SweepBackend", "evaluate_designs", "get_backend", "known_backends", "load_plugin",
           "record_from_response", "register_backend", "tilted_shear"]

#: Per-design scalar outputs (Pa or 1/m; NaN when not reached) of ``"characteristic"``.
SCALAR_VARS = ("critical_pressure", "hardening_pressure", "failure_pressure",
               "curvature_at_critical", "curvature_at_hardening", "curvature_at_failure")
#: Per-point curve outputs of ``"curves"``: the whole equilibrium path.
CURVE_VARS = ("pressure", "curvature", "peak_stretch", "stable")
#: Further per-point curves stored when a backend gives them (NaN elsewhere): the bottom
#: edge's axial stretch (-), the chamber volume (m³), the free end's bend angle (rad), the
#: strip's in-plane shear in the sense of its tilt (tilted cells, -) and the twist rate (1/m).
EXTRA_CURVE_VARS = ("axial_stretch", "volume", "bend_angle", "shear", "twist_rate")


@runtime_checkable
class SweepBackend(Protocol):
    """What :func:`multimorph.sweep.run_sweep` needs from a model."""

    name: str
    batch_size: int

    def evaluate_batch(self, designs: Sequence[CellGeometry], pmax: float,
                       outputs: Sequence[str], options: Mapping[str, Any]) -> list[Any]:
        """Evaluate ``designs`` up to pressure ``pmax`` (Pa); one entry per design."""
        ...


_REGISTRY: dict[str, Callable[[], SweepBackend]] = {}


def register_backend(name: str, factory: Callable[[], SweepBackend]) -> None:
    """Make ``factory()`` available as ``[sweep] backend = name``."""
    _REGISTRY[name] = factory


#: Entry-point group through which installed packages register sweep backends
#: (``[project.entry-points."multimorph.sweep_backends"] name = "pkg.module:factory"``).
ENTRY_POINT_GROUP = "multimorph.sweep_backends"


def _entry_points() -> dict[str, Any]:
    from importlib.metadata import entry_points

    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def load_plugin(path: str) -> Callable[[], SweepBackend]:
    """Import the backend factory ``"package.module:factory"`` named on the command line.

    Only for an explicit ``--allow-plugin`` (a spec file is data and never imports code).

    Raises
    ------
    SpecError
        Malformed path, module not importable, or the attribute is not callable.
    """
    mod, sep, attr = str(path).partition(":")
    where = f"--allow-plugin {path!r}"
    if not sep or not mod.strip() or not attr.strip():
        raise SpecError(f"{where}: expected MODULE:CALLABLE, e.g. mypackage.sweep:MyBackend")
    try:
        factory = getattr(importlib.import_module(mod.strip()), attr.strip())
    except (ImportError, AttributeError) as exc:
        raise SpecError(f"{where}: cannot import it ({exc})") from None
    if not callable(factory):
        raise SpecError(f"{where}: {attr.strip()} is not a class or function "
                        f"({type(factory).__name__})")
    return factory  # type: ignore[no-any-return]


def known_backends() -> list[str]:
    """Names a spec may give as ``[sweep] backend``: built in, registered, entry points."""
    return sorted(set(_REGISTRY) | set(_entry_points()))


def get_backend(name: str, *, plugins: Sequence[str] = ()) -> SweepBackend:
    """The backend called ``name``: ``"rom"``, ``"fe"``, one registered with
    :func:`register_backend`, one installed under the entry-point group
    :data:`ENTRY_POINT_GROUP`, or an import path ``"package.module:factory"`` *only if* it
    is one of ``plugins`` (the command line's ``--allow-plugin``: a spec file alone never
    makes multimorph import and run code).

    Raises
    ------
    SpecError
        Unknown name (the message lists the known ones), or a factory that does not make a
        backend.
    """
    if not isinstance(name, str):
        raise SpecError(f"sweep.backend: expected a backend name, got {name!r}")
    if name in _REGISTRY:
        return _REGISTRY[name]()
    eps = _entry_points()
    if name in eps:
        factory = eps[name].load()
    elif name in plugins:
        factory = load_plugin(name)
    else:
        why = (" (a MODULE:CALLABLE backend is imported only when the command line allows "
               "it with --allow-plugin MODULE:CALLABLE; a spec file cannot run code)"
               if ":" in name else "")
        raise SpecError(f"sweep.backend: unknown backend {name!r}; known: "
                        f"{', '.join(known_backends())}{why}")
    backend = factory()
    if not isinstance(backend, SweepBackend):
        raise SpecError(f"sweep.backend {name!r}: {factory!r} did not return a sweep backend "
                        "(needs name, batch_size and evaluate_batch)")
    return backend


def _f(x: Any) -> float:
    return math.nan if x is None else float(x)


def record_from_response(resp: Any, outputs: Sequence[str]) -> dict[str, Any]:
    """Convert a :class:`~multimorph.response.Response` to a flat record (SI, NaN for None)."""
    rec: dict[str, Any] = {}
    if "characteristic" in outputs:
        ch = resp.characteristic
        at = ch.curvature_at or {}
        rec.update(critical_pressure=_f(ch.critical), hardening_pressure=_f(ch.hardening),
                   failure_pressure=_f(ch.failure), critical_kind=ch.critical_kind or "",
                   curvature_at_critical=_f(at.get("critical")),
                   curvature_at_hardening=_f(at.get("hardening")),
                   curvature_at_failure=_f(at.get("failure")))
    if "curves" in outputs:
        path = resp.path
        rec.update(pressure=np.asarray(path.pressure, float),
                   curvature=np.asarray(path.curvature, float),
                   peak_stretch=np.asarray(path.peak_stretch, float),
                   stable=np.asarray(path.stable, bool),
                   axial_stretch=np.asarray(path.axial_stretch, float),
                   volume=np.asarray(path.volume, float))
        extra = path.extra or {}
        if "bend_angle" in extra:
            rec["bend_angle"] = np.asarray(extra["bend_angle"], float)
        if resp.backend == "fe":
            rec["twist_rate"] = np.asarray(path.twist_rate, float)
    return rec


def _tilted_record(resp: Any, shear: np.ndarray, outputs: Sequence[str],
                   meta: Mapping[str, Any], cell: TiltedCell) -> dict[str, Any]:
    """The record of a tilted cell: the straight response's curves plus the strip's shear
    (in the sense of its tilt), with Pc, Ph and failure (at the wall's break stretch) read
    on the shear."""
    from dataclasses import replace

    from multimorph.response import build_response

    path = replace(resp.path, twist_rate=np.asarray(shear, float))
    tilted = build_response(path, length=resp.length, shear_modulus=resp.shear_modulus,
                            backend=resp.backend,
                            break_stretch=cell.cell.material.break_stretch,
                            signal="twist_rate", meta=dict(resp.meta))
    rec = record_from_response(tilted, outputs)
    if "curves" in outputs:
        rec["shear"] = np.asarray(shear, float)
        rec["twist_rate"] = np.full(len(shear), np.nan)
    rec["meta"] = dict(meta)
    return rec


def _normalise(item: Any, outputs: Sequence[str]) -> dict[str, Any]:
    if isinstance(item, BaseException):
        return {"status": "failed", "error": f"{type(item).__name__}: {item}"}
    if isinstance(item, Mapping):
        rec = dict(item)
    else:
        rec = record_from_response(item, outputs)
    rec.setdefault("status", "ok")
    rec.setdefault("error", "")
    return rec


def tilted_shear(resp: Any, cell: CellGeometry, tilt: float) -> np.ndarray:
    """The reduced model's strip shear of a tilted cell, in the sense of its tilt:
    γ = ε sin 2|β| with ε = λ_mid − 1 the straight cell's mid-height natural strain (the
    twisting module's kinematics, :mod:`multimorph.device`)."""
    path = resp.path
    lam = np.asarray(path.axial_stretch) * (1.0 + np.asarray(path.curvature) * 0.5
                                            * cell.height)
    return (lam - 1.0) * math.sin(2.0 * abs(tilt))


def evaluate_designs(backend: SweepBackend, designs: Sequence[CellGeometry], pmax: float,
                     outputs: Sequence[str], options: Mapping[str, Any], *,
                     pad_to: int | None = None) -> list[dict[str, Any]]:
    """Evaluate a batch; a failing batch is retried design by design so one bad design fails
    alone. Never raises for a design's error: it is returned as a ``"failed"`` record.

    If the backend sets ``pad_batches = True`` (a jitted model compiles once per batch
    shape), a short batch is padded to ``pad_to`` designs by repeating its last design and
    the padding is dropped from the results.
    """
    n = len(designs)
    padded = list(designs)
    if getattr(backend, "pad_batches", False) and pad_to is not None and 0 < n < pad_to:
        padded += [designs[-1]] * (pad_to - n)
    try:
        out = list(backend.evaluate_batch(padded, pmax, outputs, options))[:n]
        if len(out) != len(designs):
            raise MultimorphError(f"backend {backend.name} returned {len(out)} results for "
                                  f"{len(designs)} designs")
    except Exception as exc:
        if len(designs) == 1:
            out = [exc]
        else:
            out = []
            for d in designs:
                try:
                    out.extend(backend.evaluate_batch([d], pmax, outputs, options))
                except Exception as exc1:
                    out.append(exc1)
    return [_normalise(r, outputs) for r in out]


# ------------------------------------------------------------------ built-in adapters
def _import_model(module: str, issue: str) -> Any:
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if exc.name is not None and module.startswith(exc.name):
            raise MultimorphError(
                f"sweep backend needs {module}, which is not available in this installation "
                f"({issue})") from None
        raise MultimorphError(
            f"sweep backend: importing {module} failed: missing dependency {exc.name!r} "
            "(install the matching extra, e.g. pip install 'multimorph[fe]')") from None


#: Names tried, in order, for the reduced model's batched entry point
#: ``fn(cells, p_max, **options) -> list[Response | Exception]``.
ROM_BATCH_NAMES = ("simulate_batch", "simulate_cells", "evaluate_batch")
#: Names tried for the single-design entry point ``fn(cell, p_max, **options) -> Response``.
ROM_SINGLE_NAMES = ("solve_cell", "simulate_cell")


class RomBackend:
    """The batched reduced-order model (:mod:`multimorph.rom`), many designs per task.

    Calls the model's batched entry point (one vmapped, jitted call per batch; see
    :data:`ROM_BATCH_NAMES`), or its single-design ``simulate_cell`` in a loop if it has no
    batched one. Batches are padded to the sweep's batch size (``pad_batches``) so the jitted
    model compiles once per worker. ``options`` are passed to the model as keyword arguments.
    """

    name = "rom"
    batch_size = 256

    @property
    def pad_batches(self) -> bool:
        """Pad short batches only for the batched (jitted) entry point."""
        return self._api()[1]

    @staticmethod
    def _api() -> tuple[Any, bool]:
        rom = _import_model("multimorph.rom", "the reduced model of issue 3")
        for n in ROM_BATCH_NAMES:
            if callable(getattr(rom, n, None)):
                return getattr(rom, n), True
        for n in ROM_SINGLE_NAMES:
            if callable(getattr(rom, n, None)):
                return getattr(rom, n), False
        raise MultimorphError(f"multimorph.rom has no entry point ({', '.join(ROM_SINGLE_NAMES)}"
                              f", or batched {', '.join(ROM_BATCH_NAMES)}) yet (issue 3)")

    def validate(self, pmax: float, options: Mapping[str, Any]) -> None:
        """Check that the model is there and ``options`` are :class:`~multimorph.rom.RomOptions`
        fields of the right types (before any task runs; SpecError naming the key)."""
        self._api()
        import dataclasses

        from multimorph.rom import RomOptions

        fields = {f.name: f.default for f in dataclasses.fields(RomOptions)}
        for key, value in options.items():
            if key not in fields:
                raise SpecError(f"sweep.options.{key}: not a reduced-model option; known: "
                                f"{', '.join(sorted(fields))}")
            default = fields[key]
            if isinstance(default, bool):
                ok = isinstance(value, bool)
            elif isinstance(default, int):
                ok = isinstance(value, int) and not isinstance(value, bool) and 1 <= value <= 64
            else:
                ok = (isinstance(value, int | float) and not isinstance(value, bool)
                      and math.isfinite(value) and value > 0)
            if not ok:
                raise SpecError(f"sweep.options.{key}: expected "
                                f"{type(default).__name__} like {default!r}, got {value!r}")

    def evaluate_batch(self, designs: Sequence[CellGeometry | TiltedCell], pmax: float,
                       outputs: Sequence[str], options: Mapping[str, Any]) -> list[Any]:
        fn, batched = self._api()
        cells = [d.cell if isinstance(d, TiltedCell) else d for d in designs]
        if batched:
            out = list(fn(cells, pmax, **dict(options)))
        else:
            out = []
            for c in cells:
                try:
                    out.append(fn(c, pmax, **dict(options)))
                except Exception as exc:
                    out.append(exc)
        for i, d in enumerate(designs):  # a tilted cell: the straight one's shear rule
            if isinstance(d, TiltedCell) and not isinstance(out[i], BaseException):
                out[i] = _tilted_record(out[i], tilted_shear(out[i], d.cell, d.tilt),
                                        outputs, {"model": "ritz"}, d)
        return out


#: ``[sweep.options]`` of the FE backend that are not :class:`multimorph.fe.FESettings`
#: fields: cells in series (a module of ``n_cells``), the mesh density as elements through
#: every wall and in-plane edge length / d, and how far each path is traced.
FE_EXTRA_OPTIONS = ("n_cells", "end", "wall_elements", "length_fraction", "pmax_rule",
                    "pmax_factor")


class FeBackend:
    """The finite-element model (:func:`multimorph.fe.simulate_cell`), one design per task.

    ``options`` are :class:`multimorph.fe.FESettings` fields (``mesh``, ``method``, ``tol`` …)
    and :data:`FE_EXTRA_OPTIONS`:

    * ``n_cells`` (default 1): the design is run as a module of that many cells in series;
    * ``end`` (``"free"``, default, ``"plate"`` or ``"mirror"``): how the free end is held
      (:data:`multimorph.fe.CELL_ENDS`; a plate ties the end section rigidly, mirror ends
      keep both end sections plane but free to stretch in their planes: the periodic cell
      of a long module);
    * ``wall_elements``, ``length_fraction``: a :class:`multimorph.fe.MeshDensity` in place
      of the ``mesh`` preset;
    * ``pmax_rule = "rom"`` with ``pmax_factor`` f (default 1): each design is traced to
      f × its reduced-model Pc (the reduced model is about twice as stiff as FE, so this
      reaches about twice the FE Pc), never beyond the sweep's ``pmax``; ``"fixed"``
      (default): to the sweep's ``pmax``.

    ``p_max`` is the sweep's ``pmax``. Tilted cells (a twisting sweep,
    :class:`~multimorph.geometry.TiltedCell`) run as the full (not half) model of the
    sheared strip; their record adds the strip's shear in the sense of the tilt, and Pc/Ph
    are read on it. Every record carries ``meta``: DOF, points, Newton iterations, time,
    why the path ended, the mesh, solver and continuation settings, the traced pressure
    range and the code version.
    """

    name = "fe"
    batch_size = 1

    @staticmethod
    def _api() -> Any:
        fe = _import_model("multimorph.fe", "the finite-element model of issue 5")
        for n in ("simulate_cell", "FESettings", "MeshDensity"):
            if getattr(fe, n, None) is None:
                raise MultimorphError(f"multimorph.fe does not export {n}")
        return fe

    def _settings(self, fe: Any, pmax: float, options: Mapping[str, Any],
                  tilted: bool = False) -> tuple[Any, dict[str, Any]]:
        opts = dict(options)
        extra = {k: opts.pop(k) for k in FE_EXTRA_OPTIONS if k in opts}
        end = extra.get("end", "free")
        if end not in fe.CELL_ENDS:
            raise SpecError(f"sweep.options.end: expected one of "
                            f"{', '.join(repr(e) for e in fe.CELL_ENDS)}, got {end!r}")
        if end == "mirror" and tilted:
            raise SpecError("sweep.options.end: \"mirror\" ends need straight cells; a "
                            "twisting (tilted) sweep keeps \"plate\"")
        n_cells = extra.get("n_cells", 1)
        if isinstance(n_cells, bool) or not isinstance(n_cells, int) or n_cells < 1:
            raise SpecError(f"sweep.options.n_cells: expected a positive integer, got "
                            f"{n_cells!r}")
        if "wall_elements" in extra or "length_fraction" in extra:
            we = extra.get("wall_elements", 2)
            lf = extra.get("length_fraction", 0.1)
            if isinstance(we, bool) or not isinstance(we, int) or we < 1:
                raise SpecError(f"sweep.options.wall_elements: expected a positive integer, "
                                f"got {we!r}")
            if isinstance(lf, bool) or not isinstance(lf, int | float) or not 0 < lf <= 1:
                raise SpecError(f"sweep.options.length_fraction: expected a fraction of the "
                                f"cell length in (0, 1], got {lf!r}")
            opts["mesh"] = fe.MeshDensity(wall_elements=we, length_fraction=float(lf))
        rule = extra.get("pmax_rule", "fixed")
        if rule not in ("fixed", "rom"):
            raise SpecError(f"sweep.options.pmax_rule: expected \"fixed\" or \"rom\", got "
                            f"{rule!r}")
        factor = extra.get("pmax_factor", 1.0)
        if isinstance(factor, bool) or not isinstance(factor, int | float) or not (
                math.isfinite(factor) and factor > 0):
            raise SpecError(f"sweep.options.pmax_factor: expected a positive number, got "
                            f"{factor!r}")
        if tilted:
            opts["half"] = False
        try:
            settings = fe.FESettings(**{**opts, "p_max": pmax})
        except TypeError as exc:
            raise SpecError(f"sweep.options: not an FE setting ({exc})") from None
        return settings, {"n_cells": n_cells, "end": end, "pmax_rule": rule,
                          "pmax_factor": float(factor)}

    def validate(self, pmax: float, options: Mapping[str, Any]) -> None:
        """Check ``options`` once, before any task runs (SpecError naming the bad key)."""
        self._settings(self._api(), pmax, options)

    def _p_max(self, cell: CellGeometry, pmax: float, how: Mapping[str, Any]) -> float:
        if how["pmax_rule"] != "rom":
            return pmax
        from multimorph.rom import solve_cell

        pc = solve_cell(cell, pmax).characteristic.critical
        return pmax if pc is None else min(pmax, how["pmax_factor"] * pc)

    def evaluate_batch(self, designs: Sequence[CellGeometry | TiltedCell], pmax: float,
                       outputs: Sequence[str], options: Mapping[str, Any]) -> list[Any]:
        from dataclasses import asdict, replace

        from multimorph._provenance import code_version

        fe = self._api()
        out: list[Any] = []
        for d in designs:
            try:
                tilted = isinstance(d, TiltedCell)
                cell = d.cell if isinstance(d, TiltedCell) else d
                settings, how = self._settings(fe, pmax, options, tilted)
                p_end = self._p_max(cell, pmax, how)
                settings = replace(settings, p_max=p_end)
                res = fe.simulate_cell(cell, settings, n_cells=how["n_cells"], end=how["end"],
                                       tilt=d.tilt if isinstance(d, TiltedCell) else 0.0)
                st = res.stats
                mesh = settings.mesh
                meta = {"model": "fe", "code_version": code_version(),
                        "nfree": st["nfree"], "points": st["points"],
                        "newton_iterations": st["newton_iterations"],
                        "wall_time": round(float(st["wall_time"]), 3),
                        "status": st["status"], "stop_reason": st["stop_reason"],
                        "p_max": p_end, "n_cells": how["n_cells"], "end": how["end"],
                        "half": settings.half,
                        "mesh": mesh if isinstance(mesh, str) else asdict(mesh),
                        "solver": st["solver"], "tol": settings.tol,
                        "max_volume_ratio": settings.max_volume_ratio,
                        "continuation": {"method": settings.method,
                                         "dx_max": settings.dx_max,
                                         "dp_max": settings.dp_max,
                                         "max_steps": settings.max_steps}}
                if isinstance(d, TiltedCell):
                    gamma = np.asarray(res.response.path.extra["shear"], float)
                    out.append(_tilted_record(res.response, -math.copysign(1.0, d.tilt) * gamma,
                                              outputs, meta, d))
                else:
                    rec = record_from_response(res.response, outputs)
                    rec["meta"] = meta
                    out.append(rec)
            except Exception as exc:
                out.append(exc)
        return out


class CalibratedBackend:
    """The calibrated cell model (:mod:`multimorph.calibrated`), many designs per task.

    Each design's Response comes from the model's batched prediction (cells outside the
    calibrated box are answered by the Ritz model, marked in ``meta`` and in the record's
    ``calibration_inside`` flag). ``options`` are not used.
    """

    name = "calibrated"
    batch_size = 1024
    #: the variant on emulated Ritz features ("calibrated-fast")
    fast = False

    def validate(self, pmax: float, options: Mapping[str, Any]) -> None:
        """Check that the model is there and that no options are given."""
        if options:
            raise SpecError(f"sweep.options: the calibrated model takes no options, got "
                            f"{', '.join(sorted(options))}")
        _import_model("multimorph.calibrated", "the calibrated cell model").load_model()

    def evaluate_batch(self, designs: Sequence[CellGeometry | TiltedCell], pmax: float,
                       outputs: Sequence[str], options: Mapping[str, Any]) -> list[Any]:
        import warnings

        cal = _import_model("multimorph.calibrated", "the calibrated cell model")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", cal.CalibrationWarning)  # recorded per design
            out = cal.load_model().responses(list(designs), pmax, fast=self.fast)
        recs: list[Any] = []
        for d, r in zip(designs, out, strict=True):
            if isinstance(r, BaseException):
                recs.append(r)
                continue
            info = r.meta.get("calibration", {})
            meta = {"model": r.meta.get("model", "calibrated"),
                    "calibration_inside": bool(info.get("inside", False)),
                    "outside": info.get("outside", {})}
            if "activation" in info:  # a cell without a knee (``calibrated._law``): why
                meta["activation"] = info["activation"]
            if isinstance(d, TiltedCell) and r.backend != "calibrated":  # (both variants)
                recs.append(_tilted_record(r, tilted_shear(r, d.cell, d.tilt), outputs, meta,
                                           d))
                continue
            rec = record_from_response(r, outputs)
            if isinstance(d, TiltedCell) and "curves" in outputs:
                rec["shear"] = np.asarray(r.path.twist_rate, float)
            rec["meta"] = meta
            recs.append(rec)
        return recs


register_backend("rom", RomBackend)
register_backend("ritz", RomBackend)
register_backend("fe", FeBackend)
register_backend("calibrated", CalibratedBackend)


class CalibratedFastBackend(CalibratedBackend):
    """The calibrated model's fast variant (emulated Ritz features; ``calibrated-fast``)."""

    name = "calibrated-fast"
    fast = True


register_backend("calibrated-fast", CalibratedFastBackend)
