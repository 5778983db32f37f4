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
from multimorph.geometry import CellGeometry

__all__ = ["CURVE_VARS", "ENTRY_POINT_GROUP", "SCALAR_VARS", "SweepBackend", "evaluate_designs",
           "get_backend", "known_backends", "load_plugin", "record_from_response",
           "register_backend"]

#: Per-design scalar outputs (Pa or 1/m; NaN when not reached) of ``"characteristic"``.
SCALAR_VARS = ("critical_pressure", "hardening_pressure", "failure_pressure",
               "curvature_at_critical", "curvature_at_hardening", "curvature_at_failure")
#: Per-point curve outputs of ``"curves"``: the whole equilibrium path.
CURVE_VARS = ("pressure", "curvature", "peak_stretch", "stable")


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
                   stable=np.asarray(path.stable, bool))
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

    def evaluate_batch(self, designs: Sequence[CellGeometry], pmax: float,
                       outputs: Sequence[str], options: Mapping[str, Any]) -> list[Any]:
        fn, batched = self._api()
        if batched:
            return list(fn(list(designs), pmax, **dict(options)))
        out: list[Any] = []
        for d in designs:
            try:
                out.append(fn(d, pmax, **dict(options)))
            except Exception as exc:
                out.append(exc)
        return out


class FeBackend:
    """The finite-element model (:func:`multimorph.fe.simulate_cell`), one design per task.

    ``options`` are :class:`multimorph.fe.FESettings` fields (``mesh``, ``method``, ``tol`` …);
    ``p_max`` is the sweep's ``pmax``.
    """

    name = "fe"
    batch_size = 1

    @staticmethod
    def _api() -> tuple[Any, Any]:
        fe = _import_model("multimorph.fe", "the finite-element model of issue 5")
        fn, settings = getattr(fe, "simulate_cell", None), getattr(fe, "FESettings", None)
        if fn is None or settings is None:
            raise MultimorphError("multimorph.fe does not export simulate_cell and FESettings "
                                  "(the finite-element model of issue 5 is not finished)")
        return fn, settings

    def validate(self, pmax: float, options: Mapping[str, Any]) -> None:
        """Check ``options`` once, before any task runs (SpecError naming the bad key)."""
        _, settings = self._api()
        try:
            settings(**{**dict(options), "p_max": pmax})
        except TypeError as exc:
            raise SpecError(f"sweep.options: not an FE setting ({exc})") from None

    def evaluate_batch(self, designs: Sequence[CellGeometry], pmax: float,
                       outputs: Sequence[str], options: Mapping[str, Any]) -> list[Any]:
        fn, settings = self._api()
        s = settings(**{**dict(options), "p_max": pmax})
        out: list[Any] = []
        for d in designs:
            try:
                out.append(fn(d, s).response)
            except Exception as exc:
                out.append(exc)
        return out


register_backend("rom", RomBackend)
register_backend("fe", FeBackend)
