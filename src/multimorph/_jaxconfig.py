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
    """Switch JAX to float64 and turn on the persistent compilation cache (idempotent)."""
    os.environ.setdefault("JAX_ENABLE_X64", "1")
    import jax

    jax.config.update("jax_enable_x64", True)
    cache = _cache_dir()
    if cache is not None and not jax.config.jax_compilation_cache_dir:
        jax.config.update("jax_compilation_cache_dir", str(cache))
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)
