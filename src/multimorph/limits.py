"""Plausibility and size limits checked at the edges, before any computation.

A spec or an option beyond these is refused with a message that names the field and gives
the estimate behind the limit, instead of running for minutes and failing (or being killed
for memory) later.

* :data:`MAX_CELL_SIZE`: no outer dimension of a pneu-net cell exceeds 1 m (a bare number is
  in metres, so ``length = 20`` is 20 m: usually a forgotten unit).
* :data:`MAX_PRESSURE_RATIO`: pressures are at most 1000 times the wall's small-strain shear
  modulus μ. Elastomer walls burst at a few μ (the reduced model's paths reach lock-up or
  break well below 100 μ), so more is a typo or a wrong unit.
* :data:`MAX_CELLS_PER_MODULE`, :data:`MAX_COPIES`: cells in series in one module and
  parallel copies (or strips); shapes and animations hold a few points per cell and copy.
* :func:`memory_budget`: half the machine's physical memory; a sweep whose estimated memory
  (designs × bytes per design) exceeds it is refused with the estimate.
"""

from __future__ import annotations

import math
import os

from multimorph.errors import SpecError

__all__ = ["MAX_CELLS_PER_MODULE", "MAX_CELL_SIZE", "MAX_COPIES", "MAX_PRESSURE_RATIO",
           "check_pressure_scale", "format_bytes", "memory_budget"]

#: Largest outer dimension of a cell (m).
MAX_CELL_SIZE = 1.0
#: Largest pressure as a multiple of the wall's small-strain shear modulus (-).
MAX_PRESSURE_RATIO = 1000.0
#: Most cells in series in one module.
MAX_CELLS_PER_MODULE = 10_000
#: Most parallel copies of a module (fingers) or strips of a twisting module.
MAX_COPIES = 1_000


def check_pressure_scale(pressure: float, mu: float, field: str) -> None:
    """Refuse a pressure (Pa) above :data:`MAX_PRESSURE_RATIO` times the modulus ``mu`` (Pa).

    Raises
    ------
    SpecError
        Naming ``field``, the pressure, μ and the ratio.
    """
    if pressure > MAX_PRESSURE_RATIO * mu:
        raise SpecError(
            f"{field}: {pressure / 1e3:.4g} kPa is {pressure / mu:.3g} times the wall shear "
            f"modulus μ = {mu / 1e3:.4g} kPa; more than {MAX_PRESSURE_RATIO:g} μ is beyond "
            "any elastomer wall (check the unit)")


def memory_budget() -> int:
    """Bytes a single run may plan to hold: half the physical memory (8 GiB if unknown)."""
    try:
        total = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        total = 16 * 2**30
    return int(total // 2)


def format_bytes(n: float) -> str:
    """``n`` bytes as a short human string (``"96 GB"``)."""
    if not math.isfinite(n):
        return "inf"
    units = ("B", "kB", "MB", "GB", "TB", "PB")
    k = 0
    while abs(n) >= 1000 and k < len(units) - 1:
        n /= 1000
        k += 1
    return f"{n:.3g} {units[k]}"
