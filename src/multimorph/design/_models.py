"""The cell model behind the designer: one batched interface, with an evaluation counter.

A *batch model* is ``fn(cells, p_max) -> list[Response | Exception]`` (one entry per cell,
an exception instance for a design the model could not trace). :func:`rom_batch_model` is
the reduced model of :mod:`multimorph.rom` (its batched, vmapped entry point when it has one,
else ``simulate_cell`` in a loop); :func:`batched` wraps any single-design
``cell_model(cell, p_max) -> Response`` (the interface of
:func:`multimorph.device.simulate_device`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from multimorph.errors import MultimorphError
from multimorph.geometry import CellGeometry, TiltedCell
from multimorph.outcome import Outcome
from multimorph.response import Response

__all__ = ["ROM_BATCH_NAMES", "BatchModel", "CountingModel", "batched", "rom_batch_model",
           "single_cell"]

BatchModel = Callable[[Sequence[CellGeometry], float], list[Any]]
CellModel = Callable[[CellGeometry, float], Response]

#: Names tried, in order, for the reduced model's batched entry point.
ROM_BATCH_NAMES = ("simulate_batch", "simulate_cells", "evaluate_batch")


def batched(cell_model: CellModel) -> BatchModel:
    """A batch model that calls a single-design ``cell_model`` per cell (errors kept)."""

    def fn(cells: Sequence[CellGeometry], p_max: float) -> list[Any]:
        out: list[Any] = []
        for c in cells:
            try:
                out.append(cell_model(c, p_max))
            except Exception as exc:  # kept: the design is scored as failed, with the message
                out.append(exc)
        return out

    fn.batched = False  # type: ignore[attr-defined]
    return fn


def _rom_fast(rom: Any, vectorise: bool | None = None) -> BatchModel | None:
    """Batched ROM with the path measures of the whole batch in one padded call.

    ``rom.solve_batch`` traces all designs at once; the per-point measures (volume, peak
    stretch) are then evaluated for the whole padded (designs × points) array in one jitted,
    doubly vmapped call — compiled once per batch shape, instead of once per distinct path
    length as when building each :class:`Response` separately. ``None`` when the ROM lacks
    the pieces (then its list-in/list-out entry point is used).
    """
    need = ("solve_batch", "cell_kernel", "RomOptions", "CellBatch")
    if not all(hasattr(rom, n) for n in need):
        return None
    import jax
    import jax.numpy as jnp
    import numpy as np

    from multimorph.response import EquilibriumPath, build_response

    compiled: dict[tuple[str, str, Any], Any] = {}

    def measures_fn(wall: str, bottom: str, options: Any) -> Any:
        key = (wall, bottom, options)
        if key not in compiled:
            kernel = rom.cell_kernel(wall, bottom, options)
            inner = jax.vmap(kernel.measures, in_axes=(0, 0, None))
            compiled[key] = jax.jit(jax.vmap(inner, in_axes=(0, 0, 0)))
        return compiled[key]

    def call(cells: Sequence[CellGeometry], p_max: float) -> list[Any]:
        groups: dict[tuple[str, str, bool], list[int]] = {}
        for i, c in enumerate(cells):
            assert c.bottom_material is not None
            groups.setdefault((c.material.model, c.bottom_material.model, c.symmetric),
                              []).append(i)
        out: list[Any] = [MultimorphError("not evaluated")] * len(cells)
        for (wall, bottom, _), idx in groups.items():
            try:
                batch = rom.CellBatch.from_cells([cells[i] for i in idx])
                rb = rom.solve_batch(batch, p_max, vectorise=vectorise)
                opts = rb.options
                free = list(opts.free)
                theta = batch.theta()
                p = rb.pressure / batch.mu[:, None]
                meas = measures_fn(wall, bottom, opts)(jnp.asarray(rb.q[:, :, free]),
                                                       jnp.asarray(p), theta)
                meas = {k: np.asarray(v) for k, v in meas.items()}
            except Exception as exc:  # a whole group cannot be set up
                for i in idx:
                    out[i] = exc
                continue
            r = batch.ratios
            for j, i in enumerate(idx):
                if int(rb.status[j]) != Outcome.COMPLETED.code:
                    out[i] = MultimorphError(f"cell ROM: {rb.message(j)}")
                    continue
                n_points = int(rb.count[j])
                d = float(batch.length[j])
                v0 = ((r["w"][j] - 2 * r["ws"][j]) * (r["h"][j] - r["ht"][j] - r["hb"][j])
                      * (1 - 2 * r["df"][j]) * d**3)
                try:
                    path = EquilibriumPath(
                        pressure=rb.pressure[j, :n_points], curvature=rb.curvature[j, :n_points],
                        twist_rate=np.zeros(n_points), axial_stretch=1.0 + rb.q[j, :n_points, 3],
                        volume=v0 + meas["volume"][j, :n_points] * d**3,
                        peak_stretch=meas["peak_stretch"][j, :n_points],
                        stable=rb.stable[j, :n_points],
                        extra={"q": rb.q[j, :n_points], "lockup": meas["lockup"][j, :n_points]})
                    bs = cells[i].material.break_stretch
                    out[i] = build_response(path, length=d, shear_modulus=float(batch.mu[j]),
                                            backend="rom", break_stretch=bs,
                                            signal=cells[i].signal,
                                            meta={"model": "cell-ritz", "points": n_points})
                except MultimorphError as exc:
                    out[i] = exc
        return out

    call.batched = True  # type: ignore[attr-defined]
    return call


def rom_batch_model(vectorised: bool = False) -> BatchModel:
    """The reduced cell model of :mod:`multimorph.rom` as a batch model.

    Parameters
    ----------
    vectorised : bool
        ``True``: one vmapped, jitted trace per batch (``rom.solve_batch(vectorise=True)``,
        measures in one padded call). ``False`` (default): single-design traces in a loop.
        On a CPU a derivative evaluation costs as much per design inside a vmapped batch
        as alone, so the loop is as fast or faster (``benchmarks/README.md``); vectorise on
        a GPU. Both give the same
        responses. The loop traces each
        design as a batch of one with its path measures padded to the full path length, so
        it compiles once (``rom.solve_cell`` evaluates the measures on the path's own
        length, which recompiles for every new number of path points).

    Raises
    ------
    MultimorphError
        When the reduced model (issue 3) is not importable or has no entry point yet.
    """
    try:
        from multimorph import rom
    except ImportError as exc:  # pragma: no cover - depends on the ROM's state
        raise MultimorphError(f"the reduced cell model multimorph.rom cannot be imported "
                              f"({exc}); the designer needs it (issue 3)") from None
    fast = _rom_fast(rom, vectorise=True if vectorised else None)
    if fast is not None and not vectorised:
        # one design per traced batch: a single compiled shape (1 design, padded path)
        return batched(lambda cell, p_max: _raise(fast([cell], p_max)[0]))
    if vectorised:
        if fast is not None:
            return fast
        for name in ROM_BATCH_NAMES:
            fn = getattr(rom, name, None)
            if callable(fn):

                def call(cells: Sequence[CellGeometry], p_max: float, _fn: Any = fn,
                         ) -> list[Any]:
                    return list(_fn(list(cells), p_max))

                call.batched = True  # type: ignore[attr-defined]
                return call
    for name in ("solve_cell", "simulate_cell"):
        single = getattr(rom, name, None)
        if callable(single):
            return batched(single)
    raise MultimorphError("multimorph.rom has no solve_cell/simulate_cell or batched entry "
                          f"point ({', '.join(ROM_BATCH_NAMES)}) yet (issue 3); the designer "
                          "needs the reduced cell model")


class CountingModel:
    """Wraps a batch model: counts cell evaluations, pads batches for jitted models.

    Parameters
    ----------
    model : BatchModel
    pad_to : int, optional
        For a batched (jitted) model, call it on chunks of exactly this many cells (the
        last one padded) so the model compiles once; padding is dropped and not counted.
    """

    def __init__(self, model: BatchModel, pad_to: int | None = None) -> None:
        self.model = model
        # padding helps a jitted model (one compiled shape); a model without compilation
        # (the calibrated one says ``fixed_shape = False``) would only evaluate the padding
        self.pad_to = (pad_to if getattr(model, "batched", False)
                       and getattr(model, "fixed_shape", True) else None)
        self.evaluations = 0
        self.calls = 0

    def support_boxes(self) -> dict[str, Any] | None:
        """The wrapped model's calibrated boxes per cell kind (``None``: no bounded support)."""
        fn = getattr(self.model, "support_boxes", None)
        return fn() if callable(fn) else None

    @property
    def tilted(self) -> bool:
        """Whether the wrapped model answers tilted cells (``tilted = True`` on it)."""
        return bool(getattr(self.model, "tilted", False))

    def __call__(self, cells: Sequence[CellGeometry | TiltedCell], p_max: float) -> list[Any]:
        # a model that does not know tilted cells gets the straight cell (its module then
        # takes the strip shear by the Ritz rule)
        cells = [c if self.tilted or not isinstance(c, TiltedCell) else c.cell for c in cells]
        n = len(cells)
        if n == 0:
            return []
        try:
            if self.pad_to:
                # fixed-size chunks: one batch shape, one compilation for every call
                k = self.pad_to
                padded = cells + [cells[-1]] * ((-n) % k)
                out = []
                for a in range(0, len(padded), k):
                    out.extend(list(self.model(padded[a:a + k], p_max)))
                out = out[:n]
            else:
                out = list(self.model(cells, p_max))
        except MultimorphError:
            if n == 1:
                raise
            out = []
            for c in cells:  # one bad design must not sink the batch
                try:
                    out.extend(list(self.model([c], p_max)))
                except MultimorphError as exc:
                    out.append(exc)
        self.evaluations += n
        self.calls += 1
        return out


def _raise(r: Any) -> Any:
    if isinstance(r, BaseException):
        raise r
    return r


def single_cell(model: BatchModel) -> CellModel:
    """A single-design ``cell_model(cell, p_max)`` from a batch model (errors raised)."""

    def fn(cell: CellGeometry, p_max: float) -> Response:
        r = model([cell], p_max)[0]
        if isinstance(r, BaseException):
            raise r
        return r

    # a device simulation gives a twisting module's tilted cell to a model that knows them
    fn.tilted = bool(getattr(model, "tilted", False))  # type: ignore[attr-defined]
    return fn
