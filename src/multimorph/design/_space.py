"""Search space: one module per stage, its cell, material and layout from a unit vector.

Each stage owns :data:`N_VARS` coordinates in [0, 1] (unused ones are ignored)::

    0 d    cell length           d_min … d_max
    1 w    cell width            w_min … max_width (a twist stage: at most its shaft's face)
    2 h    cell height           h_min … max_height
    3 ht   top wall              min_wall … half the height left over by a 1 mm chamber
    4 hb   bottom wall (bending; stretching: = ht)
    5 ws   side walls            min_wall … half the width left over
    6 df   end walls             min_wall … half the length left over
    7 wall material              discrete: index into the allowed materials
    8 bottom material (bending)  discrete
    9 tilt (twisting)            10° … 79° (FE meshes tilts below 80°); with a calibrated
                                 strip shear, the tilts it was fitted on (11° … 59°)

Every decoded cell is valid by construction (walls ≥ min_wall, chambers ≥ ``min_chamber``).

With ``boxes`` (the calibrated model's support, one :class:`~multimorph.calibrated.Box` per
cell kind) the same coordinates span the dimensionless groups inside the box instead:
d first (the lengths for which every group's interval and the constraints overlap), then
w/d, ws/d, h/d, ht/d, hb/d, df/d each within its box interval intersected with what
``min_wall``, ``max_width``, ``max_height`` and a chamber of at least ``min_chamber`` and
0.1 d (the data set's least chamber) leave; log groups interpolated in log. Wall
materials whose (equivalent) Gent Jm lies outside the box and bottom materials whose
modulus ratio does so are replaced by the nearest allowed one. A search on the calibrated
model thus spends no evaluation on cells it would refuse.

The number of cells of bend and twist modules is not searched: it follows from the wanted
angle and the cell's predicted motion (:func:`cells_for`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from multimorph.design._target import Stage, TargetSpec
from multimorph.device import Device, Module
from multimorph.errors import SpecError
from multimorph.geometry import CellGeometry, TiltedCell

__all__ = ["N_VARS", "VAR_NAMES", "Candidate", "SearchSpace"]

N_VARS = 10
VAR_NAMES = ("length", "width", "height", "top_wall", "bottom_wall", "side_wall", "end_wall",
             "material", "bottom_material", "tilt")
TILT_RANGE = (math.radians(10.0), math.radians(79.0))
#: Strips of a designed twisting module (the :class:`~multimorph.device.Module` default).
TWIST_STRIPS = 3
#: The calibrated model's cell kind behind each stage kind (a twisting module's tilted cells
#: are answered from their straight cell).
BOX_KIND = {"bend": "bending", "twist": "bending", "stretch": "stretching"}
#: Least chamber size of the FE data set, as a fraction of the cell length.
BOX_MIN_CHAMBER = 0.1


@dataclass(frozen=True)
class Candidate:
    """A decoded design: one cell (and tilt) per stage; module sizes follow later."""

    x: np.ndarray
    cells: tuple[CellGeometry, ...]
    tilts: tuple[float, ...]
    material_index: tuple[tuple[int, int], ...]
    twisting: tuple[bool, ...] = ()
    """Which stages are twisting modules (their cells are tilted by ``tilts``)."""

    def model_cells(self, model: Any = None) -> tuple[CellGeometry | TiltedCell, ...]:
        """The cells as ``model`` is asked for them: a twisting stage's as its tilted cell
        when the model knows tilted cells (``model.tilted``; it answers the strip shear),
        the straight cell otherwise (its module then takes the strip shear by the Ritz
        rule). ``model=None``: the tilted cells."""
        tilted = model is None or bool(getattr(model, "tilted", False))
        return tuple(TiltedCell(c, t) if tilted and i < len(self.twisting)
                     and self.twisting[i] else c
                     for i, (c, t) in enumerate(zip(self.cells, self.tilts, strict=True)))


@dataclass(frozen=True)
class SearchSpace:
    """Bounds of the search (SI) derived from a target's constraints.

    Parameters
    ----------
    target : TargetSpec
    d_range : (float, float)
        Cell length bounds (m).
    min_chamber : float
        Least chamber size in every direction (m).
    """

    target: TargetSpec
    d_range: tuple[float, float] = (4e-3, 20e-3)
    min_chamber: float = 1e-3
    boxes: Mapping[str, Any] | None = field(default=None, compare=False)
    """Calibrated support per cell kind (``"bending"``, ``"stretching"``): decode inside it;
    ``"tilt"``: the (low, high) tilts (rad) of the calibrated strip shear."""
    correction: tuple[Mapping[str, float], ...] | None = field(default=None, compare=False)
    """Per stage, factors on the model's Pc, Ph and motion (see
    :func:`~multimorph.design.evaluate_one`); ``None``: the model as it is."""
    model_order: bool = field(default=False, compare=False)
    """With a ``correction``: the stages must also come in order on the model's own Pc
    (``model_order`` of :func:`~multimorph.design.evaluate_one`; FE in the loop)."""

    @property
    def model_pmax(self) -> float:
        """The pressure the model traces to: ``max_pressure``, or beyond it by the largest
        downward correction of a pressure, so that a corrected Pc or Ph can still fall
        below ``max_pressure`` (at most twice it)."""
        return trace_pmax(self.target.constraints.max_pressure, self.correction)

    @property
    def n_stages(self) -> int:
        return len(self.target.stages)

    @property
    def dim(self) -> int:
        return N_VARS * self.n_stages

    def _lo(self) -> float:
        return 2.0 * self.target.constraints.min_wall + self.min_chamber

    def check(self) -> list[str]:
        """Geometric infeasibilities of the bounds themselves (empty when none)."""
        c = self.target.constraints
        out = []
        lo = self._lo()
        for what, hi in (("max_width", c.max_width), ("max_height", c.max_height)):
            if hi < lo:
                out.append(f"{what} {hi * 1e3:.4g} mm cannot hold two walls of min_wall "
                           f"{c.min_wall * 1e3:.4g} mm and a {self.min_chamber * 1e3:.3g} mm "
                           f"chamber (needs ≥ {lo * 1e3:.4g} mm)")
        if self.d_range[1] < lo:
            out.append(f"cell length up to {self.d_range[1] * 1e3:.4g} mm cannot hold two end "
                       f"walls of min_wall {c.min_wall * 1e3:.4g} mm")
        return out

    def tilt_range(self) -> tuple[float, float]:
        """Tilt bounds (rad): :data:`TILT_RANGE`, narrowed to the tilts the model's strip
        shear was calibrated on (``boxes["tilt"]``, a (low, high) pair) when it says so: a
        twisting module is then designed where FE data back its shear factor."""
        got = self.boxes.get("tilt") if self.boxes else None
        if got is None:
            return TILT_RANGE
        lo = max(TILT_RANGE[0], float(got[0]))
        hi = min(TILT_RANGE[1], float(got[1]))
        return (lo, hi) if hi > lo else TILT_RANGE

    def decode(self, x: np.ndarray) -> Candidate:
        """Cells of one design from its unit vector ``x`` (shape ``(dim,)``)."""
        x = np.clip(np.asarray(x, float), 0.0, 1.0)
        c = self.target.constraints
        mats = c.materials
        nm = len(mats)
        lo = self._lo()
        tmin, mc = c.min_wall, self.min_chamber
        cells, tilts, midx = [], [], []
        t_lo, t_hi = self.tilt_range()
        for i, stage in enumerate(self.target.stages):
            u = x[i * N_VARS:(i + 1) * N_VARS]
            box = self.boxes.get(BOX_KIND[stage.kind]) if self.boxes else None
            w_max = stage_max_width(stage, c.max_width)
            boxed = (_decode_in_box(u, box, self, stage.kind == "stretch", w_max) if box
                     else None)
            if boxed is not None:
                cells.append(boxed[0])
                tilts.append(t_lo + u[9] * (t_hi - t_lo))
                midx.append(boxed[1])
                continue
            d_lo, d_hi = max(self.d_range[0], lo), max(self.d_range[1], lo)
            d = d_lo + u[0] * (d_hi - d_lo)
            w = lo + u[1] * (max(w_max, lo) - lo)
            h = lo + u[2] * (max(c.max_height, lo) - lo)
            room_h = max(h - mc - 2.0 * tmin, 0.0)
            ht = tmin + u[3] * 0.5 * room_h
            hb = tmin + u[4] * 0.5 * room_h
            ws = tmin + u[5] * 0.5 * max(w - mc - 2.0 * tmin, 0.0)
            df = tmin + u[6] * 0.5 * max(d - mc - 2.0 * tmin, 0.0)
            im = min(int(u[7] * nm), nm - 1)
            ib = min(int(u[8] * nm), nm - 1)
            wall = mats[im]
            sym = stage.kind == "stretch"
            if sym:
                hb, ib = ht, im
            bottom = mats[ib]
            cells.append(CellGeometry(d, w, h, ht, hb, ws, df, material=wall,
                                      bottom_material=bottom, symmetric=sym))
            tilts.append(t_lo + u[9] * (t_hi - t_lo))
            midx.append((im, ib))
        return Candidate(x=x, cells=tuple(cells), tilts=tuple(tilts),
                         material_index=tuple(midx),
                         twisting=tuple(s.kind == "twist" for s in self.target.stages))

    def corner(self, *, stiff: bool, material: int, bottom: int | None = None) -> np.ndarray:
        """The stiffest (thickest walls, smallest chambers) or softest design of a material."""
        nm = len(self.target.constraints.materials)
        u = np.empty(N_VARS)
        val = 1.0 if stiff else 0.0
        u[:] = [0.5, 1 - val, 0.5, val, val, val, val, (material + 0.5) / nm,
                ((material if bottom is None else bottom) + 0.5) / nm, 0.5]
        u[0] = 0.0 if stiff else 1.0
        return np.tile(u, self.n_stages)


def trace_pmax(pmax: float, correction: Sequence[Mapping[str, float]] | None) -> float:
    """``pmax`` over the smallest pressure factor of ``correction`` (≤ 1), at most 2 pmax."""
    if not correction:
        return pmax
    low = min(min(f.get("start_pressure", 1.0), f.get("end_pressure", 1.0))
              for f in correction)
    return pmax / min(max(low, 0.5), 1.0)


def _interval(u: float, lo: float, hi: float, log: bool) -> float:
    """A point of [lo, hi] (lo when the interval is empty), log-spaced when ``log``."""
    if not hi > lo:
        return lo
    if log and lo > 0:
        return float(math.exp(math.log(lo) + u * (math.log(hi) - math.log(lo))))
    return lo + u * (hi - lo)


_JM_CACHE: dict[Any, float] = {}


def _jm(material: Any, fn: Any) -> float:
    key = (material.model, tuple(sorted((k, float(v)) for k, v in material.params.items())))
    if key not in _JM_CACHE:
        _JM_CACHE[key] = float(fn(material))
    return _JM_CACHE[key]


def _nearest_allowed(j: int, allowed: Sequence[int], key: Sequence[float]) -> int:
    if j in allowed or not allowed:
        return j
    return min(allowed, key=lambda k: (abs(math.log(key[k] / key[j])), k))


def stage_max_width(stage: Any, max_width: float) -> float:
    """The widest cell a stage may have: ``max_width``, and for a twist stage at most the
    face of its shaft (its strips lie on the faces of a regular polygon around the shaft,
    one face per strip: width ≤ 2 r tan(180°/strips), the module's default 3 strips), so
    that the designed module can be built (and meshed: :mod:`multimorph.fe.mesh`)."""
    if stage.kind != "twist":
        return max_width
    return min(max_width, 2.0 * stage.shaft_radius * math.tan(math.pi / TWIST_STRIPS))


def _decode_in_box(u: np.ndarray, box: Any, space: SearchSpace, sym: bool,
                   max_width: float | None = None,
                   ) -> tuple[CellGeometry, tuple[int, int]] | None:
    """One stage's cell with its groups inside ``box`` (``None``: the box and the
    constraints leave no cell length, then the plain decoding is used)."""
    from multimorph.calibrated._box import LINEAR_GROUPS, equivalent_jm

    c = space.target.constraints
    mats = c.materials
    nm = len(mats)
    lo_g = dict(zip(box.names, box.low, strict=True))
    hi_g = dict(zip(box.names, box.high, strict=True))
    tmin = c.min_wall
    mc0 = space.min_chamber
    # materials: wall Jm and bottom/wall modulus ratio inside the box
    jms = [_jm(m, equivalent_jm) for m in mats]
    mus = [m.shear_modulus for m in mats]
    walls = [k for k in range(nm) if lo_g["jm"] * (1 - 1e-9) <= jms[k] <= hi_g["jm"] * (1 + 1e-9)]
    im = _nearest_allowed(min(int(u[7] * nm), nm - 1), walls, jms)
    if sym:
        ib = im
    else:
        ratio_lo, ratio_hi = lo_g.get("mu_b/mu", 0.0), hi_g.get("mu_b/mu", math.inf)
        bottoms = [k for k in range(nm)
                   if ratio_lo * (1 - 1e-9) <= mus[k] / mus[im] <= ratio_hi * (1 + 1e-9)]
        ib = _nearest_allowed(min(int(u[8] * nm), nm - 1), bottoms, mus)
    # the cell lengths for which every group interval meets the constraints
    walls_hi = [hi_g["ht/d"], hi_g["ws/d"], hi_g["df/d"]] + ([] if sym else [hi_g["hb/d"]])
    d_lo = max(space.d_range[0], 2 * tmin + mc0, *(tmin / g for g in walls_hi))
    w_max = c.max_width if max_width is None else max_width
    d_hi = min(space.d_range[1], w_max / lo_g["w/d"], c.max_height / lo_g["h/d"])
    if not d_hi >= d_lo:
        return None
    d = d_lo + u[0] * (d_hi - d_lo)
    mc = max(mc0, BOX_MIN_CHAMBER * d) / d          # least chamber, in units of d
    t = tmin / d                                    # least wall, in units of d

    def pick(k: int, name: str, lo: float, hi: float) -> float:
        return _interval(float(u[k]), max(lo_g[name], lo), min(hi_g[name], hi),
                         name not in LINEAR_GROUPS)

    w = pick(1, "w/d", 2 * t + mc, w_max / d)
    ws = pick(5, "ws/d", t, 0.5 * (w - mc))
    h = pick(2, "h/d", 2 * t + mc, c.max_height / d)
    a_t = max(lo_g["ht/d"], t)
    if sym:
        ht = pick(3, "ht/d", t, 0.5 * (h - mc))
        hb = ht
    else:
        a_b = max(lo_g["hb/d"], t)
        room = max(h - mc - a_t - a_b, 0.0)
        ht = pick(3, "ht/d", t, a_t + 0.5 * room)
        hb = pick(4, "hb/d", t, a_b + 0.5 * room)
    df = pick(6, "df/d", t, 0.5 * (1.0 - mc))
    cell = CellGeometry(d, w * d, h * d, ht * d, hb * d, ws * d, df * d, material=mats[im],
                        bottom_material=mats[ib], symmetric=sym)
    return cell, (im, ib)


def cells_for(stage: Stage, per_cell: float, *, max_cells: int, min_cells: int = 1) -> int:
    """Cells in series that give the stage's angle, from the motion of one cell (rad), and
    at least ``min_cells`` (``constraints.min_cells``: the cell models answer a cell inside
    a module; a stretch stage's magnitude does not depend on the count), at most
    ``max_cells`` (what ``max_length`` leaves)."""
    top = max(max_cells, 1)
    if stage.kind == "stretch" or not (per_cell > 0 and math.isfinite(per_cell)):
        return int(min(max(min_cells, 1), top))
    n = round(abs(stage.magnitude) / per_cell)
    return int(min(max(n, min_cells, 1), top))


def build_device(target: TargetSpec, cand: Candidate, n_cells: Sequence[int],
                 name: str | None = None) -> Device:
    """The device of a candidate: stage modules in series, parallel copies at the tip.

    Stages with ``count > 1`` (fingers) sit on branches attached to the end of the last
    serial module; the others follow each other on the main branch in stage order.
    """
    mods: list[Module] = []
    serial = [i for i, other in enumerate(target.stages) if other.count == 1]
    if not serial:
        raise SpecError("a device needs at least one stage with count = 1 (its backbone)")
    for i, stage in enumerate(target.stages):
        kw = dict(name=stage.name, kind=stage.module_kind, cell=cand.cells[i],
                  n_cells=int(n_cells[i]))
        if stage.kind == "bend" and stage.sign < 0:
            kw["orientation"] = math.pi
        if stage.kind == "twist":
            kw["tilt"] = cand.tilts[i] * (1.0 if stage.sign > 0 else -1.0)
            kw["shaft_radius"] = stage.shaft_radius
            kw["strips"] = TWIST_STRIPS
        if stage.count > 1:
            kw.update(count=stage.count, attach_to=target.stages[serial[-1]].name,
                      branch=f"{stage.name}-branch", radius=0.5 * cand.cells[i].width)
        mods.append(Module(**kw))
    placed: list[Module] = []
    cursor = 0.0
    for module in mods:
        if module.attach_to is None:
            module = replace(module, start=cursor)
            cursor = module.end
        placed.append(module)
    return Device(tuple(placed), name=name or target.name, pmax=target.constraints.max_pressure)


def device_length(device: Device) -> float:
    """Backbone length plus the longest parallel branch (m)."""
    main = sum(module.length for module in device.modules if module.attach_to is None)
    branch = max((module.length for module in device.modules if module.attach_to is not None),
                 default=0.0)
    return main + branch
