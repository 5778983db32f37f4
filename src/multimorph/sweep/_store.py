"""The results store: one folder per sweep, resumable, one result per design.

Layout of ``OUT/``::

    sweep.json          manifest: spec (as parsed), spec hash, package versions, parameters,
                        counts, invalid points with their reasons
    spec.toml           the spec file as given (when run from a file)
    designs.zarr        the design table: every design (valid or not) and its parameters
    parts/part-*.zarr   results, one compact Zarr group per finished batch
    results.zarr        all designs merged (written when the sweep completes)
    .lock               held (flock) while a sweep writes here

Each part is written into a hidden temporary folder and renamed into ``parts/`` only when
complete (``os.rename`` is atomic on one filesystem), so a killed sweep leaves finished parts
intact and no half-written one; rerunning skips the designs found in parts. Zarr (not Parquet)
because curves are 2-D (design × point) arrays, xarray writes and reads it natively, chunks
are independent files (no rewrite of a growing table), and it works on object stores for
clusters.
"""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import uuid
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from multimorph.errors import MultimorphError, SpecError
from multimorph.geometry import CELL_KEYS, TiltedCell
from multimorph.io import write_json
from multimorph.sweep._backends import CURVE_VARS, EXTRA_CURVE_VARS, SCALAR_VARS
from multimorph.sweep._spec import DesignTable, SweepSpec

__all__ = ["SweepStore", "answered_by", "collect_parts", "open_results", "param_var",
           "safe_name", "write_part_group"]

FORMAT = "multimorph-sweep/1"


def _versions() -> dict[str, str]:
    import dask
    import xarray
    import zarr

    import multimorph

    return {"multimorph": multimorph.__version__, "dask": dask.__version__,
            "xarray": xarray.__version__, "zarr": zarr.__version__}


def safe_name(name: str) -> str:
    """Variable name for a parameter or ratio (Zarr names cannot hold ``/``): ``ht/d`` ->
    ``ht_d``, ``cell.top_wall`` -> ``cell_top_wall``."""
    return name.replace("/", "_").replace(".", "_")


def param_var(name: str) -> str:
    """Variable holding a swept parameter's values in the design table."""
    return f"param_{safe_name(name)}"


def _strings(values: Sequence[str]) -> np.ndarray:
    # variable-length strings (object dtype) have a stable Zarr v3 encoding
    arr = np.empty(len(values), dtype=object)
    arr[:] = list(values)
    return arr


PART_FORMAT = "multimorph-sweep-part/1"
_CURVE_FLOATS = tuple(v for v in CURVE_VARS if v != "stable")


def write_part_group(path: Path, indices: Sequence[int], records: Sequence[Mapping[str, Any]],
                     outputs: Sequence[str]) -> None:
    """Write one batch of records as a compact Zarr group (few arrays: fast to write).

    Arrays: ``design`` (n,), ``scalars`` (n, 6) of :data:`SCALAR_VARS`, ``curves``
    (n, m, k) of pressure, curvature, peak stretch and, where a record has them, the
    :data:`EXTRA_CURVE_VARS` (their names in the attribute ``curve_vars``), padded with
    NaN, ``curve_stable`` (n, m), ``n_points`` (n,); strings (status, error, critical kind,
    and each record's ``meta`` as JSON) in the group attributes.
    """
    import zarr

    n = len(records)
    group = zarr.open_group(str(path), mode="w", zarr_format=3)
    attrs: dict[str, Any] = {
        "format": PART_FORMAT,
        "status": [str(r.get("status", "ok")) for r in records],
        "error": [str(r.get("error", "")) for r in records],
    }
    if any("meta" in r for r in records):
        attrs["meta"] = [json.dumps(r.get("meta", {}), sort_keys=True, default=str)
                         for r in records]
    group.create_array("design", data=np.asarray(indices, dtype=np.int64))
    if "characteristic" in outputs:
        sc = np.array([[float(r.get(v, np.nan)) for v in SCALAR_VARS] for r in records],
                      dtype=float).reshape(n, len(SCALAR_VARS))
        group.create_array("scalars", data=sc)
        attrs["critical_kind"] = [str(r.get("critical_kind", "")) for r in records]
    if "curves" in outputs:
        lens = [len(r["pressure"]) if "pressure" in r else 0 for r in records]
        width = max([*lens, 1])
        names = [*_CURVE_FLOATS, *(v for v in EXTRA_CURVE_VARS if any(v in r for r in records))]
        cur = np.full((n, width, len(names)), np.nan)
        stable = np.zeros((n, width), bool)
        for i, r in enumerate(records):
            if lens[i]:
                for j, v in enumerate(names):
                    if v in r:
                        cur[i, :lens[i], j] = np.asarray(r[v], float)
                stable[i, :lens[i]] = np.asarray(r["stable"], bool)
        group.create_array("curves", data=cur)
        group.create_array("curve_stable", data=stable)
        group.create_array("n_points", data=np.asarray(lens, dtype=np.int64))
        attrs["curve_vars"] = names
    group.attrs.update(attrs)


