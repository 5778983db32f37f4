"""Sweep room: parameter studies on Dask with a resumable Zarr results store.

The only room that imports Dask. A sweep spec (TOML) names a base cell, the parameters to vary
and a backend (``"rom"`` or ``"fe"``); :func:`run_sweep` evaluates every design in batches on a
Dask scheduler and writes each finished batch to the out folder, so a rerun resumes.

Examples
--------
>>> from multimorph.sweep import load_sweep_spec, run_sweep   # doctest: +SKIP
>>> summary = run_sweep(load_sweep_spec("examples/sweep_ht.toml"), "out/ht")  # doctest: +SKIP
>>> ds = open_results("out/ht")  # doctest: +SKIP
"""

from multimorph.sweep._backends import (
    CURVE_VARS,
    EXTRA_CURVE_VARS,
    SCALAR_VARS,
    FeBackend,
    RomBackend,
    SweepBackend,
    evaluate_designs,
    get_backend,
    record_from_response,
    register_backend,
)
from multimorph.sweep._params import RATIO_NAMES, Parameter
from multimorph.sweep._run import SweepSummary, plan_batches, run_sweep
from multimorph.sweep._spec import (
    CELL_KINDS,
    DEFAULT_BACKEND,
    OUTPUTS,
    DesignTable,
    InvalidPoint,
    SweepSpec,
    load_sweep_spec,
    parse_sweep_spec,
)
from multimorph.sweep._store import (
    SweepStore,
    answered_by,
    collect_parts,
    open_results,
    param_var,
    safe_name,
    write_part_group,
)

__all__ = [
    "CELL_KINDS",
    "CURVE_VARS",
    "DEFAULT_BACKEND",
    "EXTRA_CURVE_VARS",
    "OUTPUTS",
    "RATIO_NAMES",
    "SCALAR_VARS",
    "DesignTable",
    "FeBackend",
    "InvalidPoint",
    "Parameter",
    "RomBackend",
    "SweepBackend",
    "SweepSpec",
    "SweepStore",
    "SweepSummary",
    "answered_by",
    "collect_parts",
    "evaluate_designs",
    "get_backend",
    "load_sweep_spec",
    "open_results",
    "param_var",
    "parse_sweep_spec",
    "plan_batches",
    "record_from_response",
    "register_backend",
    "run_sweep",
    "safe_name",
    "write_part_group",
]
