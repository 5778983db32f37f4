"""One FE run as a command asks for it: the route (a cell or module of cells, a device, one
module of a device), the settings that route implies, the analysis and its comparison with
the reduced model.

:class:`FEJob` picks the route: a tilted strip has no mirror plane (a full model), a device
runs to its design pressure unless told otherwise, one bending or stretching module of a
device runs as a one-module device and one twisting module as its strips around the shaft.
:func:`run_job` runs it and, when asked, a fast cell model beside it (the calibrated one
by default).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from multimorph.device import Device, Module, answered_cell, default_cell_model
from multimorph.device import simulate_device as rom_device
from multimorph.errors import SpecError
from multimorph.fe.analyses._cell import FEResult, simulate_cell
from multimorph.fe.analyses._compare import (
    RomComparison,
    compare_cell_run,
    compare_device,
    compare_twisting,
)
from multimorph.fe.analyses._device import FEDeviceResult, simulate_device
from multimorph.fe.analyses._run import Progress
from multimorph.fe.analyses._twist import FETwistResult, simulate_twisting_module
from multimorph.fe.engine import FESettings, PathCheckpoint
from multimorph.fe.mesh import FE_MODULE_KINDS, fe_device_branches
from multimorph.geometry import CellGeometry, TiltedCell
from multimorph.response import Response

__all__ = ["JOB_KINDS", "FEJob", "FEOutcome", "run_job"]

#: the routes of one FE run
JOB_KINDS = ("cell", "device", "twisting")
#: A cell model, as :mod:`multimorph.models` makes them.
CellModel = Callable[[CellGeometry | TiltedCell, float], Response]


@dataclass(frozen=True, eq=False)
class FEJob:
    """What one FE run inflates, with which settings, to which pressure.

    Build it with :meth:`for_cell`, :meth:`for_device` or :meth:`for_module`.

    Attributes
    ----------
    kind : {"cell", "device", "twisting"}
    settings : FESettings
        As the route needs them (``p_max`` set for a device or module, ``half`` off where
        there is no mirror plane).
    p_end : float
        The highest pressure (Pa).
    geometry : CellGeometry, optional
        A cell run's cell.
    device : Device, optional
        A device run's device.
    module : Module, optional
        A twisting-module run's module.
    n_cells : int
        A cell run's cells in series.
    tilt : float
        A cell run's chamber tilt (rad).
    compare : bool
        Also run the reduced model and compare.
    """

    kind: str
    settings: FESettings
    p_end: float
    geometry: CellGeometry | None = None
    device: Device | None = None
    module: Module | None = None
    n_cells: int = 1
    tilt: float = 0.0
    compare: bool = False

    def __post_init__(self) -> None:
        if self.kind not in JOB_KINDS:
            raise SpecError(f"kind: expected one of {', '.join(JOB_KINDS)}, got {self.kind!r}")

    @classmethod
    def for_cell(cls, geometry: CellGeometry, settings: FESettings, *, n_cells: int = 1,
                 tilt: float = 0.0, compare: bool = False) -> FEJob:
        """A cell, or ``n_cells`` in series; a tilted strip (``tilt`` ≠ 0, rad) is always
        modelled whole (it has no mirror plane)."""
        settings = replace(settings, half=settings.half and not tilt)
        p_end = settings.p_max if settings.p_max is not None else geometry.mu
        return cls("cell", settings, p_end, geometry=geometry, n_cells=n_cells, tilt=tilt,
                   compare=compare)

    @classmethod
    def for_device(cls, device: Device, settings: FESettings, *, compare: bool = False,
                   ) -> FEJob:
        """A device (checked for FE before any work), to ``settings.p_max`` or its design
        pressure."""
        fe_device_branches(device)  # refuse what FE cannot mesh before any work
        p_end = settings.p_max if settings.p_max is not None else device.pmax
        return cls("device", replace(settings, p_max=p_end), p_end, device=device,
                   compare=compare)

    @classmethod
    def for_module(cls, device: Device, name: str, settings: FESettings, *,
                   compare: bool = False) -> FEJob:
        """Module ``name`` of ``device``, clamped at its start: a twisting module as its
        strips around the shaft, a bending or stretching module as one copy of it, a
        one-module device (to ``settings.p_max`` or the device's design pressure)."""
        module = device.module(name)
        if module.kind in FE_MODULE_KINDS:
            one = Device((replace(module, start=0.0, attach_to=None, branch="main", count=1,
                                  radius=0.0),), name=f"{device.name}: {name}",
                         pmax=device.pmax)
            return cls.for_device(one, settings, compare=compare)
        if module.kind != "twisting":
            raise SpecError(f"module {name!r}.kind: {module.kind!r} is not supported by FE "
                            f"(twisting, {', '.join(FE_MODULE_KINDS)})")
        p_end = settings.p_max if settings.p_max is not None else device.pmax
        return cls("twisting", replace(settings, half=False, p_max=p_end), p_end,
                   module=module, compare=compare)


@dataclass(frozen=True, eq=False)
class FEOutcome:
    """A finished FE run: the job, its result and the comparison with the reduced model
    (a ``Comparison`` or ``ShearComparison`` of a cell, the dict of :func:`compare_device`
    or :func:`compare_twisting`; ``None`` when not asked for)."""

    job: FEJob
    result: FEResult | FEDeviceResult | FETwistResult
    comparison: RomComparison | None = None


def run_job(job: FEJob, *, progress: Progress | None = None,
            checkpoint: PathCheckpoint | None = None,
            cell_model: CellModel | None = None) -> FEOutcome:
    """Run an FE job and, with ``job.compare``, a fast cell model beside it (``progress``
    and ``checkpoint`` as for :func:`~multimorph.fe.simulate_cell`).

    ``cell_model(cell, p_max) -> Response`` is the model the comparison runs (default
    :func:`multimorph.device.default_cell_model`, the calibrated model; the CLI's
    ``fem --compare --model``). A tilted strip and a twisting module are compared with what
    the model answers for them in a device (:func:`multimorph.device.simulate_device`):
    a model that answers tilted cells (``model.tilted``: the calibrated and FE models) is
    given the tilted cell and its own strip shear is read; another (the Ritz model) is given
    the straight cell, read by the Ritz twisting kinematics γ = ε sin 2β."""
    model = cell_model or default_cell_model
    if job.kind == "cell":
        assert job.geometry is not None
        cell = simulate_cell(job.geometry, job.settings, progress=progress,
                             n_cells=job.n_cells, tilt=job.tilt, checkpoint=checkpoint)
        if not job.compare:
            return FEOutcome(job, cell)
        answered = answered_cell(model, job.geometry, job.tilt)
        return FEOutcome(job, cell, compare_cell_run(model(answered, job.p_end), cell))
    if job.kind == "device":
        assert job.device is not None
        device = simulate_device(job.device, job.settings, progress=progress,
                                 checkpoint=checkpoint)
        if not job.compare:
            return FEOutcome(job, device)
        # the cell-model device to 2 × p_max (where it is stiffer than FE, it still reaches
        # the FE's activations)
        p_rom = 2.0 * device.stats["p_max"]
        rom = rom_device(job.device, p_rom, cell_model=model)
        return FEOutcome(job, device, compare_device(device, rom, rom_p_max=p_rom))
    assert job.module is not None
    twist = simulate_twisting_module(job.module, job.settings, p_max=job.settings.p_max,
                                     progress=progress, checkpoint=checkpoint)
    if not job.compare:
        return FEOutcome(job, twist)
    p_rom = 2.0 * float(np.max(twist.pressure))
    answered = answered_cell(model, job.module.cell, job.module.tilt)
    return FEOutcome(job, twist, compare_twisting(twist, rom=model(answered, p_rom),
                                                  rom_p_max=p_rom))

