"""Say that the Ritz model is being compiled: its first call in a process can take tens of
seconds of silence.

The jitted kernels (the path tracer, its vectorised form, the calibrated model's linear
response) are wrapped by :func:`announced`. On the first call of a kernel the message
:data:`NOTICE` is logged (logger ``multimorph.compile``, level INFO; the CLI prints it on
stderr) once per process, and only when the compile is not served by JAX's persistent
compilation cache (``multimorph._jaxconfig``): a marker file per kernel, written in that
cache folder after a first call completed, tells a warm cache. (JAX says whether the cache
hit only after the compile; the marker covers the kernel, not every array shape of it.)

A jitted kernel is also kept in that folder in its exported form (:mod:`._exported`), so
that later processes call it without tracing it again (the tracer's ~14 s).
"""

from __future__ import annotations

import functools
import hashlib
import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

from multimorph.rom._exported import cache_folder, exported

__all__ = ["NOTICE", "announced"]

logger = logging.getLogger("multimorph.compile")

#: The message, with the persistent compilation cache on (and without it).
NOTICE = "compiling the model (first run only)…"
NOTICE_NO_CACHE = "compiling the model (the compilation cache is off: every run)…"

_told: list[bool] = []  # once per process


def _marker(key: str, cache: str | None) -> Path | None:
    import jax

    if not cache:
        return None
    digest = hashlib.sha256(f"jax {jax.__version__}|{key}".encode()).hexdigest()[:32]
    return Path(cache) / "multimorph-kernels" / digest


def announced(fn: Callable[..., Any], key: str,
              cache: Callable[[], str | None] = cache_folder) -> Callable[..., Any]:
    """``fn`` (a jitted kernel) that tells :data:`NOTICE` before its first call compiles.

    Parameters
    ----------
    fn : callable
        The jitted kernel.
    key : str
        What identifies the compiled kernel across processes (laws, options, settings).
    cache : callable
        The persistent compilation cache folder (None: off).
    """
    called: list[bool] = []
    run = exported(fn, key, cache)

    @functools.wraps(fn)
    def call(*args: Any, **kwargs: Any) -> Any:
        if called:
            return run(*args, **kwargs)
        folder = cache()
        marker = _marker(key, folder)
        if not _told and (marker is None or not marker.exists()):
            _told.append(True)
            logger.info(NOTICE if folder else NOTICE_NO_CACHE)
        out = run(*args, **kwargs)
        called.append(True)
        if marker is not None:
            try:
                marker.parent.mkdir(parents=True, exist_ok=True)
                marker.touch()
            except OSError:  # a read-only cache: the notice may be shown again
                pass
        return out

    return call
