"""The deformed device as bodies: rod frames per module copy, hubs, and what the rod model
cannot see (coils past a full turn, parts running into each other).

Each module copy is a :class:`Body`: the rod frames along its centre line (from
:func:`~multimorph.device._kinematics.frames_along`), so a drawing can sweep the cell's
cross-section along it and show bend and twist. Copies spaced around a parent (fingers) hang
from a :class:`Hub` at the parent's end (or at the base). The device's base is at the
origin with its axis along +y; lengths in m.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from multimorph.device._device import Device
from multimorph.device._kinematics import RodStrains, frames_along, segment_transform
from multimorph.device._modules import Module

__all__ = ["Body", "DeviceShape", "Hub", "device_shape"]


@dataclass(frozen=True, eq=False)
class Body:
    """One module copy at one pressure.

    Parameters
    ----------
    key : str
        ``"<module>"``, or ``"<module>#<copy>"`` for parallel copies.
    module : Module
    frames : ndarray, shape (n, 4, 4)
        Rod frames along the centre line (m), ``points_per_cell`` steps per cell.
    parent : int or None
        Index of the body it starts from (None: the device's base).
    bend_angle : float
        Total bend angle |κ| L of the module (rad).
    """

    key: str
    module: Module
    frames: np.ndarray
    parent: int | None
    bend_angle: float

    @property
    def points(self) -> np.ndarray:
        """Centre-line points (n, 3) (m)."""
        return self.frames[:, :3, 3]

    @property
    def thickness(self) -> float:
        """Size of the body across its axis (m): the cell height; a twisting module's strips
        around its shaft: their outer diameter."""
        cell = self.module.cell
        if self.module.kind == "twisting":
            return 2.0 * (self.module.shaft_radius + cell.height)
        return cell.height


@dataclass(frozen=True, eq=False)
class Hub:
    """A rigid disc that parallel copies (fingers) hang from: centre and axis (the frame's
    y axis) in ``frame`` (4×4, m), radius (m)."""

    frame: np.ndarray
    radius: float


@dataclass(frozen=True, eq=False)
class DeviceShape:
    """The device at ``pressure`` (Pa): its bodies and hubs."""

    pressure: float
    bodies: tuple[Body, ...]
    hubs: tuple[Hub, ...]

    def lines(self) -> dict[str, np.ndarray]:
        """Centre lines (n, 3) (m) by body key."""
        return {body.key: body.points for body in self.bodies}

    def notes(self) -> list[str]:
        """What the rod model does not handle at this pressure: a module coiling past a full
        turn, parts closer than their thickness (self-contact is not modelled)."""
        coiled = {body.module.name: body.bend_angle for body in self.bodies
                  if body.bend_angle > 2.0 * math.pi}
        out = [f"module {name!r} coils past 360° (bend {math.degrees(angle):.0f}°)"
               for name, angle in coiled.items()]
        module = {body.key: body.module.name for body in self.bodies}
        for a, b in self.overlaps():
            if a == b:
                text = f"{a!r} overlaps itself (closer than its thickness)"
            elif module[a] == module[b]:
                text = f"copies of {module[a]!r} overlap each other (closer than their thickness)"
            else:
                text = f"{a!r} and {b!r} overlap (closer than their thickness)"
            if text not in out:
                out.append(text)
        return out

    def overlaps(self) -> list[tuple[str, str]]:
        """Pairs of bodies with centre-line points closer than their mean thickness, the
        points more than two thicknesses apart along the device (not neighbours)."""
        s_start, points, arcs, owner = _arc_lengths(self.bodies)
        pairs: set[tuple[int, int]] = set()
        gap = np.linalg.norm(points[:, None, :] - points[None, :, :], axis=-1)
        thick = np.array([self.bodies[i].thickness for i in owner])
        size = 0.5 * (thick[:, None] + thick[None, :])
        for i, j in zip(*np.nonzero(np.triu(gap < size, k=1)), strict=True):
            a, b = int(owner[i]), int(owner[j])
            if (a, b) in pairs:
                continue
            along = _separation(self.bodies, s_start, a, float(arcs[i]), b, float(arcs[j]))
            if along > 2.0 * size[i, j]:
                pairs.add((a, b))
        return [(self.bodies[a].key, self.bodies[b].key) for a, b in sorted(pairs)]


def _arc_lengths(bodies: tuple[Body, ...]) -> tuple[list[float], np.ndarray, np.ndarray,
                                                     np.ndarray]:
    """Arc length (m) from the base to every body's start; all points, their arc length
    within their body and the index of their body."""
    s_start: list[float] = []
    points, arcs, owner = [], [], []
    for k, body in enumerate(bodies):
        steps = np.linalg.norm(np.diff(body.points, axis=0), axis=1)
        s = np.concatenate([[0.0], np.cumsum(steps)])
        parent = body.parent
        s_start.append(0.0 if parent is None else
                       s_start[parent] + _length(bodies[parent]))
        points.append(body.points)
        arcs.append(s)
        owner.append(np.full(len(s), k))
    return s_start, np.concatenate(points), np.concatenate(arcs), np.concatenate(owner)


def _length(body: Body) -> float:
    return float(np.sum(np.linalg.norm(np.diff(body.points, axis=0), axis=1)))


def _lineage(bodies: tuple[Body, ...], k: int) -> list[int]:
    out = [k]
    while bodies[out[-1]].parent is not None:
        out.append(bodies[out[-1]].parent)  # type: ignore[arg-type]
    return out[::-1]


def _separation(bodies: tuple[Body, ...], s_start: list[float], a: int, sa: float, b: int,
                sb: float) -> float:
    """Distance (m) along the device between a point of body ``a`` (arc ``sa`` in it) and one
    of body ``b``: along the rod where one is the other's ancestor, else down to where
    their branches part and across the hub between their starts."""
    la, lb = _lineage(bodies, a), _lineage(bodies, b)
    common = 0
    while common < min(len(la), len(lb)) and la[common] == lb[common]:
        common += 1
    abs_a, abs_b = s_start[a] + sa, s_start[b] + sb
    if common in (len(la), len(lb)):  # one body is on the other's way to the base
        return abs(abs_b - abs_a)
    x, y = la[common], lb[common]  # the first bodies of the two branches
    across = float(np.linalg.norm(bodies[x].points[0] - bodies[y].points[0]))
    return (abs_a - s_start[x]) + (abs_b - s_start[y]) + across


def _rot_y(angle: float) -> np.ndarray:
    cos_a, sin_a = math.cos(angle), math.sin(angle)
    T = np.eye(4)
    T[:3, :3] = [[cos_a, 0.0, sin_a], [0.0, 1.0, 0.0], [-sin_a, 0.0, cos_a]]
    return T


def _shift(v: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = v
    return T


def device_shape(device: Device, states: Mapping[str, Mapping[str, float]], pressure: float,
                 points_per_cell: int = 4) -> DeviceShape:
    """The bodies and hubs of ``device`` for module strains ``states`` (module name →
    ``bend`` (1/m), ``twist`` (rad/m), ``stretch``) at ``pressure`` (Pa).

    Copies ``j`` of a module are turned by 2πj/count about the parent's axis and set off by
    its radius; every copy hangs from the parent's first copy. A bending module with zero
    orientation bends toward −z.
    """
    branches = device.branches()
    end_frame: dict[str, np.ndarray] = {}
    index: dict[str, int] = {}
    bodies: list[Body] = []
    hubs: list[Hub] = []
    pending = list(branches)
    guard = 0
    while pending:
        guard += 1
        if guard > 10_000:  # Device validation rules out cycles
            raise RuntimeError("branch ordering did not converge")
        name = pending.pop(0)
        mods = branches[name]
        parent = next((module.attach_to for module in mods if module.attach_to), None)
        if parent is not None and parent not in end_frame:
            pending.append(name)
            continue
        base = np.eye(4) if parent is None else end_frame[parent]
        first = mods[0]
        if first.count > 1 or first.radius > 0:
            hubs.append(Hub(base, first.radius + 0.5 * first.cell.width))
        for j in range(first.count):
            T = base @ _rot_y(2.0 * math.pi * j / first.count)
            T = T @ _shift(np.array([0.0, 0.0, first.radius]))
            previous = None if parent is None else index[parent]
            for module in mods:
                state = states[module.name]
                segment = RodStrains.bend_twist(module.length, bend=state["bend"],
                                                twist=state["twist"],
                                                stretch=state["stretch"])
                Tm = T @ _rot_y(module.orientation)
                frames = frames_along([segment], max(2, points_per_cell * module.n_cells), Tm)
                key = module.name if module.count == 1 else f"{module.name}#{j}"
                bodies.append(Body(key, module, frames, previous,
                                   abs(state["bend"]) * module.length))
                previous = len(bodies) - 1
                if j == 0:
                    index[module.name] = previous
                T = Tm @ segment_transform(segment) @ _rot_y(-module.orientation)
                if j == 0:
                    end_frame[module.name] = T
    return DeviceShape(float(pressure), tuple(bodies), tuple(hubs))
