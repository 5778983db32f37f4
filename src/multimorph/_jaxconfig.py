"""JAX configuration used by the whole package (applied once, on ``import multimorph``).

- **float64**: multimorph evaluates every energy in double precision; material fits and
  equilibrium paths near Gent's lock-up are not accurate in float32. This sets the
  process-wide flag ``jax_enable_x64`` (said in the package docstring and README).
- **persistent compilation cache**: the path-tracing kernels take tens of seconds to compile;
  every CLI call is a new process, so compiled kernels are cached on disk in
  ``$MULTIMORPH_JAX_CACHE`` (default ``~/.cache/multimorph/jax``; set it to ``0`` or ``off``
  to disable). Only kernels that took more than a second to compile are stored. If the cache
  folder cannot be created, caching is silently left off (compilation still works).
"""

import os
from pathlib import Path


def _cache_dir() -> Path | None:
    value = os.environ.get("MULTIMORPH_JAX_CACHE", "")
    if value.strip().lower() in {"0", "off", "false", "no"}:
        return None
    path = Path(value) if value else Path.home() / ".cache" / "multimorph" / "jax"
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return path if os.access(path, os.W_OK) else None


def enable_x64() -> None:
    """Switch JAX to float64 and turn on the persistent compilation cache (idempotent).

    When JAX is not imported yet this only sets its environment variables (JAX reads them
    on import), so ``import multimorph`` does not pay for importing JAX: the calibrated
    model and the CLI's own work do not need it, and a first ``multimorph cell`` stays fast.
    """
    import sys

    cache = _cache_dir()
    if "jax" not in sys.modules:
        os.environ["JAX_ENABLE_X64"] = "1"
        if cache is not None:
            os.environ.setdefault("JAX_COMPILATION_CACHE_DIR", str(cache))
            os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "1.0")
        return
    import jax

    jax.config.update("jax_enable_x64", True)
    if cache is not None and not jax.config.jax_compilation_cache_dir:
        jax.config.update("jax_compilation_cache_dir", str(cache))
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)
