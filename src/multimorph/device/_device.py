"""Devices: modules on a backbone (series and parallel branches), all on one pressure line.

TOML form (units as strings; bare numbers SI)::

    [device]
    name = "bend-then-twist gripper"
    pmax = "60 kPa"

    [materials.soft]              # optional named materials (else library names)
    model = "gent"
    mu = "60 kPa"
    jm = 12

    [cells.finger]                # optional named cells, referenced by modules
    length = "6 mm"  ...          # the [cell] keys of ``multimorph cell``
    material = "soft"

    [[module]]
    name = "twister"
    kind = "twisting"             # bending | stretching | twisting
    cell = "twist-cell"           # a [cells.*] name or an inline table
    cells = 8                     # cells in series
    tilt = "30 deg"               # twisting: chamber tilt to the strip axis
    shaft_radius = "6 mm"
    strips = 3

    [[module]]
    name = "finger"
    kind = "bending"
    cell = "finger"
    cells = 10
    attach_to = "twister"         # a parallel branch starting at the end of "twister"
    count = 3                     # three identical fingers around the axis
    radius = "8 mm"
    orientation = "0 deg"         # 180 deg: bends the other way

Modules of one branch follow each other in the order given (``start`` may place one
explicitly; overlapping modules are an error).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from multimorph.device._modules import Module
from multimorph.errors import SpecError
from multimorph.geometry import CellGeometry
from multimorph.limits import (
    MAX_CELLS_PER_MODULE,
    MAX_COPIES,
    check_pressure_scale,
    format_bytes,
)
from multimorph.names import kind_name
from multimorph.units import to_angle, to_si

__all__ = ["Device", "device_from_spec"]

_MODULE_KEYS = {"name", "kind", "cell", "cells", "branch", "attach_to", "start", "count",
                "radius", "orientation", "tilt", "shaft_radius", "strips"}


@dataclass(frozen=True)
class Device:
    """Modules on one pressure line (validated: unique names, known parents, no overlaps).

    Parameters
    ----------
    modules : sequence of Module
    name : str
    pmax : float
        Design (maximum supply) pressure (Pa).
    """

    modules: tuple[Module, ...]
    name: str = "device"
    pmax: float = 60e3
    meta: dict[str, Any] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        mods = tuple(self.modules)
        object.__setattr__(self, "modules", mods)
        if not mods:
            raise SpecError("device: needs at least one [[module]]")
        if not (math.isfinite(self.pmax) and self.pmax > 0):
            raise SpecError(f"device.pmax: must be a positive pressure, got {self.pmax!r} Pa")
        names = [module.name for module in mods]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise SpecError(f"device: module names must be unique; repeated: {', '.join(dup)}")
        for module in mods:
            if module.attach_to is not None and module.attach_to not in names:
                raise SpecError(f"module {module.name!r}: attach_to {module.attach_to!r} is not a "
                                f"module of this device (modules: {', '.join(names)})")
            if module.attach_to == module.name:
                raise SpecError(f"module {module.name!r}: cannot attach to itself")
        by_branch: dict[str, list[Module]] = {}
        for module in mods:
            by_branch.setdefault(module.branch, []).append(module)
        for branch, ms in by_branch.items():
            parents = {module.attach_to for module in ms if module.attach_to is not None}
            if len(parents) > 1:
                raise SpecError(f"branch {branch!r}: its modules attach to different parents "
                                f"{sorted(str(p) for p in parents)}; give each branch one parent")
            ordered = sorted(ms, key=lambda module: module.start)
            for a, b in itertools.pairwise(ordered):
                if b.start < a.end - 1e-12:
                    raise SpecError(
                        f"modules {a.name!r} and {b.name!r} overlap on branch {branch!r}: "
                        f"{a.name!r} spans {a.start * 1e3:.4g}–{a.end * 1e3:.4g} mm, "
                        f"{b.name!r} starts at {b.start * 1e3:.4g} mm")
        # no cycles through attach_to
        parent: dict[str, str | None] = {}
        for module in mods:
            if parent.get(module.branch) is None:
                parent[module.branch] = module.attach_to
        branch_of = {module.name: module.branch for module in mods}
        for b in parent:
            seen = {b}
            cur = parent[b]
            while cur is not None:
                nb = branch_of[cur]
                if nb in seen:
                    raise SpecError(f"branch {b!r}: attach_to forms a cycle")
                seen.add(nb)
                cur = parent[nb]

    def module(self, name: str) -> Module:
        for module in self.modules:
            if module.name == name:
                return module
        raise SpecError(f"no module named {name!r}")

    def branches(self) -> dict[str, list[Module]]:
        """Modules per branch, in order along the branch."""
        out: dict[str, list[Module]] = {}
        for module in self.modules:
            out.setdefault(module.branch, []).append(module)
        return {k: sorted(v, key=lambda module: module.start) for k, v in out.items()}


def _length(v: Any, field_: str, *, allow_zero: bool = False) -> float:
    x = to_si(v, "m", field=field_)
    if not math.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        raise SpecError(f"{field_}: must be a {'non-negative' if allow_zero else 'positive'} "
                        f"length, got {v!r}")
    return x


def _count(v: Any, field_: str, attr: str, limit: int, cell: CellGeometry) -> int:
    """A positive integer count (cells in series, copies, strips) of at most ``limit``;
    ``attr`` is the :class:`Module` field it sets."""
    if isinstance(v, bool) or not isinstance(v, int) or v < 1:
        raise SpecError(f"{field_}: {attr} must be a positive integer, got {v!r}")
    if v > limit:
        # each cell (and copy) is drawn with a few points in every shape and animation frame
        what = (f"{v} cells of {cell.length * 1e3:.3g} mm make a {v * cell.length:.3g} m "
                "module, and" if attr == "n_cells" else f"with {v} copies")
        raise SpecError(f"{field_}: {v} is more than {limit}; {what} every shape would hold "
                        f"{format_bytes(4.0 * 24 * v)} of points")
    return v


def _angle(v: Any, field_: str) -> float:
    x = to_angle(v, field=field_)
    if not math.isfinite(x):
        raise SpecError(f"{field_}: must be a finite angle, got {v!r}")
    return x


def _named_tables(spec: Mapping[str, Any], key: str) -> dict[str, Mapping[str, Any]]:
    """``[key.<name>]`` tables of a spec (SpecError naming the key if not tables)."""
    tables = spec.get(key, {})
    if not isinstance(tables, Mapping):
        raise SpecError(f"[{key}]: expected named tables [{key}.<name>], got {tables!r}")
    for name, table in tables.items():
        if not isinstance(table, Mapping):
            raise SpecError(f"{key}.{name}: expected a table, got {table!r}")
    return dict(tables)


def device_from_spec(spec: Mapping[str, Any]) -> Device:
    """Build a :class:`Device` from a parsed TOML mapping (see the module docstring)."""
    from multimorph.materials import material_from_spec

    if not isinstance(spec, Mapping):
        raise SpecError("device spec: expected a table")
    unknown = sorted(set(spec) - {"device", "materials", "cells", "module"})
    if unknown:
        raise SpecError(f"device spec: unknown top-level key(s) {', '.join(unknown)}; expected "
                        "[device], [materials.*], [cells.*], [[module]]")
    dev = spec.get("device", {})
    if not isinstance(dev, Mapping):
        raise SpecError("[device]: expected a table")
    bad = sorted(set(dev) - {"name", "pmax", "description"})
    if bad:
        raise SpecError(f"[device]: unknown key(s) {', '.join(bad)}")
    pmax = to_si(dev.get("pmax", "60 kPa"), "Pa", field="device.pmax")
    if not (math.isfinite(pmax) and pmax > 0):
        raise SpecError(f"device.pmax: must be a positive, finite pressure, got "
                        f"{dev.get('pmax')!r}")

    named_materials = {}
    for name, table in _named_tables(spec, "materials").items():
        named_materials[name] = material_from_spec({"name": name, **dict(table)},
                                                   f"materials.{name}")

    def mat(v: Any, where: str) -> Any:
        if isinstance(v, str) and v in named_materials:
            return named_materials[v]
        return material_from_spec(v, where)

    def cell_of(v: Any, where: str) -> CellGeometry:
        if isinstance(v, Mapping):
            table = dict(v)
        else:
            raise SpecError(f"{where}: expected a cell table")
        for k in ("material", "bottom_material"):
            if k in table:
                table[k] = mat(table[k], f"{where}.{k}")
        return CellGeometry.from_spec(table, field=where)

    cells = {name: cell_of(t, f"cells.{name}")
             for name, t in _named_tables(spec, "cells").items()}

    raw_modules = spec.get("module")
    if not raw_modules:
        raise SpecError("device spec: needs at least one [[module]] table")
    if not isinstance(raw_modules, Sequence) or isinstance(raw_modules, str | bytes):
        raise SpecError("device spec: 'module' must be an array of tables ([[module]])")
    modules: list[Module] = []
    cursor: dict[str, float] = {}
    for i, raw in enumerate(raw_modules):
        where = f"module[{i}]"
        if not isinstance(raw, Mapping):
            raise SpecError(f"{where}: expected a table")
        name = raw.get("name")
        if not isinstance(name, str) or not name:
            raise SpecError(f"{where}.name: missing (a unique module name)")
        where = f"module {name!r}"
        extra = sorted(set(raw) - _MODULE_KEYS)
        if extra:
            raise SpecError(f"{where}: unknown key(s) {', '.join(extra)}")
        if "kind" not in raw:
            raise SpecError(f"{where}.kind: missing (bending, stretching or twisting; bend, "
                            "stretch, twist are accepted)")
        c = raw.get("cell")
        if c is None:
            raise SpecError(f"{where}.cell: missing (a [cells.*] name or an inline table)")
        if isinstance(c, str):
            if c not in cells:
                raise SpecError(f"{where}.cell: no [cells.{c}] table (cells: "
                                f"{', '.join(cells) or 'none'})")
            cell = cells[c]
        else:
            cell = cell_of(c, f"{where}.cell")
        default_branch = f"{name}-branch" if raw.get("attach_to") else "main"
        branch = str(raw.get("branch", default_branch))
        if "start" in raw:
            start = _length(raw["start"], f"{where}.start", allow_zero=True)
        else:
            start = cursor.get(branch, 0.0)
        counts = {attr: _count(raw.get(key, default), f"{where}.{key}", attr, limit, cell)
                  for key, attr, default, limit in (
                      ("cells", "n_cells", 1, MAX_CELLS_PER_MODULE),
                      ("count", "count", 1, MAX_COPIES),
                      ("strips", "strips", 3, MAX_COPIES))}
        kw: dict[str, Any] = dict(
            name=name, kind=kind_name(str(raw["kind"])), cell=cell, branch=branch,
            attach_to=raw.get("attach_to"), start=start, **counts,
        )
        if "radius" in raw:
            kw["radius"] = _length(raw["radius"], f"{where}.radius", allow_zero=True)
        if "orientation" in raw:
            kw["orientation"] = _angle(raw["orientation"], f"{where}.orientation")
        if "tilt" in raw:
            kw["tilt"] = _angle(raw["tilt"], f"{where}.tilt")
        if "shaft_radius" in raw:
            kw["shaft_radius"] = _length(raw["shaft_radius"], f"{where}.shaft_radius")
        module = Module(**kw)
        cursor[branch] = max(cursor.get(branch, 0.0), module.end)
        modules.append(module)
    check_pressure_scale(pmax, min(mod.cell.mu for mod in modules), "device.pmax")
    return Device(tuple(modules), name=str(dev.get("name", "device")), pmax=pmax)
