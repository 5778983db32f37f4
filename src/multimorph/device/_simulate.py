"""Simulate a device: one cell response per distinct cell, module strains, shapes, sequence.

The cell backend is one interface, ``cell_model(cell, p_max) -> Response``: the default
model of :mod:`multimorph.models` (``DEFAULT_MODEL``) unless one is given; the calibrated,
Ritz and FE models fit the same slot. A model with ``tilted = True`` is given a twisting
module's cell as a :class:`~multimorph.geometry.TiltedCell` and answers its strip shear
(``path.extra["shear"]``); others get the straight cell and the module applies the Ritz rule
γ = ε sin 2β.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from multimorph.device._device import Device
from multimorph.device._modules import ModuleStrains, module_strains
from multimorph.device._sequence import ModuleCurve, SequenceReport, analyse_sequence
from multimorph.device._shape import DeviceShape, device_shape
from multimorph.geometry import CellGeometry, TiltedCell
from multimorph.response import Response

__all__ = ["DeviceResult", "answered_cell", "default_cell_model", "simulate_device"]

CellModel = Callable[[CellGeometry, float], Response]


def default_cell_model(cell: CellGeometry | TiltedCell, p_max: float) -> Response:
    """The default cell model, :data:`multimorph.models.DEFAULT_MODEL`: the calibrated model
    on emulated Ritz features, "calibrated-fast" (imported from :mod:`multimorph.calibrated`
    itself, not through :mod:`multimorph.models`, whose FE model depends on this package)."""
    from multimorph.calibrated import load_model

    r = load_model().responses([cell], p_max, fast=True)[0]
    if isinstance(r, Exception):
        raise r
    return r


default_cell_model.tilted = True  # type: ignore[attr-defined]


def answered_cell(model: Any, cell: CellGeometry, tilt: float = 0.0,
                  ) -> CellGeometry | TiltedCell:
    """The cell ``model`` is asked for: the tilted cell where there is a tilt and the
    model answers tilted cells (``model.tilted``: its own strip shear), else the straight
    cell (whose strip shear the module's Ritz rule gives). The device and the FE
    comparisons (``fe.run_job``) ask alike."""
    return TiltedCell(cell, tilt) if tilt and getattr(model, "tilted", False) else cell


def _model_of(response: Response) -> str:
    """Which cell model made a response (``meta["model"]``, else its backend)."""
    name = str(response.meta.get("model", response.backend))
    return "ritz" if name == "rom" else name


@dataclass(frozen=True, eq=False)
class DeviceResult:
    """Everything :func:`simulate_device` predicts for a device (SI units)."""

    device: Device
    pmax: float
    strains: dict[str, ModuleStrains]
    sequence: SequenceReport

    def module_state(self, name: str, pressure: float) -> dict[str, float]:
        return self.strains[name].at(pressure)

    def shape(self, pressure: float, points_per_cell: int = 4) -> dict[str, np.ndarray]:
        """Centre lines (n, 3) (m) of every module copy at ``pressure`` (Pa).

        Keys are ``"<module>"`` or ``"<module>#<copy>"`` for parallel copies. The base of the
        device is at the origin with its axis along +y; a bending module with zero orientation
        bends toward −z.
        """
        return self.bodies(pressure, points_per_cell).lines()

    def bodies(self, pressure: float, points_per_cell: int = 4) -> DeviceShape:
        """The module copies at ``pressure`` (Pa) as bodies with rod frames, and the hubs
        (:class:`~multimorph.device.DeviceShape`): what the 3D pictures draw."""
        states = {name: self.module_state(name, pressure) for name in self.strains}
        return device_shape(self.device, states, pressure, points_per_cell)

    def notes(self, samples: int = 24) -> list[str]:
        """What the rod model does not handle along the traced path, each with the lowest
        pressure it appears at (of ``samples`` pressures up to pmax): a module coiling past
        360°, parts overlapping. Self-contact is not modelled: the shapes beyond are not
        physical."""
        first: dict[str, float] = {}
        for p in np.linspace(self.pmax / samples, self.pmax, samples):
            for note in self.bodies(float(p)).notes():
                key = note.split(" (")[0]
                first.setdefault(key, float(p))
        return [f"{key} from {p / 1e3:.3g} kPa; self-contact is not modelled"
                for key, p in first.items()]

    def activation_notes(self) -> list[str]:
        """The modules a cell model says do not activate at all, and why (a stretching
        or twisting module of a strongly hardening Yeoh wall:
        ``calibrated._law.wall_activates``)."""
        out = []
        for name, strain in self.strains.items():
            act = ((strain.response.meta or {}).get("calibration") or {}).get("activation")
            if act and act.get("activates") is False:
                out.append(f"{name}: no activation — {act.get('reason', '')}")
        return out

    def twist_notes(self) -> list[str]:
        """What a twisting module's angle is worth (stop 61): the strip rule τ = γ / R
        turns its tilted cells' strip shear into twist, and the whole module inflated on
        its shaft in 3D FE twists a third to a sixth of that at the same pressures (the
        gripper's twister, the three-stage turn; docs/design.md, FE verification)."""
        return [f"{name}: its twist is the strip rule's (τ = γ / R on its cells' strip "
                "shear); the whole module on its shaft in 3D FE twists a third to a sixth "
                "of it at the same pressures (docs/design.md)"
                for name, strain in self.strains.items() if strain.module.kind == "twisting"]

    def to_dict(self) -> dict[str, Any]:
        models = sorted({_model_of(s.response) for s in self.strains.values()})
        out: dict[str, Any] = {"device": self.device.name, "pmax": self.pmax,
                               "model": models[0] if len(models) == 1 else models,
                               "modules": {}, "sequence": self.sequence.to_dict(),
                               "notes": (self.notes() + self.activation_notes()
                                         + self.twist_notes())}
        for name, strain in self.strains.items():
            ch = strain.response.characteristic
            module = strain.module
            meta = strain.response.meta
            out["modules"][name] = {
                "kind": module.kind, "mode": module.mode, "cells": module.n_cells,
                "count": module.count, "length": module.length,
                "shear_modulus": strain.response.shear_modulus,
                "model": _model_of(strain.response),
                **({"calibration": meta["calibration"]} if "calibration" in meta else {}),
                **ch.to_dict(),
                "pressure": strain.pressure, "bend": strain.bend, "twist": strain.twist,
                "stretch": strain.stretch, "measure": strain.measure,
            }
        return out


def simulate_device(device: Device, p_max: float | None = None, *,
                    cell_model: CellModel | None = None,
                    progress: Callable[[int, int], None] | None = None) -> DeviceResult:
    """Trace every module's response to ``p_max`` (Pa; default the device's design pressure).

    Each distinct cell is traced once (modules sharing a cell share the response).
    ``progress(done, total)`` is called with the number of modules done (before the first
    and after each).
    """
    p_max = float(device.pmax if p_max is None else p_max)
    model = cell_model or default_cell_model
    cache: dict[int, Response] = {}
    keys: dict[int, CellGeometry | TiltedCell] = {}
    strains: dict[str, ModuleStrains] = {}
    if progress is not None:
        progress(0, len(device.modules))
    for done, module in enumerate(device.modules, start=1):
        cell = answered_cell(model, module.cell,
                             module.tilt if module.kind == "twisting" else 0.0)
        key = next((k for k, c in keys.items() if c == cell), None)
        if key is None:
            key = len(keys)
            keys[key] = cell
            cache[key] = model(cell, p_max)
        strains[module.name] = module_strains(module, cache[key])
        if progress is not None:
            progress(done, len(device.modules))
    curves = [
        ModuleCurve(name=n, mode=strain.module.mode, pressure=strain.pressure,
                    measure=strain.measure,
                    critical=strain.response.characteristic.critical,
                    hardening=strain.response.characteristic.hardening,
                    failure=strain.response.characteristic.failure,
                    unloading_pressure=strain.unloading_pressure,
                    unloading_measure=strain.unloading_measure)
        for n, strain in strains.items()
    ]
    return DeviceResult(device=device, pmax=p_max, strains=strains,
                        sequence=analyse_sequence(curves))


