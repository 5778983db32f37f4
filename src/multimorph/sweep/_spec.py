"""Sweep specs (TOML): a base cell, the parameters to vary, the backend and the outputs.

Example::

    [cell]                      # the base design, as for ``multimorph cell``
    length = "20 mm"
    ...
    [cell.material]
    model = "gent"
    mu = "245 kPa"
    jm = 20

    [sweep]
    backend = "calibrated-fast" # the default cell model (also when left out); "calibrated",
                                # "ritz" (alias "rom": the reduced model, about twice as
                                # stiff as FE) or "fe"
    outputs = ["characteristic", "curves"]
    pmax = "60 kPa"
    combine = "grid"            # "grid" (product), "zip", "random", or the space-filling
                                # "sobol" (scrambled Sobol) and "lhs" (Latin hypercube),
                                # each with samples and seed
    kind = "bending"            # or "stretching" (mirror-symmetric cells) or "twisting"
                                # (tilted cells: a "tilt" parameter or tilt = "30 deg")

    [[sweep.parameter]]
    name = "ht/d"
    start = 0.03
    stop = 0.08
    num = 6

    [[sweep.parameter]]
    name = "cell.side_wall"
    values = ["1 mm", "2 mm"]

Parameters may also be given as a table ``[sweep.parameters]`` mapping names to a list of
values or to a range table: ``"ht/d" = {start = 0.03, stop = 0.08, num = 6}``.

A malformed spec raises :class:`~multimorph.errors.SpecError`; design points whose geometry or
material is invalid are *kept* in the design table, marked invalid with the reason.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from multimorph.errors import SpecError
from multimorph.geometry import CELL_KEYS, CellGeometry, TiltedCell
from multimorph.io import load_toml
from multimorph.limits import check_pressure_scale, format_bytes, memory_budget
from multimorph.names import kind_name
from multimorph.sweep._params import Parameter, parse_parameter
from multimorph.units import to_si

#: The backend of a spec that names none: the default cell model
#: (:data:`multimorph.models.DEFAULT_MODEL`, the calibrated model on emulated Ritz features;
#: until stop 61 the Ritz model, ``"rom"``).
DEFAULT_BACKEND = "calibrated-fast"

__all__ = ["CELL_KINDS", "DEFAULT_BACKEND", "OUTPUTS", "DesignTable", "InvalidPoint",
           "SweepSpec", "load_sweep_spec", "parse_sweep_spec"]

#: What a sweep can store per design.
OUTPUTS = ("characteristic", "curves")
BACKENDS = ("rom", "fe")
COMBINE = ("grid", "zip", "random", "sobol", "lhs")
#: Cell kinds a sweep can evaluate: the three kinds of cell the modules use.
CELL_KINDS = ("bending", "stretching", "twisting")
_SWEEP_KEYS = {"backend", "outputs", "pmax", "combine", "samples", "seed", "parameter",
               "parameters", "options", "name", "kind", "tilt", "min_chamber"}
#: Most points of one stored curve (the reduced model's step limit + 1; FE paths are shorter).
CURVE_POINTS = 601
# order in which parameter kinds are applied (ratios need the final d; mu_b/mu the final mu)
_KIND_ORDER = {"length": 0, "material": 1, "ratio": 2, "modulus": 3, "tilt": 4}


@dataclass(frozen=True)
class InvalidPoint:
    """A design point that cannot be built (kept in the table, never silently dropped)."""

    index: int
    values: dict[str, float]
    reason: str

    def to_dict(self) -> dict[str, Any]:
        return {"index": self.index, "values": self.values, "reason": self.reason}


@dataclass(frozen=True, eq=False)
class DesignTable:
    """All design points of a sweep, in a fixed order (the design index).

    Attributes
    ----------
    names : tuple of str
        Parameter names (columns of ``values``).
    units : tuple of str
        SI unit of each column.
    values : ndarray (n, p)
        Parameter values (SI) per design.
    cells : list of CellGeometry, TiltedCell or None
        The built design (tilted cells in a twisting sweep), ``None`` where invalid.
    invalid : list of InvalidPoint
    """

    names: tuple[str, ...]
    units: tuple[str, ...]
    values: np.ndarray
    cells: list[CellGeometry | TiltedCell | None]
    invalid: list[InvalidPoint]

    def __len__(self) -> int:
        return len(self.cells)

    @property
    def valid_indices(self) -> np.ndarray:
        """Design indices with a valid geometry (int64, ascending)."""
        return np.array([i for i, c in enumerate(self.cells) if c is not None], dtype=np.int64)

    def row(self, i: int) -> dict[str, float]:
        return {n: float(v) for n, v in zip(self.names, self.values[i], strict=True)}


@dataclass(frozen=True, eq=False)
class SweepSpec:
    """A parsed sweep spec (SI values inside).

    Attributes
    ----------
    base : CellGeometry
        The base design every point starts from.
    parameters : tuple of Parameter
    combine : {"grid", "zip", "random"}
    samples : int or None
        Number of random designs (``combine = "random"``).
    seed : int
        Random seed (``combine = "random"``).
    backend : str
        ``"calibrated-fast"`` (:data:`DEFAULT_BACKEND`, when the spec names none),
        ``"calibrated"``, ``"ritz"`` (alias ``"rom"``), ``"fe"``, or a backend registered
        with :func:`multimorph.sweep.register_backend`.
    outputs : tuple of str
        Subset of ``("characteristic", "curves")``.
    pmax : float
        Largest pressure of each equilibrium path (Pa).
    options : dict
        Backend options (``[sweep.options]``), passed through to the backend.
    raw : dict
        The whole spec as parsed from TOML (stored with the results).
    kind : {"bending", "stretching", "twisting"}
        The kind of cell every design is: as built (bending), mirror-symmetric (stretching:
        bottom wall and material set to the top's, :meth:`CellGeometry.mirrored`), or tilted
        (twisting: a :class:`~multimorph.geometry.TiltedCell` with the design's tilt).
    tilt : float or None
        Fixed chamber tilt (rad) of a twisting sweep that does not sweep ``tilt``.
    min_chamber : float
        Least chamber size in every direction as a fraction of the cell length d: smaller
        chambers make a design invalid (kept, with the reason). 0 accepts any chamber.
    """

    base: CellGeometry
    parameters: tuple[Parameter, ...]
    combine: str
    samples: int | None
    seed: int
    backend: str
    outputs: tuple[str, ...]
    pmax: float
    options: dict[str, Any] = field(default_factory=dict)
    raw: dict[str, Any] = field(default_factory=dict)
    kind: str = "bending"
    tilt: float | None = None
    min_chamber: float = 0.0

    @property
    def spec_hash(self) -> str:
        """SHA-256 of the canonical JSON of the spec (formatting and comments do not count)."""
        text = json.dumps(self.raw, sort_keys=True, separators=(",", ":"), default=str)
        return hashlib.sha256(text.encode()).hexdigest()

    @property
    def n_designs(self) -> int:
        if self.combine in ("random", "sobol", "lhs"):
            assert self.samples is not None
            return self.samples
        if self.combine == "zip":
            return len(self.parameters[0].values)
        return math.prod(len(p.values) for p in self.parameters)

    def point_values(self) -> np.ndarray:
        """Parameter values of every design, shape (n, p), SI, in design-index order."""
        p = self.parameters
        if self.combine == "random":
            rng = np.random.default_rng(self.seed)
            assert self.samples is not None
            return np.column_stack([q.sample(rng, self.samples) for q in p])
        if self.combine in ("sobol", "lhs"):
            from scipy.stats import qmc

            assert self.samples is not None
            engine = (qmc.Sobol(len(p), scramble=True, seed=self.seed)
                      if self.combine == "sobol" else qmc.LatinHypercube(len(p), seed=self.seed))
            u = engine.random(self.samples)
            return np.column_stack([q.from_unit(u[:, j]) for j, q in enumerate(p)])
        if self.combine == "zip":
            return np.array([list(v) for v in zip(*(q.values for q in p), strict=True)], float)
        return np.array(list(itertools.product(*(q.values for q in p))), float).reshape(-1, len(p))

    def build(self, values: Mapping[str, float]) -> CellGeometry | TiltedCell:
        """The design at one point: the base cell with ``values`` applied (SpecError if invalid).

        Lengths and material parameters are applied first, then ratios (× the final d), then
        ``mu`` (wall material scaled to that shear modulus), then ``mu_b/mu``. A stretching
        sweep's cell is then made mirror-symmetric, a twisting sweep's is tilted.
        """
        lengths = {k: getattr(self.base, k) for k in CELL_KEYS}
        mats = {"material": self.base.material, "bottom_material": self.base.bottom_material}
        tilt = self.tilt
        for q in sorted(self.parameters,
                        key=lambda q: (_KIND_ORDER[q.kind], q.target == "mu_b/mu")):
            v = float(values[q.name])
            if q.kind == "tilt":
                tilt = v
            elif q.kind == "length":
                lengths[q.target] = v
            elif q.kind == "material":
                which, key = q.target.split(".")
                chosen = mats[which]
                mats[which] = replace(chosen, params={**chosen.params, key: v})
            elif q.kind == "ratio":
                lengths[q.target] = v * lengths["length"]
            elif q.target == "mu":
                if not v > 0:
                    raise SpecError(f"mu must be > 0, got {v:.4g} Pa")
                chosen = mats["material"]
                mats["material"] = chosen.scaled(v / chosen.shear_modulus)
            else:  # mu_b/mu
                if not v > 0:
                    raise SpecError(f"mu_b/mu must be > 0, got {v:.4g}")
                b = mats["bottom_material"]
                mats["bottom_material"] = b.scaled(
                    v * mats["material"].shear_modulus / b.shear_modulus)
        if self.kind == "stretching":
            lengths["bottom_wall"] = lengths["top_wall"]
            mats["bottom_material"] = mats["material"]
        cell = CellGeometry(**lengths, material=mats["material"],
                            bottom_material=mats["bottom_material"],
                            symmetric=self.kind == "stretching")
        if self.min_chamber > 0:
            d = cell.length
            for name, size in (("width", cell.wc), ("height", cell.hc), ("length", cell.dc)):
                if size < self.min_chamber * d:
                    raise SpecError(f"chamber {name} {size * 1e3:.4g} mm is below min_chamber "
                                    f"= {self.min_chamber:g} d ({self.min_chamber * d * 1e3:.4g}"
                                    " mm)")
        if self.kind == "twisting":
            assert tilt is not None
            return TiltedCell(cell, tilt)
        return cell

    def design_table(self) -> DesignTable:
        """Every design point, valid or not (invalid ones carry the reason)."""
        vals = self.point_values()
        names = tuple(q.name for q in self.parameters)
        cells: list[CellGeometry | TiltedCell | None] = []
        invalid: list[InvalidPoint] = []
        for i, row in enumerate(vals):
            point = {n: float(v) for n, v in zip(names, row, strict=True)}
            try:
                cells.append(self.build(point))
            except SpecError as exc:
                cells.append(None)
                invalid.append(InvalidPoint(i, point, str(exc)))
        return DesignTable(names, tuple(q.unit for q in self.parameters), vals, cells, invalid)


def _parameter_entries(sweep: Mapping[str, Any]) -> list[tuple[str, Mapping[str, Any]]]:
    entries: list[tuple[str, Mapping[str, Any]]] = []
    lst = sweep.get("parameter", [])
    if not isinstance(lst, list):
        raise SpecError("sweep.parameter: expected an array of tables [[sweep.parameter]]")
    for i, e in enumerate(lst):
        entries.append((f"sweep.parameter[{i}]", e))
    tbl = sweep.get("parameters", {})
    if not isinstance(tbl, Mapping):
        raise SpecError("sweep.parameters: expected a table of name = values or range")
    for name, v in tbl.items():
        where = f"sweep.parameters.{name!r}"
        if isinstance(v, list):
            entries.append((where, {"name": name, "values": v}))
        elif isinstance(v, Mapping):
            if "name" in v or "path" in v:
                raise SpecError(f"{where}: the key is the name; drop 'name'/'path'")
            entries.append((where, {"name": name, **v}))
        else:
            raise SpecError(f"{where}: expected a list of values or a range table, got {v!r}")
    return entries


def design_bytes(outputs: Sequence[str]) -> int:
    """Estimated memory (bytes) a sweep holds per design: the design table entry (a built
    cell, its parameters, about 2 kB) and, with ``"curves"``, a path of up to
    :data:`CURVE_POINTS` points (pressure, curvature, peak stretch and stability)."""
    return 2_000 + (CURVE_POINTS * (3 * 8 + 1) if "curves" in outputs else 0)


def _check_size(params: Sequence[Parameter], combine: str, samples: int | None,
                outputs: Sequence[str]) -> None:
    """Refuse, before any work, a sweep whose estimated memory exceeds the budget."""
    if combine == "random":
        n, where = int(samples or 0), "sweep.samples"
    elif combine == "zip":
        n, where = len(params[0].values), "sweep"
    else:
        n = math.prod(len(q.values) for q in params)
        where = "sweep"
    need = n * design_bytes(outputs)
    budget = memory_budget()
    if need > budget:
        grid = (f" (grid of {' x '.join(str(len(q.values)) for q in params)})"
                if combine == "grid" and len(params) > 1 else "")
        raise SpecError(
            f"{where}: {n} designs{grid} x ~{format_bytes(design_bytes(outputs))} each "
            f"(design table and results) = {format_bytes(need)}, more than this run may hold "
            f"({format_bytes(budget)}, half the memory); use fewer values or samples, or "
            "split the sweep")


def parse_sweep_spec(raw: Mapping[str, Any]) -> SweepSpec:
    """Parse a sweep spec from a TOML mapping (see the module docstring).

    Raises
    ------
    SpecError
        The spec is malformed (message names the field): missing tables, unknown keys or
        parameter paths, empty ranges, a parameter given twice, zip lengths that differ.
    """
    if not isinstance(raw, Mapping):
        raise SpecError("sweep spec: expected a TOML table")
    unknown = sorted(set(raw) - {"cell", "sweep"})
    if unknown:
        raise SpecError(f"sweep spec: unknown table(s) {', '.join(unknown)}; expected [cell] "
                        "and [sweep] (module and device base specs are not supported yet)")
    if "cell" not in raw:
        raise SpecError("sweep spec: missing the base design table [cell]")
    if "sweep" not in raw or not isinstance(raw["sweep"], Mapping):
        raise SpecError("sweep spec: missing table [sweep]")
    base = CellGeometry.from_spec(raw["cell"])
    assert base.bottom_material is not None
    sweep = raw["sweep"]
    bad = sorted(set(sweep) - _SWEEP_KEYS)
    if bad:
        raise SpecError(f"sweep: unknown key(s) {', '.join(bad)}; expected "
                        f"{', '.join(sorted(_SWEEP_KEYS))}")

    backend = sweep.get("backend", DEFAULT_BACKEND)
    if not isinstance(backend, str) or not backend:
        raise SpecError(f"sweep.backend: expected the name of a backend (calibrated-fast, "
                        f"calibrated, ritz, fe), got {backend!r}")
    outputs = sweep.get("outputs", ["characteristic"])
    if isinstance(outputs, str):
        outputs = [outputs]
    if not isinstance(outputs, list) or not outputs:
        raise SpecError(f"sweep.outputs: expected a non-empty list from {OUTPUTS}")
    for output in outputs:
        if output not in OUTPUTS:
            raise SpecError(f"sweep.outputs: unknown output {output!r}; expected one of {OUTPUTS}")
    if "pmax" not in sweep:
        raise SpecError("sweep.pmax: missing (largest pressure, e.g. \"60 kPa\")")
    pmax = to_si(sweep["pmax"], "Pa", field="sweep.pmax")
    if not (math.isfinite(pmax) and pmax > 0):
        raise SpecError(f"sweep.pmax: must be a positive pressure, got {sweep['pmax']!r}")
    combine = sweep.get("combine", "grid")
    if combine not in COMBINE:
        raise SpecError(f"sweep.combine: expected one of {COMBINE}, got {combine!r}")
    options = sweep.get("options", {})
    if not isinstance(options, Mapping):
        raise SpecError("sweep.options: expected a table of backend options")

    entries = _parameter_entries(sweep)
    if not entries:
        raise SpecError("sweep: no parameters; add [[sweep.parameter]] entries")
    params = [parse_parameter(e, field=where, base_material=base.material,
                              base_bottom=base.bottom_material, cell_table=raw["cell"])
              for where, e in entries]
    seen: dict[str, str] = {}
    for q in params:
        if q.target in seen:
            raise SpecError(f"sweep: parameters {seen[q.target]!r} and {q.name!r} both set "
                            f"{q.target}; keep one")
        seen[q.target] = q.name

    kind, tilt, min_chamber = _cell_kind(sweep, base, params)
    samples: int | None = None
    seed = sweep.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise SpecError(f"sweep.seed: expected an integer, got {seed!r}")
    if combine in ("random", "sobol", "lhs"):
        samples = sweep.get("samples")
        if isinstance(samples, bool) or not isinstance(samples, int):
            raise SpecError(f"sweep.samples: combine = \"{combine}\" needs an integer number "
                            f"of samples, got {samples!r}")
        if samples < 1:
            raise SpecError(f"sweep.samples: empty sample (samples = {samples}); need >= 1")
        if combine != "random":
            lists = [q.name for q in params if q.scale == "list"]
            if lists:
                raise SpecError(f"sweep.combine = \"{combine}\": parameters need ranges "
                                f"(start, stop), not lists: {', '.join(lists)}")
    else:
        if "samples" in sweep:
            raise SpecError("sweep.samples: applies to combine = \"random\", \"sobol\" or "
                            "\"lhs\" only")
        for q in params:
            if not q.values:
                raise SpecError(f"sweep parameter {q.name!r}: a range needs 'num' unless "
                                "combine = \"random\"")
        if combine == "zip":
            lens = {q.name: len(q.values) for q in params}
            if len(set(lens.values())) > 1:
                raise SpecError("sweep.combine = \"zip\": parameters must have the same number "
                                f"of values, got {lens}")
    check_pressure_scale(pmax, base.mu, "sweep.pmax")
    _check_size(params, combine, samples, outputs)
    return SweepSpec(base=base, parameters=tuple(params), combine=combine, samples=samples,
                     seed=seed, backend=backend, outputs=tuple(dict.fromkeys(outputs)),
                     pmax=pmax, options=dict(options),
                     raw=json.loads(json.dumps(raw, default=str)), kind=kind, tilt=tilt,
                     min_chamber=min_chamber)


def _cell_kind(sweep: Mapping[str, Any], base: CellGeometry, params: list[Parameter],
               ) -> tuple[str, float | None, float]:
    """``kind``, fixed ``tilt`` and ``min_chamber`` of a ``[sweep]`` table (checked)."""
    kind = sweep.get("kind", "stretching" if base.symmetric else "bending")
    if isinstance(kind, str):
        kind = kind_name(kind)  # "bend" is accepted for "bending" (multimorph.names)
    if kind not in CELL_KINDS:
        raise SpecError(f"sweep.kind: expected one of {', '.join(CELL_KINDS)}, got {kind!r}")
    swept = {q.target for q in params}
    if kind == "stretching" and swept & {"bottom_wall", "bottom_material.mu",
                                         "bottom_material.jm", "mu_b/mu"}:
        raise SpecError("sweep.kind = \"stretching\": the bottom wall and material are the top "
                        "wall's; do not sweep hb/d, mu_b/mu or the bottom material")
    tilt: float | None = None
    if "tilt" in sweep:
        if kind != "twisting":
            raise SpecError("sweep.tilt: applies to kind = \"twisting\" only")
        if "tilt" in swept:
            raise SpecError("sweep.tilt: the tilt is also a swept parameter; keep one")
        tilt = to_si(sweep["tilt"], "rad", field="sweep.tilt")
    if kind == "twisting" and tilt is None and "tilt" not in swept:
        raise SpecError("sweep.kind = \"twisting\" needs a chamber tilt: tilt = \"30 deg\" "
                        "in [sweep], or a \"tilt\" parameter")
    if kind != "twisting" and "tilt" in swept:
        raise SpecError("sweep parameter 'tilt': applies to kind = \"twisting\" only")
    min_chamber = sweep.get("min_chamber", 0.0)
    if isinstance(min_chamber, bool) or not isinstance(min_chamber, int | float) or not (
            math.isfinite(min_chamber) and 0 <= min_chamber < 1):
        raise SpecError(f"sweep.min_chamber: expected a fraction of the cell length in [0, 1),"
                        f" got {min_chamber!r}")
    return kind, tilt, float(min_chamber)


def load_sweep_spec(path: str | os.PathLike[str]) -> SweepSpec:
    """Read and parse a sweep spec file (errors name the file)."""
    raw = load_toml(Path(path))
    try:
        return parse_sweep_spec(raw)
    except SpecError as exc:
        raise SpecError(f"{path}: {exc}") from None
