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
from multimorph.geometry import CellGeometry
from multimorph.response import Response

__all__ = ["ROM_BATCH_NAMES", "BatchModel", "CountingModel", "batched", "rom_batch_model"]

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
            except MultimorphError as exc:
                out.append(exc)
        return out

    fn.batched = False  # type: ignore[attr-defined]
    return fn


def rom_batch_model() -> BatchModel:
    """The reduced cell model of :mod:`multimorph.rom` as a batch model.

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
    for name in ROM_BATCH_NAMES:
        fn = getattr(rom, name, None)
        if callable(fn):

            def call(cells: Sequence[CellGeometry], p_max: float, _fn: Any = fn) -> list[Any]:
                return list(_fn(list(cells), p_max))

            call.batched = True  # type: ignore[attr-defined]
            return call
    single = getattr(rom, "simulate_cell", None)
    if callable(single):
        return batched(single)
    raise MultimorphError("multimorph.rom has no simulate_cell or batched entry point "
                          f"({', '.join(ROM_BATCH_NAMES)}) yet (issue 3); the designer "
                          "needs the reduced cell model")


class CountingModel:
    """Wraps a batch model: counts cell evaluations, pads batches for jitted models.

    Parameters
    ----------
    model : BatchModel
    pad_to : int, optional
        For a batched (jitted) model, pad every call to a multiple of this many cells so
        the model compiles once; padding is dropped and not counted.
    """

    def __init__(self, model: BatchModel, pad_to: int | None = None) -> None:
        self.model = model
        self.pad_to = pad_to if getattr(model, "batched", False) else None
        self.evaluations = 0
        self.calls = 0

    def __call__(self, cells: Sequence[CellGeometry], p_max: float) -> list[Any]:
        cells = list(cells)
        n = len(cells)
        if n == 0:
            return []
        padded = cells
        if self.pad_to and n % self.pad_to:
            padded = cells + [cells[-1]] * (self.pad_to - n % self.pad_to)
        try:
            out = list(self.model(padded, p_max))[:n]
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
