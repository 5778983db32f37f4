"""Running a sweep on Dask: batches of designs per task, results written as they finish.

Schedulers (``scheduler=``):

- ``None`` or ``"local"``: a ``dask.distributed.LocalCluster`` with ``workers`` worker
  *processes* (one thread each), started and closed by the sweep;
- ``"threads"``: Dask's local threaded scheduler (no distributed), ``workers`` threads;
- ``"sync"``: Dask's synchronous scheduler (one thread, for debugging);
- any other string: the address of a running ``dask.distributed`` scheduler
  (``"tcp://host:8786"``), e.g. one started by dask-jobqueue on SLURM;
- or pass ``client=`` (a ``distributed.Client``) directly.

Every task evaluates one batch of designs and returns its records; the process running the
sweep writes each batch to the store the moment it arrives, so a SIGKILL loses at most the
batches in flight. A design that fails is recorded with its error; a task that raises (a
broken worker, a crash outside the model) is retried ``retries`` times, then all its designs
are recorded as failed. Dask also reschedules tasks of a worker that died.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from multimorph.errors import MultimorphError, SpecError
from multimorph.geometry import CellGeometry
from multimorph.sweep._backends import SweepBackend, evaluate_designs, get_backend, load_plugin
from multimorph.sweep._spec import SweepSpec, load_sweep_spec
from multimorph.sweep._store import SweepStore, answered_by

__all__ = ["SweepSummary", "plan_batches", "run_sweep"]

ProgressFn = Callable[[int, int], None]


@dataclass(frozen=True)
class SweepSummary:
    """What a sweep did.

    Attributes
    ----------
    out : Path
        The sweep folder.
    results : Path or None
        ``out/results.zarr`` (None if nothing could be consolidated).
    n_designs, n_invalid : int
        All design points; those with an invalid geometry or material (listed in
        ``invalid``, never evaluated).
    n_ok, n_failed : int
        Evaluated designs that succeeded / failed (both counted over the whole store).
    n_resumed : int
        Designs already in the store when this run started (skipped).
    n_run : int
        Designs evaluated by this run.
    elapsed : float
        Wall time of this run (s), including cluster start-up.
    compute_time : float
        Wall time from the first task submitted to the last batch written (s).
    scheduler : str
    model : str
        The cell model the spec asked for (its backend; ``"ritz"`` for ``"rom"``).
    models : dict
        Designs that succeeded, by the model that answered them (a calibrated backend
        answers a cell outside its box with the Ritz model: ``{"calibrated-fast": 5,
        "ritz": 2}``).
    """

    out: Path
    results: Path | None
    n_designs: int
    n_invalid: int
    n_ok: int
    n_failed: int
    n_resumed: int
    n_run: int
    elapsed: float
    compute_time: float
    scheduler: str
    invalid: list[dict[str, Any]] = field(default_factory=list)
    failed: list[dict[str, Any]] = field(default_factory=list)
    model: str = ""
    models: dict[str, int] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def plan_batches(valid: np.ndarray, done: np.ndarray, batch_size: int) -> list[np.ndarray]:
    """Batches still to run: fixed chunks of the valid indices, minus finished designs.

    The chunking depends only on the design table and the batch size, so a resumed sweep
    evaluates each remaining design in the same batch (hence bitwise the same numbers) as an
    uninterrupted one.
    """
    if batch_size < 1:
        raise SpecError(f"batch size must be >= 1, got {batch_size}")
    done_set = np.isin(valid, done)
    out = []
    for k in range(0, len(valid), batch_size):
        sel = valid[k:k + batch_size][~done_set[k:k + batch_size]]
        if sel.size:
            out.append(sel)
    return out


class _Job:
    """One task's arguments in an opaque box, so Dask does not traverse the design list."""

    __slots__ = ("backend", "batch_size", "designs", "indices", "options", "outputs", "pmax")

    def __init__(self, backend: SweepBackend, indices: np.ndarray,
                 designs: Sequence[CellGeometry], pmax: float, outputs: Sequence[str],
                 options: Mapping[str, Any], batch_size: int) -> None:
        self.backend, self.indices, self.designs = backend, indices, list(designs)
        self.pmax, self.outputs, self.options = pmax, tuple(outputs), dict(options)
        self.batch_size = batch_size


def _task(job: _Job) -> tuple[np.ndarray, list[dict[str, Any]]]:
    return job.indices, evaluate_designs(job.backend, job.designs, job.pmax, job.outputs,
                                         job.options, pad_to=job.batch_size)


def _failed_batch(indices: np.ndarray, exc: BaseException) -> tuple[np.ndarray,
                                                                      list[dict[str, Any]]]:
    msg = f"task failed after retries: {type(exc).__name__}: {exc}"
    return indices, [{"status": "failed", "error": msg} for _ in indices]


