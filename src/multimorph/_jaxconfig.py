"""JAX configuration used by the whole package.

multimorph evaluates every energy in float64: material fits and equilibrium paths
near lock-up are not accurate in float32. Importing :mod:`multimorph` therefore turns
on ``jax_enable_x64`` (a process-wide JAX flag). This is done once, here, and said
loudly in the package docstring and README.
"""

import os


def enable_x64() -> None:
    """Switch JAX to float64 (idempotent). JAX itself is imported lazily-safe here."""
    os.environ.setdefault("JAX_ENABLE_X64", "1")
    import jax

    jax.config.update("jax_enable_x64", True)
