"""A deformed device drawn as solid bodies (matplotlib 3D): each module copy's cell
cross-section swept along its rod frames, in mm.

- the cross-section is the cell's outer width × height (a twisting module: its strips around
  the shaft), so bend, twist and stretch all show;
- a darker band at every partition between two cells (the chambers read as segments);
- a dark stripe along the top face (the first strip's outer face for a twisting module), so
  that twist can be seen;
- hubs (discs) where parallel copies such as fingers hang from.

All polygons of one picture go into one ``Poly3DCollection`` so that matplotlib sorts them
by depth together.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["BODY_POINTS_PER_CELL", "HUB", "body_polygons", "draw_bodies"]

#: Rod frames per cell in a drawing (the partition band is one of them wide).
BODY_POINTS_PER_CELL = 8
#: Colour of the stripe and of hubs; how much darker a partition band is.
STRIPE = (0.12, 0.12, 0.12, 1.0)
HUB = (0.55, 0.55, 0.58, 1.0)
BAND = 0.6


def _rectangle(w: float, h: float, *, offset: float = 0.0, angle: float = 0.0
               ) -> tuple[np.ndarray, int]:
    """Outline (m, 2) in the body's (x, z) plane of a w × h rectangle centred at height
    ``offset``, turned by ``angle`` about the axis; the index of its stripe edge (the middle
    third of the top face)."""
    pts = np.array([(-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2), (w / 6, h / 2),
                    (-w / 6, h / 2), (-w / 2, h / 2)])
    pts[:, 1] += offset
    cos_a, sin_a = math.cos(angle), math.sin(angle)
    turned = np.column_stack([pts[:, 0] * cos_a + pts[:, 1] * sin_a,
                              -pts[:, 0] * sin_a + pts[:, 1] * cos_a])
    return turned, 3


def _sections(body: Any) -> list[tuple[np.ndarray, int | None, bool]]:
    """Outlines of a body's cross-section: (points, stripe edge or None, is the shaft)."""
    module, cell = body.module, body.module.cell
    if module.kind != "twisting":
        return [(*_rectangle(cell.width, cell.height), False)]
    out: list[tuple[np.ndarray, int | None, bool]] = []
    for k in range(module.strips):
        pts, stripe = _rectangle(cell.width, cell.height,
                                 offset=module.shaft_radius + 0.5 * cell.height,
                                 angle=2.0 * math.pi * k / module.strips)
        out.append((pts, stripe if k == 0 else None, False))
    ring = np.linspace(0.0, 2.0 * math.pi, 13)[:-1]
    out.append((module.shaft_radius * np.column_stack([np.cos(ring), np.sin(ring)]), None,
                True))
    return out


def _sweep(frames: np.ndarray, outline: np.ndarray) -> np.ndarray:
    """Points (n, m, 3) (m) of ``outline`` (m, 2) in the (x, z) plane of every frame."""
    R, r = frames[:, :3, :3], frames[:, :3, 3]
    return (r[:, None, :] + outline[None, :, 0, None] * R[:, None, :, 0]
            + outline[None, :, 1, None] * R[:, None, :, 2])


def _shade(colour: tuple[float, ...], factor: float) -> tuple[float, ...]:
    """``colour`` darker (factor < 1) or lighter (> 1), each channel kept within 0–1."""
    return (*(min(1.0, factor * c) for c in colour[:3]), 1.0)


def body_polygons(shape: Any, colours: Mapping[str, Any], *,
                  points_per_cell: int = BODY_POINTS_PER_CELL
                  ) -> tuple[list[np.ndarray], list[tuple[float, ...]], list[str]]:
    """Polygons (each (k, 3), mm), their face colours and what each belongs to (a module's
    name, or ``"hub"``) for a :class:`~multimorph.device.DeviceShape` (drawn with
    ``points_per_cell`` frames per cell); ``colours`` by module name."""
    from matplotlib.colors import to_rgba

    polygons: list[np.ndarray] = []
    faces: list[tuple[float, ...]] = []
    owners: list[str] = []
    for body in shape.bodies:
        start = len(polygons)
        base = to_rgba(colours[body.module.name])
        n = len(body.frames)
        for outline, stripe, shaft in _sections(body):
            X = _sweep(body.frames, outline) * 1e3
            m = len(outline)
            colour = _shade(base, 1.25) if shaft else base
            for k in range(n - 1):
                # the last ring of every cell but the last: the partition between chambers
                ring = (_shade(colour, BAND) if (k + 1) % points_per_cell == 0 and k + 2 < n
                        else colour)
                for j in range(m):
                    polygons.append(np.array([X[k, j], X[k + 1, j], X[k + 1, (j + 1) % m],
                                              X[k, (j + 1) % m]]))
                    faces.append(STRIPE if j == stripe else ring)
            for end in (0, n - 1):
                polygons.append(X[end])
                faces.append(colour)
        owners += [body.module.name] * (len(polygons) - start)
    for hub in shape.hubs:
        start = len(polygons)
        ring = np.linspace(0.0, 2.0 * math.pi, 25)[:-1]
        outline = hub.radius * np.column_stack([np.cos(ring), np.sin(ring)])
        thickness = 0.15 * hub.radius
        frames = np.array([hub.frame, hub.frame])
        frames[0, :3, 3] -= thickness * hub.frame[:3, 1]  # behind the plane it carries
        X = _sweep(frames, outline) * 1e3
        for j in range(len(outline)):
            polygons.append(np.array([X[0, j], X[1, j], X[1, (j + 1) % len(outline)],
                                      X[0, (j + 1) % len(outline)]]))
            faces.append(HUB)
        polygons += [X[0], X[1]]
        faces += [HUB, HUB]
        owners += ["hub"] * (len(polygons) - start)
    return polygons, faces, owners


def draw_bodies(ax: Any, shape: Any, colours: Mapping[str, Any]) -> Any:
    """Add the bodies and hubs of ``shape`` to the 3D axes ``ax`` as one shaded
    ``Poly3DCollection``; return it."""
    from matplotlib.colors import LightSource
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    polygons, faces, _ = body_polygons(shape, colours)
    surface = Poly3DCollection(polygons, facecolors=faces, edgecolors=faces, linewidths=0.2,
                               shade=True,
                               lightsource=LightSource(azdeg=225, altdeg=45))
    ax.add_collection3d(surface, autolim=False)  # the caller sets the limits
    return surface