def read_part_group(path: Path) -> dict[str, np.ndarray]:
    """Columns of one part: ``design``, ``status``, ``error``, scalars, ``curve_*``."""
    import zarr

    group = zarr.open_group(str(path), mode="r")
    attrs = dict(group.attrs)
    out: dict[str, np.ndarray] = {"design": np.asarray(group["design"][:], dtype=np.int64)}
    for key in ("status", "error", "critical_kind", "meta"):
        if key in attrs:
            out[key] = _strings(attrs[key])
    names = set(group.array_keys())
    if "scalars" in names:
        sc = np.asarray(group["scalars"][:])
        for j, v in enumerate(SCALAR_VARS):
            out[v] = sc[:, j]
    if "curves" in names:
        cur = np.asarray(group["curves"][:])
        for j, v in enumerate(attrs.get("curve_vars", _CURVE_FLOATS)):
            out[f"curve_{v}"] = cur[:, :, j]
        out["curve_stable"] = np.asarray(group["curve_stable"][:], dtype=bool)
        out["n_points"] = np.asarray(group["n_points"][:], dtype=np.int64)
    return out


def design_dataset(spec: SweepSpec, table: DesignTable) -> Any:
    """The design table as an xarray Dataset: parameters, lengths (m), ratios, moduli (Pa),
    the wall's Gent Jm where it has one, and the chamber tilt (rad) of tilted cells."""
    import xarray as xr

    n = len(table)
    reasons = {p.index: p.reason for p in table.invalid}
    cells = [c.cell if isinstance(c, TiltedCell) else c for c in table.cells]
    data: dict[str, Any] = {}
    for j, name in enumerate(table.names):
        data[param_var(name)] = ("design", table.values[:, j].astype(float),
                                 {"unit": table.units[j], "parameter": name})
    for key in CELL_KEYS:
        data[key] = ("design", np.array([getattr(c, key) if c else np.nan
                                         for c in cells]), {"unit": "m"})
    ratios = [c.ratios() if c else {} for c in cells]
    for r in ("ws/d", "df/d", "ht/d", "hb/d", "w/d", "h/d"):
        data[safe_name(r)] = ("design", np.array([q.get(r, np.nan) for q in ratios]),
                              {"unit": "1", "long_name": r})
    data["mu"] = ("design", np.array([c.mu if c else np.nan for c in cells]),
                  {"unit": "Pa", "long_name": "wall shear modulus"})
    data["mu_b"] = ("design", np.array([c.bottom_material.shear_modulus
                                        if c and c.bottom_material else np.nan
                                        for c in cells]),
                    {"unit": "Pa", "long_name": "bottom-wall shear modulus"})
    data["jm"] = ("design", np.array([float(c.material.params.get("jm", np.nan)) if c
                                      else np.nan for c in cells]),
                  {"unit": "1", "long_name": "wall Gent Jm (NaN for other laws)"})
    if spec.kind == "twisting":
        data["tilt"] = ("design", np.array([c.tilt if isinstance(c, TiltedCell) else np.nan
                                            for c in table.cells]),
                        {"unit": "rad", "long_name": "chamber tilt"})
    data["valid"] = ("design", np.array([c is not None for c in cells]))
    data["invalid_reason"] = ("design", _strings([reasons.get(i, "") for i in range(n)]))
    return xr.Dataset(data, coords={"design": np.arange(n, dtype=np.int64)},
                      attrs={"spec_hash": spec.spec_hash, "kind": spec.kind})


def _atomic_zarr(ds: Any, final: Path) -> None:
    tmp = final.parent / f".tmp-{final.name}-{uuid.uuid4().hex[:8]}"
    ds.to_zarr(tmp, mode="w", zarr_format=3, consolidated=False)
    os.rename(tmp, final)