def _run_local(jobs: list[_Job], scheduler: str, workers: int | None,
               write: Callable[[tuple[np.ndarray, list[dict[str, Any]]]], None]) -> None:
    import dask
    from dask.callbacks import Callback

    keys = {}
    tasks = []
    for k, job in enumerate(jobs):
        key = f"multimorph-sweep-batch-{k}"
        keys[key] = k
        tasks.append(dask.delayed(_task, pure=False)(job, dask_key_name=key))

    def posttask(key: Any, result: Any, dsk: Any, state: Any, worker_id: Any) -> None:
        if key in keys:
            write(result)

    kw: dict[str, Any] = {"scheduler": "sync" if scheduler == "sync" else "threads"}
    if scheduler == "threads" and workers:
        kw["num_workers"] = workers
    with Callback(posttask=posttask):
        dask.compute(*tasks, **kw)


def _run_distributed(jobs: list[_Job], client: Any, retries: int,
                     write: Callable[[tuple[np.ndarray, list[dict[str, Any]]]], None]) -> None:
    from distributed import as_completed

    futs = []
    indices = {}
    for job in jobs:
        fut = client.submit(_task, job, retries=retries, pure=False)
        futs.append(fut)
        indices[fut.key] = job.indices
    del jobs
    for fut in as_completed(futs):
        try:
            res = fut.result()
        except Exception as exc:  # retries exhausted, or the worker kept dying
            res = _failed_batch(indices[fut.key], exc)
        write(res)
        fut.release()


def _only_designs(designs: Sequence[int], table: Any) -> np.ndarray:
    """The design indices a run is restricted to, checked against the table."""
    only = np.unique(np.asarray([int(i) for i in designs], dtype=np.int64))
    valid = set(table.valid_indices.tolist())
    bad = [int(i) for i in only if int(i) not in valid]
    if bad:
        raise SpecError(f"designs: {bad[:5]} {'is' if len(bad) == 1 else 'are'} not valid "
                        f"design indices of this sweep (0-{len(table) - 1}, invalid ones "
                        "excluded)")
    return only


#: Seconds to wait for a scheduler address to answer (before anything is created).
SCHEDULER_TIMEOUT = 10.0
#: Most worker processes or threads per CPU core.
WORKERS_PER_CPU = 8


def _check_workers(workers: int | None, scheduler: str | None) -> None:
    if workers is None:
        return
    if workers < 1:
        raise SpecError(f"--workers: must be >= 1, got {workers}")
    cpus = os.cpu_count() or 1
    if scheduler in (None, "local", "threads") and workers > WORKERS_PER_CPU * cpus:
        raise SpecError(f"--workers: {workers} workers on {cpus} CPU core(s) (each a process "
                        f"or thread holding a model); at most {WORKERS_PER_CPU * cpus} here")


def _check_reachable(address: str) -> None:
    """Refuse a scheduler address that does not accept connections (SpecError)."""
    import socket
    from urllib.parse import urlsplit

    parts = urlsplit(address if "://" in address else f"tcp://{address}")
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        host, port = None, None
    if parts.scheme not in ("tcp", "tls", "ws", "wss") or not host or port is None:
        raise SpecError(f"--scheduler: expected an address such as tcp://host:8786, got "
                        f"{address!r}")
    try:
        with socket.create_connection((host, port), timeout=SCHEDULER_TIMEOUT):
            pass
    except OSError as exc:
        raise SpecError(f"--scheduler: cannot reach {address} "
                        f"({exc.strerror or exc})") from None


