"""Solids for CAD and printing: STEP/STL of a cell or device (gmsh OpenCASCADE boxes) and the
STL of an FE mesh's surface."""

from __future__ import annotations

import contextlib
import math
import os
import sys
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from multimorph.fe._deps import require
from multimorph.geometry import CellGeometry

__all__ = ["export_box_pieces", "export_box_solid", "export_cell_solid", "write_surface_stl"]


@contextlib.contextmanager
def _quiet_stdout() -> Iterator[None]:
    """Silence C-level stdout (OpenCASCADE's STEP writer prints banners on it)."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):
        yield
        return
    sys.stdout.flush()
    saved = os.dup(fd)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), fd)
            yield
    finally:
        os.dup2(saved, fd)
        os.close(saved)


def export_cell_solid(geometry: CellGeometry, path: Path, n_cells: int = 1,
                      tilt: float = 0.0) -> None:
    """Write the cell solid (box minus chamber), or ``n_cells`` of them in series, as STEP or
    STL (by suffix) with gmsh OCC; ``tilt`` β shears it in the strip plane as the FE mesh
    (y' = y + (x − w/2) tan β, see :func:`~multimorph.fe.cell_mesh`)."""
    cell = geometry
    outer = [(0.0, 0.0, 0.0, cell.width, n_cells * cell.length, cell.height)]
    inner = [(cell.ws, k * cell.length + cell.df, cell.hb, cell.wc, cell.dc, cell.hc)
             for k in range(n_cells)]
    # affine map, row-major 3 × 4: y' = y + k x − k w/2
    shear = None
    if tilt:
        k = math.tan(tilt)
        shear = [1, 0, 0, 0, k, 1, 0, -k * 0.5 * cell.width, 0, 0, 1, 0]
    export_box_solid(outer, inner, path, min(cell.ht, cell.ws, cell.df, cell.hb), affine=shear)


def export_box_solid(outer: Sequence[Sequence[float]], inner: Sequence[Sequence[float]],
                     path: Path, stl_size: float, *,
                     affine: Sequence[float] | None = None) -> None:
    """Write the union of the ``outer`` boxes minus the ``inner`` ones (each ``(x, y, z,
    dx, dy, dz)`` in m) as STEP or STL (by suffix, CAD in mm) with gmsh OCC; ``affine`` is
    an optional row-major 3 × 4 map (m) applied to the solid; ``stl_size`` (m) is the
    largest STL facet edge."""
    export_box_pieces([(outer, inner, affine)], path, stl_size)


def export_box_pieces(pieces: Sequence[tuple[Sequence[Sequence[float]],
                                             Sequence[Sequence[float]],
                                             Sequence[float] | None]],
                      path: Path, stl_size: float) -> None:
    """Like :func:`export_box_solid` for several solids, each ``(outer, inner, affine)``,
    fused into one shape (pieces that touch or overlap merge, the others stay separate
    volumes of the file)."""
    gmsh = require("gmsh")
    initialised = gmsh.isInitialized()
    if not initialised:
        gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("solid")
        occ = gmsh.model.occ
        mm = 1e3  # CAD in mm
        solids = []
        for outer, inner, affine in pieces:
            boxes = [(3, occ.addBox(*(v * mm for v in b))) for b in outer]
            if len(boxes) > 1:
                boxes, _ = occ.fuse(boxes[:1], boxes[1:])
            holes = [(3, occ.addBox(*(v * mm for v in b))) for b in inner]
            solid, _ = occ.cut(boxes, holes) if holes else (boxes, None)
            if affine is not None:
                a = list(affine)
                occ.affineTransform(solid, [*a[0:3], a[3] * mm, *a[4:7], a[7] * mm,
                                            *a[8:11], a[11] * mm])
            solids += solid
        if len(solids) > 1:
            solids, _ = occ.fuse(solids[:1], solids[1:])
        occ.synchronize()
        if Path(path).suffix.lower() == ".stl":
            gmsh.option.setNumber("Mesh.MeshSizeMax", stl_size * mm)
            gmsh.model.mesh.generate(2)
        with _quiet_stdout():
            gmsh.write(str(path))
        gmsh.model.remove()
    finally:
        if not initialised:
            gmsh.finalize()


def write_surface_stl(points: np.ndarray, quads: np.ndarray, path: Path, *,
                      name: str = "multimorph") -> None:
    """Write quads (two triangles each, split along the diagonal 0–2) as ASCII STL in mm.

    For the undeformed FE mesh of a solid this is its closed surface (outer skin and cavity
    walls), which slicers and CAD tools open."""
    P = np.asarray(points, dtype=float) * 1e3
    tri = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    v = P[tri]
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    lines = [f"solid {name}"]
    for nk, vk in zip(n, v, strict=True):
        lines.append(f"facet normal {nk[0]:.9g} {nk[1]:.9g} {nk[2]:.9g}")
        lines.append("outer loop")
        lines += [f"vertex {a:.9g} {b:.9g} {c:.9g}" for a, b, c in vk]
        lines += ["endloop", "endfacet"]
    lines.append(f"endsolid {name}")
    Path(path).write_text("\n".join(lines) + "\n")


