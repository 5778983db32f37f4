"""Simulate a device: one cell response per distinct cell, module strains, shapes, sequence.

The cell backend is one interface, ``cell_model(cell, p_max) -> Response``: the reduced
model by default (:func:`multimorph.rom.solve_cell`); the FE backend fits the same slot.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from multimorph.device._device import Device
from multimorph.device._kinematics import RodStrains, centerline, segment_transform
from multimorph.device._modules import ModuleStrains, module_strains
from multimorph.device._sequence import ModuleCurve, SequenceReport, analyse_sequence
from multimorph.geometry import CellGeometry
from multimorph.response import Response

__all__ = ["DeviceResult", "default_cell_model", "simulate_device"]

CellModel = Callable[[CellGeometry, float], Response]


def default_cell_model(cell: CellGeometry, p_max: float) -> Response:
    """The reduced-order cell model (:func:`multimorph.rom.solve_cell`)."""
    from multimorph.rom import solve_cell

    return solve_cell(cell, p_max)


def _rot_y(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    T = np.eye(4)
    T[:3, :3] = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
    return T


def _shift(v: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = v
    return T


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
        dev = self.device
        branches = dev.branches()
        end_frame: dict[str, np.ndarray] = {}
        lines: dict[str, np.ndarray] = {}

        def seg(mod_name: str) -> RodStrains:
            st = self.module_state(mod_name, pressure)
            m = dev.module(mod_name)
            return RodStrains.bend_twist(m.length, bend=st["bend"], twist=st["twist"],
                                         stretch=st["stretch"])

        pending = list(branches)
        guard = 0
        while pending:
            guard += 1
            if guard > 10_000:  # Device validation rules out cycles
                raise RuntimeError("branch ordering did not converge")
            b = pending.pop(0)
            mods = branches[b]
            parent = next((m.attach_to for m in mods if m.attach_to), None)
            if parent is not None and parent not in end_frame:
                pending.append(b)
                continue
            base = np.eye(4) if parent is None else end_frame[parent]
            count = mods[0].count
            for j in range(count):
                T = base @ _rot_y(2.0 * math.pi * j / count)
                T = T @ _shift(np.array([0.0, 0.0, mods[0].radius]))
                for m in mods:
                    T_start = T @ _shift(np.array([0.0, 0.0, 0.0]))
                    Tm = T_start @ _rot_y(m.orientation)
                    s = seg(m.name)
                    n = max(2, points_per_cell * m.n_cells)
                    pts = centerline([s], points_per_segment=n, base=Tm)
                    key = m.name if m.count == 1 else f"{m.name}#{j}"
                    lines[key] = pts
                    T = Tm @ segment_transform(s) @ _rot_y(-m.orientation)
                    if j == 0:
                        end_frame[m.name] = T
        return lines

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"device": self.device.name, "pmax": self.pmax,
                               "modules": {}, "sequence": self.sequence.to_dict()}
        for name, s in self.strains.items():
            ch = s.response.characteristic
            m = s.module
            out["modules"][name] = {
                "kind": m.kind, "mode": m.mode, "cells": m.n_cells, "count": m.count,
                "length": m.length, "shear_modulus": s.response.shear_modulus,
                **ch.to_dict(),
                "pressure": s.pressure, "bend": s.bend, "twist": s.twist,
                "stretch": s.stretch, "measure": s.measure,
            }
        return out


def simulate_device(device: Device, p_max: float | None = None, *,
                    cell_model: CellModel | None = None) -> DeviceResult:
    """Trace every module's response to ``p_max`` (default the device's design pressure).

    Each distinct cell is traced once (modules sharing a cell share the response).
    """
    p_max = float(device.pmax if p_max is None else p_max)
    model = cell_model or default_cell_model
    cache: dict[int, Response] = {}
    keys: dict[int, CellGeometry] = {}
    strains: dict[str, ModuleStrains] = {}
    for m in device.modules:
        cell = m.cell
        key = next((k for k, c in keys.items() if c == cell), None)
        if key is None:
            key = len(keys)
            keys[key] = cell
            cache[key] = model(cell, p_max)
        strains[m.name] = module_strains(m, cache[key])
    curves = [
        ModuleCurve(name=n, mode=s.module.mode, pressure=s.pressure, measure=s.measure,
                    critical=s.response.characteristic.critical,
                    hardening=s.response.characteristic.hardening,
                    failure=s.response.characteristic.failure,
                    unloading_pressure=s.unloading_pressure,
                    unloading_measure=s.unloading_measure)
        for n, s in strains.items()
    ]
    return DeviceResult(device=device, pmax=p_max, strains=strains,
                        sequence=analyse_sequence(curves))


