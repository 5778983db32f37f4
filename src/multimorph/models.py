"""The cell models a user can choose, by name: one place for ``--model`` and ``model =``.

* ``"calibrated-fast"`` (default of ``cell``, ``simulate`` and the library): the Ritz model
  corrected against the project's own 3D FE (:mod:`multimorph.calibrated`), its Ritz
  features read from emulators (no Ritz trace, no JAX compile: ~1 ms a curve, a first call
  in a few seconds). Its held-out errors against FE are within a point or two of
  ``"calibrated"``'s (docs/validation.md). Outside its calibrated box it answers with the
  Ritz model and says so (``meta["calibration"]["inside"] = False``, a warning).
* ``"calibrated"`` (default of ``design``, which searches on the fast variant and scores its
  best designs with this one): the same correction with the Ritz features traced exactly
  for each cell (a Ritz trace per cell: ~60 ms a curve, ~45 s to compile on first use).
* ``"ritz"`` (alias ``"rom"``): the reduced (Ritz energy) model of :mod:`multimorph.rom` —
  the physics backbone, about twice as stiff as FE (its Pc ≈ 2 × FE's).
* ``"fe"``: 3D finite elements (:mod:`multimorph.fe`), one cell at a time as inside a long
  module: a straight cell with mirror ends (both end sections stay plane and stretch in
  their planes, :data:`multimorph.fe.CELL_ENDS`), a tilted cell with its end on a rigid
  plate; 2 elements through every wall, edges d/20: minutes per cell, for ``cell`` and
  ``simulate``. (Until stop 31 a straight cell's end was a rigid plate too, as in the
  bending sets of the data set: the same within 0.3 % for cells with a stiff bottom layer,
  up to 35 % stiffer for one-elastomer cells; docs/validation.md.)

Every model is a callable ``model(cell, p_max) -> Response`` (a
:class:`~multimorph.geometry.TiltedCell` too, for twisting modules), and
:func:`batch_model` gives ``fn(cells, p_max) -> list[Response | Exception]``. Each
Response says which model made it (``meta["model"]``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from multimorph.errors import SpecError
from multimorph.geometry import CellGeometry, TiltedCell
from multimorph.response import Response

__all__ = ["DEFAULT_MODEL", "DESIGN_MODEL", "MODEL_ALIASES", "MODEL_NAMES", "batch_model",
           "cell_model", "model_name"]

MODEL_NAMES = ("calibrated", "calibrated-fast", "ritz", "fe")
MODEL_ALIASES = {"rom": "ritz"}
#: The default cell model (``cell``, ``simulate``, ``sweep --model`` omitted: the spec's).
DEFAULT_MODEL = "calibrated-fast"
#: The default model of ``design`` (search on ``calibrated-fast``, score with this one).
DESIGN_MODEL = "calibrated"
CellModel = Callable[[CellGeometry | TiltedCell, float], Response]


def model_name(name: str | None, *, allowed: Sequence[str] = MODEL_NAMES,
               field: str = "model") -> str:
    """The canonical model name (``None`` → the default), or a SpecError naming ``field``."""
    if name is None:
        return DEFAULT_MODEL
    if not isinstance(name, str):
        raise SpecError(f"{field}: expected one of {', '.join(allowed)}, got {name!r}")
    key = MODEL_ALIASES.get(name.strip().lower(), name.strip().lower())
    if key not in allowed:
        raise SpecError(f"{field}: unknown model {name!r}; expected one of "
                        f"{', '.join(allowed)}")
    return key


def _calibrated(cell: CellGeometry | TiltedCell, p_max: float) -> Response:
    from multimorph.calibrated import load_model

    return load_model().response(cell, p_max)


def _calibrated_fast(cell: CellGeometry | TiltedCell, p_max: float) -> Response:
    from multimorph.calibrated import load_model

    r = load_model().responses([cell], p_max, fast=True)[0]
    if isinstance(r, Exception):
        raise r
    return r


def _ritz(cell: CellGeometry | TiltedCell, p_max: float) -> Response:
    from multimorph.rom import solve_cell

    straight = cell.cell if isinstance(cell, TiltedCell) else cell
    r = solve_cell(straight, p_max)
    return r.with_meta(model="ritz")


def _fe(cell: CellGeometry | TiltedCell, p_max: float, **settings: Any) -> Response:
    from dataclasses import replace

    from multimorph.fe import FESettings, MeshDensity, simulate_cell

    s = FESettings(mesh=MeshDensity(wall_elements=2, length_fraction=0.05), p_max=p_max,
                   max_volume_ratio=60.0)
    if settings:
        s = replace(s, **settings)
    if isinstance(cell, TiltedCell):
        res = simulate_cell(cell.cell, replace(s, half=False), tilt=cell.tilt, end="plate")
    else:
        res = simulate_cell(cell, s, end="mirror" if s.half else "plate")
    return res.response.with_meta(model="fe")


def cell_model(name: str | None = None, **fe_settings: Any) -> CellModel:
    """The single-cell model called ``name`` (see the module docstring)."""
    key = model_name(name)
    if key in ("calibrated", "calibrated-fast"):
        fn: Any = _calibrated if key == "calibrated" else _calibrated_fast
        fn.tilted = True
        return fn
    if key == "ritz":
        return _ritz

    def fe(cell: CellGeometry | TiltedCell, p_max: float) -> Response:
        return _fe(cell, p_max, **fe_settings)

    fe.tilted = True  # type: ignore[attr-defined]
    return fe


def batch_model(name: str | None = None, *, fallback: bool = True,
                ) -> Callable[[Sequence[Any], float], list[Any]]:
    """``fn(cells, p_max) -> list[Response | Exception]`` of the model ``name``.

    ``fallback=False`` (calibrated model): a cell outside the calibrated support gets an
    exception (:class:`~multimorph.errors.OutsideSupportError`) instead of the Ritz model's
    answer, so a search (the designer) stays where
    the calibrated model holds rather than mixing two models in one objective.
    """
    key = model_name(name)
    if key in ("calibrated", "calibrated-fast"):
        fast = key == "calibrated-fast"

        def calibrated(cells: Sequence[Any], p_max: float) -> list[Any]:
            from multimorph.calibrated import load_model

            return load_model().responses(list(cells), p_max, fallback=fallback, fast=fast)

        def support_boxes() -> dict[str, Any]:
            """The calibrated box of each cell kind (the designer searches inside them)."""
            from multimorph.calibrated import load_model

            m = load_model()
            out: dict[str, Any] = {kind: k.box
                                   for kind, k in (m.fast_kinds if fast else m.kinds).items()}
            shear = m.twisting_shear or {}
            tw = out.get("twisting")
            if tw is not None and "tilt" in tw.names:   # the tilted cells' own calibration
                j = tw.names.index("tilt")
                out["tilt"] = (float(tw.low[j]), float(tw.high[j]))
            elif "tilt_range" in shear:   # tilts the strip shear factor was fitted on
                out["tilt"] = tuple(float(t) for t in shear["tilt_range"])
            return out

        calibrated.batched = True  # type: ignore[attr-defined]
        calibrated.tilted = True  # type: ignore[attr-defined]  # answers the strip shear
        calibrated.fixed_shape = False  # type: ignore[attr-defined]  # nothing to compile
        calibrated.support_boxes = support_boxes  # type: ignore[attr-defined]
        return calibrated
    if key == "ritz":
        from multimorph.rom import simulate_cells

        def ritz(cells: Sequence[Any], p_max: float) -> list[Any]:
            straight = [c.cell if isinstance(c, TiltedCell) else c for c in cells]
            return [r if isinstance(r, Exception) else r.with_meta(model="ritz")
                    for r in simulate_cells(straight, p_max)]

        ritz.batched = True  # type: ignore[attr-defined]
        return ritz
    single = cell_model(key)

    def loop(cells: Sequence[Any], p_max: float) -> list[Any]:
        out: list[Any] = []
        for c in cells:
            try:
                out.append(single(c, p_max))
            except Exception as exc:  # kept per design
                out.append(exc)
        return out

    return loop
