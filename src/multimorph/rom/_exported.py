"""Traced kernels kept across processes.

The first call of the Ritz path tracer in a process spends about 14 s tracing its Python
(the energy's derivatives inside the continuation loop) before JAX's persistent compilation
cache (``multimorph._jaxconfig``) can serve the compiled code in about a second: a
``multimorph design`` that checks its designs on the exact calibrated model (bending and
stretching cells, two tracers) paid 36 of its 40 s there. A kernel is therefore exported
once (``jax.export``: its lowered StableHLO, serialised) into the cache folder, and later
processes read it back and call it without tracing.

A file is used only by the same kernel (its key: laws, options, settings), the same
argument types (tree, shapes, dtypes, weak types), the same JAX and jaxlib versions,
backend and precision, and the same multimorph sources (a digest of every ``.py`` file of
the package): any change of the code traces again. A file that cannot be read or called
is traced again and rewritten; files are written whole or not at all (several processes
may export the same kernel at once); beyond :data:`MAX_KEPT` files the least recently used
are removed. Kernels that trace in under :data:`MIN_TRACE_SECONDS` are not kept: an empty
marker sends later processes straight to plain jit. Without a cache folder, without the
``flatbuffers`` package that JAX's serialisation needs, or with ``MULTIMORPH_JAX_EXPORT=0``,
kernels are traced in every process, as before.
"""

from __future__ import annotations

import hashlib
import logging
import os
import time
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path
from typing import Any

__all__ = ["EXPORT_FOLDER", "MAX_KEPT", "MIN_TRACE_SECONDS", "cache_folder", "export_enabled",
           "exported", "kernel_file", "source_digest"]

logger = logging.getLogger("multimorph.compile")

#: The subfolder of the compilation cache that holds the exported kernels.
EXPORT_FOLDER = "multimorph-exported"
#: Only kernels whose export (its tracing) took at least this long are kept (s): a cheap
#: kernel called on many batch sizes would fill the folder for nothing (JAX's own cache
#: keeps only compilations of a second or more, ``multimorph._jaxconfig``).
MIN_TRACE_SECONDS = 1.0
#: The most kernels kept (~0.5 MB each): every change of the sources exports its kernels
#: anew, so the least recently used beyond this are removed when one is written.
MAX_KEPT = 200


@lru_cache(maxsize=1)
def source_digest() -> str:
    """SHA-256 of the package's Python sources (relative paths and contents, in order)."""
    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for f in sorted(root.rglob("*.py")):
        h.update(str(f.relative_to(root)).encode())
        h.update(b"\0")
        h.update(f.read_bytes())
        h.update(b"\0")
    return h.hexdigest()


def export_enabled() -> bool:
    """Whether kernels are kept in their exported form: on, unless the environment variable
    ``MULTIMORPH_JAX_EXPORT`` is ``0``/``off`` (the compilation cache stays as it is)."""
    value = os.environ.get("MULTIMORPH_JAX_EXPORT", "").strip().lower()
    return value not in {"0", "off", "false", "no"}


def cache_folder() -> str | None:
    """JAX's persistent compilation cache folder (None: off), where the kernels are kept."""
    import jax

    return jax.config.jax_compilation_cache_dir or None


def _signature(args: tuple[Any, ...]) -> str | None:
    """The argument types a call is exported for: tree structure and each leaf's type
    (shape, dtype, weak type); None where this JAX cannot say them (no ``jax.typeof``)."""
    import jax

    typeof = getattr(jax, "typeof", None)
    if typeof is None:
        return None
    leaves, tree = jax.tree_util.tree_flatten(args)
    return f"{tree}|" + ",".join(str(typeof(x)) for x in leaves)


def kernel_file(folder: str | Path, key: str, signature: str) -> Path:
    """Where the kernel ``key`` exported for ``signature`` is kept in ``folder``."""
    import jax
    import jaxlib

    ident = "|".join((jax.__version__, getattr(jaxlib, "__version__", "?"),
                      jax.default_backend(), f"x64={bool(jax.config.jax_enable_x64)}",
                      source_digest(), key, signature))
    digest = hashlib.sha256(ident.encode()).hexdigest()[:40]
    return Path(folder) / EXPORT_FOLDER / f"{digest}.bin"