class SweepStore:
    """The out folder of one sweep (see the module docstring for the layout).

    Parameters
    ----------
    path : path
        Out folder; created if missing.
    spec : SweepSpec
    table : DesignTable
    spec_text : str, optional
        The spec file's text, kept as ``spec.toml``.
    """

    def __init__(self, path: str | os.PathLike[str], spec: SweepSpec, table: DesignTable,
                 spec_text: str | None = None) -> None:
        self.path = Path(path)
        self.spec = spec
        self.table = table
        self.spec_text = spec_text
        self.parts = self.path / "parts"

    # ---------------------------------------------------------------- lifecycle
    @contextmanager
    def locked(self) -> Iterator[None]:
        """Hold an exclusive lock on the folder (released even if the process is killed)."""
        self.path.mkdir(parents=True, exist_ok=True)
        with open(self.path / ".lock", "w") as fh:
            try:
                fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise MultimorphError(f"{self.path}: another sweep is writing to this folder "
                                      "right now") from None
            try:
                yield
            finally:
                fcntl.flock(fh, fcntl.LOCK_UN)

    def manifest(self) -> dict[str, Any]:
        spec, table = self.spec, self.table
        return {
            "format": FORMAT,
            "spec_hash": spec.spec_hash,
            "spec": spec.raw,
            "versions": _versions(),
            "backend": spec.backend,
            "outputs": list(spec.outputs),
            "pmax": spec.pmax,
            "combine": spec.combine,
            "parameters": [q.to_dict() for q in spec.parameters],
            "n_designs": len(table),
            "n_valid": len(table) - len(table.invalid),
            "invalid": [p.to_dict() for p in table.invalid],
        }

    def check(self) -> None:
        """Check, without writing anything, that the folder can hold this sweep: missing or
        empty, or a folder of this very sweep (to resume).

        Raises
        ------
        SpecError
            The folder is a file or lies under one, is not writable, holds results of a
            different spec (hash mismatch) or something else (each message names --out).
        """
        from multimorph.io import check_output_dir

        check_output_dir(self.path, in_place=True)
        if not self.path.is_dir():
            return
        man = self.path / "sweep.json"
        if man.exists():
            try:
                old = json.loads(man.read_text())
            except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
                raise SpecError(f"--out: {man}: unreadable sweep manifest ({exc})") from None
            if not isinstance(old, dict) or old.get("spec_hash") != self.spec.spec_hash:
                old_hash = old.get("spec_hash") if isinstance(old, dict) else None
                raise SpecError(
                    f"--out: {self.path} holds results of a different sweep spec (hash "
                    f"{str(old_hash)[:12]}, this spec {self.spec.spec_hash[:12]}); "
                    "use another --out folder or delete that one")
            if old.get("backend", self.spec.backend) != self.spec.backend:
                # the same spec, read with another default backend (a spec that names
                # none: the Ritz model until stop 61, the default cell model since)
                raise SpecError(
                    f"--out: {self.path} holds results of this spec computed with backend "
                    f"{old['backend']!r}; it now runs on {self.spec.backend!r}, and one "
                    f"store never mixes two models: name backend = {old['backend']!r} in "
                    "[sweep] to resume it, or use another --out folder")
        else:
            others = [p.name for p in self.path.iterdir() if not p.name.startswith(".")]
            if others:
                raise SpecError(f"--out: {self.path}: not a sweep folder and not empty "
                                f"({', '.join(sorted(others)[:5])}); choose another --out")

    def prepare(self) -> None:
        """Create the folder (manifest, spec, design table) or check it holds this sweep.

        Raises
        ------
        SpecError
            The folder holds results of a different spec (hash mismatch) or something else.
        """
        self.check()
        self.path.mkdir(parents=True, exist_ok=True)
        man = self.path / "sweep.json"
        for tmp in list(self.parts.glob(".tmp-*")) + list(self.path.glob(".tmp-*")):
            if tmp.is_dir():  # leftovers of a killed run
                shutil.rmtree(tmp, ignore_errors=True)
            else:
                tmp.unlink(missing_ok=True)
        # the manifest first: a run killed during set-up leaves a folder that a rerun accepts
        if not man.exists():
            tmp = self.path / ".tmp-sweep.json"
            write_json(tmp, self.manifest())
            os.replace(tmp, man)
        self.parts.mkdir(exist_ok=True)
        if self.spec_text is not None and not (self.path / "spec.toml").exists():
            tmp = self.path / ".tmp-spec.toml"
            tmp.write_text(self.spec_text)
            os.replace(tmp, self.path / "spec.toml")
        if not (self.path / "designs.zarr").exists():
            _atomic_zarr(design_dataset(self.spec, self.table), self.path / "designs.zarr")

    # ---------------------------------------------------------------- parts
    def part_paths(self) -> list[Path]:
        return sorted(p for p in self.parts.glob("part-*.zarr") if p.is_dir())

    def finished(self, *, include_failed: bool = True) -> np.ndarray:
        """Design indices with a stored result, ascending, unique.

        With ``include_failed=False`` only successful designs count (failed ones are run
        again, and the new result supersedes the failure).
        """
        import zarr

        idx = []
        for p in self.part_paths():
            group = zarr.open_group(str(p), mode="r")
            i = np.asarray(group["design"][:], dtype=np.int64)
            if not include_failed:
                i = i[np.asarray(group.attrs["status"], dtype=object) == "ok"]
            idx.append(i)
        return np.unique(np.concatenate(idx)) if idx else np.zeros(0, np.int64)

    def write_part(self, indices: Sequence[int], records: Sequence[Mapping[str, Any]]) -> Path:
        """Store one finished batch atomically; returns the part's path."""
        final = self.parts / f"part-{int(min(indices)):08d}-{uuid.uuid4().hex[:8]}.zarr"
        tmp = self.parts / f".tmp-{final.name}"
        write_part_group(tmp, indices, records, self.spec.outputs)
        os.rename(tmp, final)
        return final

    # ---------------------------------------------------------------- merge
    def consolidate(self) -> Path:
        """Merge parts and the design table into ``results.zarr`` (exactly one row per design).

        Designs never evaluated have status ``"invalid"`` (with the reason) or ``"pending"``.
        If a design appears in several parts (a failure rerun with ``retry_failed``), a
        success supersedes a failure; otherwise the first part in name order wins.
        """
        import xarray as xr

        designs = xr.open_zarr(self.path / "designs.zarr", consolidated=False).load()
        n = designs.sizes["design"]
        seen = np.zeros(n, bool)
        failed_before = np.zeros(n, bool)
        cols: dict[str, np.ndarray] = {}
        dims: dict[str, tuple[str, ...]] = {}
        for p in self.part_paths():
            part = read_part_group(p)
            idx = part.pop("design")
            # first result wins, except that a success supersedes an earlier failure
            ok_here = part["status"] == "ok"
            keep = ~seen[idx] | (failed_before[idx] & ok_here)
            seen[idx] = True
            failed_before[idx[keep]] = ~ok_here[keep]
            idx = idx[keep]
            for name, arr in part.items():
                vals = arr[keep]
                if name not in cols:
                    dims[name] = ("design", "point")[:vals.ndim]
                    shape = (n, *vals.shape[1:])
                    if vals.dtype == object:
                        cols[name] = np.full(shape, "", dtype=object)
                    elif vals.dtype == bool:
                        cols[name] = np.zeros(shape, bool)
                    elif vals.dtype.kind in "iu":
                        cols[name] = np.zeros(shape, vals.dtype)
                    else:
                        cols[name] = np.full(shape, np.nan)
                col = cols[name]
                if col.ndim == 2 and vals.shape[1] > col.shape[1]:  # longer curves: widen
                    fill = False if col.dtype == bool else np.nan
                    wider = np.full((n, vals.shape[1]), fill, dtype=col.dtype)
                    wider[:, :col.shape[1]] = col
                    cols[name] = col = wider
                if col.ndim == 2:
                    col[idx, :vals.shape[1]] = vals
                else:
                    col[idx] = vals
        # one point axis: a curve a part has only on shorter paths (an extra curve that
        # only some parts record) is padded to the longest curve of the sweep
        width = max((c.shape[1] for c in cols.values() if c.ndim == 2), default=0)
        for name, col in list(cols.items()):
            if col.ndim == 2 and col.shape[1] < width:
                fill: Any = (False if col.dtype == bool else "" if col.dtype == object
                             else 0 if col.dtype.kind in "iu" else np.nan)
                wider = np.full((n, width), fill, dtype=col.dtype)
                wider[:, :col.shape[1]] = col
                cols[name] = wider
        status = cols.get("status", np.full(n, "", dtype=object))
        error = cols.get("error", np.full(n, "", dtype=object))
        valid = designs["valid"].values
        reasons = designs["invalid_reason"].values
        for i in np.flatnonzero(~seen):
            status[i] = "pending" if valid[i] else "invalid"
            error[i] = "" if valid[i] else str(reasons[i])
        cols["status"], cols["error"] = status, error
        dims.setdefault("status", ("design",))
        dims.setdefault("error", ("design",))
        res = xr.Dataset({k: (dims[k], v) for k, v in cols.items()},
                         coords={"design": np.arange(n, dtype=np.int64)})
        out = xr.merge([designs.drop_vars("invalid_reason"), res], compat="override",
                       join="left")
        man = self.manifest()
        out.attrs = {"format": FORMAT, "spec_hash": self.spec.spec_hash,
                     "spec": json.dumps(man["spec"]), "versions": json.dumps(man["versions"]),
                     "backend": self.spec.backend, "pmax": self.spec.pmax,
                     "parameters": json.dumps([q.name for q in self.spec.parameters]),
                     "outputs": json.dumps(list(self.spec.outputs))}
        final = self.path / "results.zarr"
        tmp = self.path / f".tmp-results-{uuid.uuid4().hex[:8]}.zarr"
        out.to_zarr(tmp, mode="w", zarr_format=3, consolidated=False)
        if final.exists():
            old = self.path / f".tmp-old-results-{uuid.uuid4().hex[:8]}"
            os.rename(final, old)
            os.rename(tmp, final)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.rename(tmp, final)
        return final


