"""Reduced-order (Ritz energy) model of pneu-net unit cells and a generic path tracer.

* :func:`solve_cell` — one cell, whole equilibrium path, observed curves, Pc/Ph (a
  :class:`~multimorph.response.Response`);
* :func:`solve_cells` — the same model over thousands of designs at once (``vmap``), a
  :class:`CellBatch` in, a :class:`ResponseBatch` out;
* :func:`path_sensitivity` — how every point of a traced path moves with the cell's lengths
  (implicit function theorem; :func:`characteristic_sensitivity` for Pc and Ph);
* :func:`trace_path` — pseudo-arc-length continuation of any energy Π(q, p) (used by the cell
  model, and by the tests on the Gent sphere and tube).

The model is derived in ``docs/rom.md``.
"""

from multimorph.rom._batch import CellBatch, ResponseBatch, simulate_cells, solve_batch
from multimorph.rom._cell_energy import COORDINATES, RomOptions, cell_kernel
from multimorph.rom._continuation import (
    ContinuationError,
    RawPath,
    TracerSettings,
    make_tracer,
    trace_path,
)
from multimorph.rom._model import (
    DEFAULT_SETTINGS,
    RUNAWAY_VOLUME_RATIO,
    cell_theta,
    runaway_points,
    solve_cell,
)
from multimorph.rom._notice import announced
from multimorph.rom._sensitivity import (
    LENGTHS,
    PathSensitivity,
    characteristic_sensitivity,
    path_sensitivity,
)

#: Alias used by the device, sweep, design and FE-comparison rooms.
simulate_cell = solve_cell

__all__ = [
    "COORDINATES",
    "DEFAULT_SETTINGS",
    "LENGTHS",
    "RUNAWAY_VOLUME_RATIO",
    "CellBatch",
    "ContinuationError",
    "PathSensitivity",
    "RawPath",
    "ResponseBatch",
    "RomOptions",
    "TracerSettings",
    "announced",
    "cell_kernel",
    "cell_theta",
    "characteristic_sensitivity",
    "make_tracer",
    "path_sensitivity",
    "runaway_points",
    "simulate_cell",
    "simulate_cells",
    "solve_batch",
    "solve_cell",
    "trace_path",
]