def _serialisable() -> bool:
    try:
        import flatbuffers  # noqa: F401  (JAX's serialisation needs it)
        from jax import export  # noqa: F401
    except ImportError:  # flatbuffers missing, or a JAX without jax.export
        return False
    return True


def _write(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    tmp.write_bytes(data)
    tmp.replace(path)
    _prune(path.parent)


def _prune(folder: Path, keep: int | None = None) -> None:
    """Remove the least recently used kernels of ``folder`` beyond ``keep`` (default
    :data:`MAX_KEPT`); a file another process removes first is skipped."""
    keep = MAX_KEPT if keep is None else keep
    files = []
    for f in [*folder.glob("*.bin"), *folder.glob("*.cheap")]:
        try:
            files.append((f.stat().st_mtime, f))
        except OSError:
            continue
    for _, f in sorted(files, reverse=True)[keep:]:
        try:
            f.unlink()
        except OSError:
            pass


def exported(fn: Callable[..., Any], key: str, folder: Callable[[], str | None],
             ) -> Callable[..., Any]:
    """``fn`` (a ``jax.jit`` function) called through its exported form kept in
    ``folder()`` (see the module docstring); ``fn`` itself where there is no folder, the
    call has keyword arguments, or ``fn`` cannot be exported."""
    if not hasattr(fn, "lower") or not _serialisable():
        return fn
    calls: dict[str, Callable[..., Any]] = {}

    def call(*args: Any, **kwargs: Any) -> Any:
        if kwargs:
            return fn(*args, **kwargs)
        sig = _signature(args)
        if sig is None:
            return fn(*args)
        known = calls.get(sig)
        if known is not None:
            return known(*args)
        where = folder() if export_enabled() else None
        if not where:
            calls[sig] = fn
            return fn(*args)
        path = kernel_file(where, key, sig)
        if path.with_suffix(".cheap").exists():   # traced quickly before: plain jit
            calls[sig] = fn
            return fn(*args)
        run = _read(path)
        if run is not None:
            try:
                out = run(*args)
            except Exception as exc:  # a stale or damaged file: trace again
                logger.debug("exported kernel %s unusable (%s); tracing it again", path, exc)
            else:
                calls[sig] = run
                return out
        run = _export(fn, args, path)
        calls[sig] = run
        return run(*args)

    call.__wrapped__ = fn  # type: ignore[attr-defined]
    return call


def _read(path: Path) -> Callable[..., Any] | None:
    if not path.exists():
        return None
    from jax import export

    try:
        run = export.deserialize(bytearray(path.read_bytes())).call
        os.utime(path)          # recently used: the last to be pruned
        return run
    except Exception as exc:
        logger.debug("exported kernel %s unreadable (%s); tracing it again", path, exc)
        return None


def _export(fn: Callable[..., Any], args: tuple[Any, ...], path: Path) -> Callable[..., Any]:
    """Trace and export ``fn`` for ``args``, keep it at ``path``, and return the exported
    call (so that this process compiles the same module later ones will read back); ``fn``
    where exporting fails."""
    from jax import export

    t0 = time.perf_counter()
    try:
        exp = export.export(fn)(*args)
        data = exp.serialize()
    except Exception as exc:
        logger.debug("kernel not exportable (%s); traced every run", exc)
        return fn
    if time.perf_counter() - t0 < MIN_TRACE_SECONDS:
        # cheap to trace: plain jit, here and (a marker says so) in later processes
        try:
            _write(path.with_suffix(".cheap"), b"")
        except OSError:
            pass
        return fn
    try:
        _write(path, bytes(data))
    except OSError as exc:  # a read-only cache: this process still uses the export
        logger.debug("exported kernel not kept (%s)", exc)
    return exp.call