def run_sweep(spec: SweepSpec | str | os.PathLike[str], out: str | os.PathLike[str], *,
              scheduler: str | None = None, workers: int | None = None,
              batch_size: int | None = None, retries: int = 2, client: Any = None,
              backend: SweepBackend | None = None, progress: ProgressFn | None = None,
              retry_failed: bool = False, limit: int | None = None,
              allow_plugins: Sequence[str] = (), designs: Sequence[int] | None = None,
              options: Mapping[str, Any] | None = None) -> SweepSummary:
    """Run (or resume) a sweep into the folder ``out``.

    Parameters
    ----------
    spec : SweepSpec or path
        Parsed spec or a TOML file.
    out : path
        Sweep folder (created; if it holds this sweep already, finished designs are skipped;
        if it holds another sweep, :class:`~multimorph.errors.SpecError`).
    scheduler : str, optional
        ``None``/``"local"`` (LocalCluster, worker processes), ``"threads"``, ``"sync"``, or
        a scheduler address. See the module docstring.
    workers : int, optional
        Worker processes (LocalCluster) or threads (``"threads"``); default: CPU count.
    batch_size : int, optional
        Designs per task; default: the backend's (256 for ROM, 1 for FE).
    retries : int
        Retries of a task that raised (distributed schedulers).
    client : distributed.Client, optional
        Use this client instead of creating one.
    backend : SweepBackend, optional
        Use this backend object instead of looking up ``spec.backend``.
    progress : callable, optional
        ``progress(done, total)`` after each batch (designs of this run).
    retry_failed : bool
        Evaluate designs that failed in an earlier run again (default: keep their failure).
    limit : int, optional
        Evaluate at most this many of the pending designs in this run (in design order; a
        later run goes on with the rest), e.g. to grow a long FE sweep in passes.
    allow_plugins : sequence of str
        ``"package.module:factory"`` backends the spec may name (the command line's
        ``--allow-plugin``); a spec alone can only name registered backends.
    designs : sequence of int, optional
        Evaluate only these design indices of the spec's table (each a valid design); the
        others stay pending. E.g. a few designs run again into a folder of their own.
    options : mapping, optional
        Backend options that update the spec's ``sweep.options`` for this run (checked by
        the backend like the spec's). The folder's manifest keeps the spec's; what a record
        was run with is the backend's to record (the FE records its settings in ``meta``).

    Raises
    ------
    SpecError
        Before anything is created or run: a malformed spec or option, an unknown backend,
        too many designs for the memory, every design invalid, an ``out`` folder that holds
        something else, or a scheduler address that does not answer.

    Returns
    -------
    SweepSummary
    """
    t0 = time.perf_counter()
    # every check before anything is created: spec, backend, options, size, scheduler, folder
    if scheduler not in (None, "local", "threads", "sync") and ":" not in str(scheduler):
        raise SpecError(f"--scheduler: expected local, threads, sync or an address such as "
                        f"tcp://host:8786, got {scheduler!r}")
    _check_workers(workers, scheduler if client is None else "client")
    for path in allow_plugins:
        load_plugin(path)
    text = None
    where = ""
    if not isinstance(spec, SweepSpec):
        path = Path(spec)
        spec = load_sweep_spec(path)  # a non-UTF-8 or malformed file fails here, cleanly
        text = path.read_text(encoding="utf-8")
        where = f"{path}: "
    try:
        be = backend if backend is not None else get_backend(spec.backend,
                                                             plugins=allow_plugins)
        run_options = {**dict(spec.options), **dict(options or {})}
        validate = getattr(be, "validate", None)
        if validate is not None:
            validate(spec.pmax, run_options)
        table = spec.design_table()
        only = None if designs is None else _only_designs(designs, table)
        if len(table.invalid) == len(table):
            first = table.invalid[0]
            raise SpecError(f"sweep: all {len(table)} designs are invalid, nothing to run "
                            f"(design {first.index} {first.values}: {first.reason})")
    except SpecError as exc:
        raise type(exc)(f"{where}{exc}") from None
    bs = int(batch_size or be.batch_size)
    if bs < 1:
        raise SpecError(f"--batch-size: must be >= 1, got {bs}")
    store = SweepStore(out, spec, table, spec_text=text)
    store.check()
    if client is None and scheduler not in (None, "local", "threads", "sync"):
        _check_reachable(str(scheduler))
    label = "client" if client is not None else (scheduler or "local")
    with store.locked():
        store.prepare()
        done = store.finished(include_failed=not retry_failed)
        n_resumed = int(done.size)
        pending = np.setdiff1d(table.valid_indices, done)
        if only is not None:
            done = np.union1d(done, np.setdiff1d(pending, only))  # not asked for: as if done
            pending = np.intersect1d(pending, only)
        if limit is not None:
            if limit < 0:
                raise SpecError(f"limit must be >= 0, got {limit}")
            done = np.union1d(done, pending[limit:])  # not run now: planned as if done
        batches = plan_batches(table.valid_indices, done, bs)
        total = int(sum(b.size for b in batches))
        jobs = [_Job(be, b, [table.cells[i] for i in b], spec.pmax, spec.outputs, run_options,
                     bs) for b in batches]
        count = [0]

        def write(res: tuple[np.ndarray, list[dict[str, Any]]]) -> None:
            idx, recs = res
            store.write_part(idx, recs)
            count[0] += len(idx)
            if progress is not None:
                progress(count[0], total)

        if progress is not None:
            progress(0, total)
        t1 = time.perf_counter()
        if jobs:
            if client is not None:
                _run_distributed(jobs, client, retries, write)
            elif scheduler in ("threads", "sync"):
                _run_local(jobs, scheduler, workers, write)
            else:
                from distributed import Client, LocalCluster

                if scheduler in (None, "local"):
                    n = workers or os.cpu_count() or 1
                    with LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                      dashboard_address=None) as cluster, \
                            Client(cluster) as cl:
                        _run_distributed(jobs, cl, retries, write)
                else:
                    try:
                        cl = Client(scheduler, timeout=SCHEDULER_TIMEOUT)
                    except (OSError, TimeoutError) as exc:
                        raise MultimorphError(f"--scheduler: cannot connect to {scheduler} "
                                              f"({exc})") from None
                    with cl:
                        _run_distributed(jobs, cl, retries, write)
        t2 = time.perf_counter()
        results = store.consolidate()
    import xarray as xr

    ds = xr.open_zarr(results, consolidated=False)
    status = ds["status"].values
    err = ds["error"].values
    failed = [{"index": int(i), "error": str(err[i])} for i in np.flatnonzero(status == "failed")]
    model, models = answered_by(ds)
    return SweepSummary(
        out=store.path, results=results, n_designs=len(table), n_invalid=len(table.invalid),
        n_ok=int(np.sum(status == "ok")), n_failed=len(failed), n_resumed=n_resumed,
        n_run=total, elapsed=time.perf_counter() - t0, compute_time=t2 - t1, scheduler=label,
        invalid=[p.to_dict() for p in table.invalid], failed=failed, model=model,
        models=models)