def collect_parts(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """The finished designs of a sweep folder, read from its parts (no merge, no results
    file needed: usable while the sweep runs). One row per finished design, ascending
    design index; a success supersedes a failure of the same design. Curves are padded
    with NaN to the longest; ``{}`` when nothing has finished.
    """
    parts = sorted(p for p in (Path(path) / "parts").glob("part-*.zarr") if p.is_dir())
    rows: dict[int, dict[str, Any]] = {}
    for p in parts:
        part = read_part_group(p)
        for r, i in enumerate(part["design"]):
            row = {k: v[r] for k, v in part.items()}
            old = rows.get(int(i))
            if old is None or (old["status"] != "ok" and row["status"] == "ok"):
                rows[int(i)] = row
    if not rows:
        return {}
    order = sorted(rows)
    keys = sorted({k for r in rows.values() for k in r})
    out: dict[str, np.ndarray] = {}
    for k in keys:
        vals = [rows[i].get(k) for i in order]
        first = next(v for v in vals if v is not None)
        if isinstance(first, np.ndarray) and first.ndim == 1:
            m = max(len(v) for v in vals if v is not None)
            fill: Any = False if first.dtype == bool else np.nan
            arr = np.full((len(vals), m), fill, dtype=bool if first.dtype == bool else float)
            for j, v in enumerate(vals):
                if v is not None:
                    arr[j, :len(v)] = v
            out[k] = arr
        elif isinstance(first, str):
            out[k] = _strings(["" if v is None else str(v) for v in vals])
        else:
            out[k] = np.array([np.nan if v is None else v for v in vals])
    out["design"] = np.asarray(order, dtype=np.int64)
    return out


def open_results(path: str | os.PathLike[str]) -> Any:
    """Open a sweep's results as an xarray Dataset (a sweep folder or its ``results.zarr``).

    Raises
    ------
    MultimorphError
        No results there (the message says whether the sweep is unfinished).
    """
    import xarray as xr

    p = Path(path)
    if (p / "results.zarr").is_dir():
        p = p / "results.zarr"
    if not (p.is_dir() and ((p / "zarr.json").exists() or (p / ".zgroup").exists())):
        hint = " (the sweep has not finished: rerun it to resume)" if (
            p / "sweep.json").exists() else ""
        raise MultimorphError(f"{path}: no sweep results found{hint}")
    return xr.open_zarr(p, consolidated=False).load()


def answered_by(ds: Any) -> tuple[str, dict[str, int]]:
    """Which cell model a sweep's results asked for and which answered its designs.

    Returns the backend as a model name (``"ritz"`` for ``"rom"``) and the designs that
    succeeded, counted by the model that answered each (its ``meta`` record names it; a
    calibrated backend answers a cell outside its box with the Ritz model), e.g.
    ``("calibrated-fast", {"calibrated-fast": 5, "ritz": 2})``.
    """
    def name(backend: str) -> str:
        return "ritz" if backend == "rom" else backend

    model = name(str(ds.attrs.get("backend", "")))
    ok = np.asarray(ds["status"].values) == "ok"
    metas = ds["meta"].values if "meta" in ds else np.full(ok.shape, "")
    counts: dict[str, int] = {}
    for m in metas[ok]:
        try:
            who = json.loads(str(m)).get("model") if m else None
        except (ValueError, AttributeError):
            who = None
        who = name(str(who)) if who else model
        counts[who] = counts.get(who, 0) + 1
    return model, counts
