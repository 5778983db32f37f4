"""FE result files: VTU time series (+ PVD index for ParaView), CSV/JSON, PNG, STEP/STL.

Everything is written into a given folder; the CLI wraps it in
:func:`multimorph.io.atomic_output_dir`, so an interrupted run leaves nothing half-written.
"""

from __future__ import annotations

import contextlib
import csv
import math
import os
import sys
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from multimorph.fe._cell import FEResult
from multimorph.fe._deps import require
from multimorph.fe._measure import peak_summary
from multimorph.geometry import CellGeometry
from multimorph.io import write_json

__all__ = ["export_box_solid", "export_cell_solid", "hex_boundary", "plot_hex_snapshots",
           "plot_path_panels", "summary", "write_fe_outputs", "write_surface_stl"]

_CSV_COLUMNS = [
    ("pressure_pa", lambda p: p.pressure),
    ("curvature_1_per_m", lambda p: p.curvature),
    ("bend_angle_deg", lambda p: np.degrees(p.extra["bend_angle"])),
    ("twist_rate_rad_per_m", lambda p: p.twist_rate),
    ("axial_stretch", lambda p: p.axial_stretch),
    ("chamber_volume_m3", lambda p: p.volume),
    ("volume_ratio", lambda p: p.extra["volume_ratio"]),
    ("peak_stretch", lambda p: p.peak_stretch),
    ("stable", lambda p: p.stable.astype(int)),
    ("arc_length_step", lambda p: p.extra["arc_length"].astype(int)),
]

#: strip strains of full-model runs (``simulate_cell`` records them when not ``half``)
_STRIP_KEYS = ("shear", "shear_slope", "strip_axial_strain", "strip_lateral_strain",
               "strip_rotation")


def summary(result: FEResult) -> dict[str, Any]:
    """JSON-able summary: characteristic pressures, final state, solver statistics."""
    r = result.response
    p = r.path
    strip = {f"strip_{k}" if not k.startswith("strip_") else k: float(p.extra[k][-1])
             for k in _STRIP_KEYS if k in p.extra}
    return {
        "backend": "fe",
        "characteristic": r.characteristic.to_dict(),
        "final": {
            "pressure_pa": float(p.pressure[-1]),
            "curvature_1_per_m": float(p.curvature[-1]),
            "bend_angle_deg": float(np.degrees(p.extra["bend_angle"][-1])),
            "volume_ratio": float(p.extra["volume_ratio"][-1]),
            "axial_stretch": float(p.axial_stretch[-1]),
            **peak_summary(p),
            **strip,
        },
        "max_pressure_pa": float(np.max(p.pressure)),
        "unstable_points": int(np.sum(~p.stable)),
        "length_m": r.length,
        "cells": int(result.mesh.n_cells),
        "shear_modulus_pa": r.shear_modulus,
        "stats": result.stats,
    }


def write_path_csv(result: FEResult, path: Path) -> None:
    p = result.response.path
    cols = [(name, np.asarray(f(p))) for name, f in _CSV_COLUMNS]
    cols += [(k, np.asarray(p.extra[k])) for k in _STRIP_KEYS if k in p.extra]
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow([c[0] for c in cols])
        for i in range(len(p)):
            w.writerow([f"{c[1][i]:.8g}" for c in cols])


def write_hex_series(folder: Path, stem: str, points: np.ndarray, cells: np.ndarray,
                     displacements: Sequence[np.ndarray], stretch: Sequence[np.ndarray],
                     pressure: Sequence[float], tags: Mapping[str, np.ndarray]) -> list[str]:
    """One VTU per path point (the deformed hexahedral mesh with its displacement, max
    principal stretch and integer cell ``tags``) and a ``.pvd`` collection indexed by
    pressure (kPa) that ParaView opens as a time series; returns the file names."""
    meshio = require("meshio")
    folder = Path(folder)
    tags = {k: np.asarray(v).astype(np.int32) for k, v in tags.items()}
    files = []
    lines = ['<?xml version="1.0"?>',
             '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
             "  <Collection>"]
    for i, (u, lam) in enumerate(zip(displacements, stretch, strict=True)):
        name = f"{stem}_{i:04d}.vtu"
        meshio.Mesh(points + u, [("hexahedron", cells)], point_data={"displacement": u},
                    cell_data={"max_principal_stretch": [lam],
                               **{k: [v] for k, v in tags.items()}},
                    ).write(folder / name, binary=True)
        lines.append(f'    <DataSet timestep="{i}" group="" part="0" file="{name}"'
                     f' name="P={float(pressure[i]) / 1e3:.4g}kPa"/>')
        files.append(name)
    lines += ["  </Collection>", "</VTKFile>"]
    (folder / f"{stem}.pvd").write_text("\n".join(lines) + "\n")
    return [f"{stem}.pvd", *files]


def write_vtu_series(result: FEResult, folder: Path, stem: str = "cell") -> list[str]:
    """The cell's VTU series (:func:`write_hex_series`, tagged by ``region``)."""
    m = result.mesh
    return write_hex_series(folder, stem, m.points, m.cells, result.displacements,
                            result.stretch, result.response.path.pressure,
                            {"region": m.region})


def plot_curves(result: FEResult, path: Path) -> None:
    """Pressure against curvature·d, chamber volume ratio and peak stretch (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r = result.response
    p = r.path
    mu = r.shear_modulus
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.8), constrained_layout=True)
    xs = [(p.curvature * r.length, "κ d (-)"), (p.extra["volume_ratio"], "V / V0 (-)"),
          (p.peak_stretch, "peak principal stretch (-)")]
    for ax, (x, label) in zip(axes, xs, strict=True):
        ax.plot(x, p.pressure / mu, "-", color="0.6", lw=1, label="path")
        st = p.stable
        ax.plot(np.where(st, x, np.nan), np.where(st, p.pressure / mu, np.nan), "o-", ms=2.5,
                label="stable")
        if (~st).any():
            ax.plot(x[~st], p.pressure[~st] / mu, "x", color="C3", ms=4, label="unstable")
        ax.set_xlabel(label)
        ax.set_ylabel("P / μ (-)")
        ax.grid(alpha=0.3)
    c = r.characteristic
    for val, name, ls in ((c.critical, "Pc", "--"), (c.hardening, "Ph", ":")):
        if val is not None:
            for ax in axes:
                ax.axhline(val / mu, color="k", ls=ls, lw=0.8)
            axes[0].text(0.02, val / mu, f" {name}", va="bottom", fontsize=8,
                         transform=axes[0].get_yaxis_transform())
    axes[0].legend(fontsize=8)
    fig.suptitle(f"FE cell path ({result.stats['nfree']} DOF, {result.stats['solver']})")
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_snapshots(result: FEResult, path: Path, count: int = 4) -> None:
    """Side views (y–z) of the deformed cell at a few path points, coloured by stretch."""
    m = result.mesh
    plot_hex_snapshots(m.points, m.cells, result.displacements, result.stretch,
                       result.response.path.pressure, path, count=count)


def plot_hex_snapshots(points: np.ndarray, cells: np.ndarray, displacements: np.ndarray,
                       stretch: np.ndarray, pressure: np.ndarray, path: Path, *,
                       count: int = 4, view: tuple[int, int] = (1, 2), slab: int = 0,
                       slab_side: str = "low", title: str | None = None) -> None:
    """Views of a deformed hex mesh at ``count`` path points, coloured by stretch (PNG).

    The element centroids of one slab (the third of the mesh nearest its ``slab_side``
    along axis ``slab``: the outer face of a half model by default) are projected on the
    plane of the ``view`` axes (0 x, 1 y, 2 z), so walls in front hide nothing behind them.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    picks = _snapshot_picks(np.asarray(pressure, dtype=float), count)
    cen0 = points[cells].mean(axis=1)[:, slab]
    lo, hi = float(cen0.min()), float(cen0.max())
    third = (hi - lo) / 3 + 1e-12 * max(abs(hi), 1.0)
    front = cen0 <= lo + third if slab_side == "low" else cen0 >= hi - third
    vmax = float(np.nanmax(stretch[picks][:, front])) if front.any() else 1.0
    fig, axes = plt.subplots(1, len(picks), figsize=(3.2 * len(picks), 3.2),
                             constrained_layout=True, squeeze=False)
    names = "xyz"
    sc = None
    cens = {i: (points + displacements[i])[cells].mean(axis=1)[front] * 1e3 for i in picks}
    both = np.concatenate([c[:, list(view)] for c in cens.values()])
    pad = 0.03 * float(np.ptp(both, axis=0).max())
    lims = [(float(both[:, k].min()) - pad, float(both[:, k].max()) + pad) for k in (0, 1)]
    for ax, i in zip(axes[0], picks, strict=True):
        cen = cens[i]
        sc = ax.scatter(cen[:, view[0]], cen[:, view[1]], c=stretch[i][front], s=6,
                        cmap="viridis", vmin=1.0, vmax=max(vmax, 1.0 + 1e-6))
        ax.set_xlim(*lims[0])
        ax.set_ylim(*lims[1])
        ax.set_aspect("equal")
        ax.set_title(f"P = {float(pressure[i]) / 1e3:.3g} kPa", fontsize=9)
        ax.set_xlabel(f"{names[view[0]]} (mm)")
        ax.set_ylabel(f"{names[view[1]]} (mm)")
    if sc is not None:
        fig.colorbar(sc, ax=axes[0].tolist(), label="max principal stretch", shrink=0.8)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _snapshot_picks(pressure: np.ndarray, count: int) -> list[int]:
    """Path points to show: the first to reach each of ``count`` evenly spaced pressures
    from 0 to the highest, and the last point (a path crowds its points where it balloons,
    so evenly spaced indices would show mostly the end)."""
    n = len(pressure)
    if n == 0:
        return []
    top = float(np.max(pressure))
    picks = {n - 1}
    for t in np.linspace(0.0, top, max(count, 1)):
        picks.add(int(np.argmax(pressure >= t - 1e-12 * max(abs(top), 1.0))))
    return sorted(picks)


def plot_path_panels(pressure: np.ndarray, stable: np.ndarray,
                     panels: Sequence[tuple[str, Mapping[str, np.ndarray]]], path: Path, *,
                     title: str, marks: Sequence[tuple[float, str]] = ()) -> None:
    """Pressure (kPa) against one or more path quantities per panel (PNG).

    ``panels``: (x-axis label, {curve label: values per path point}); unstable points are
    crossed; ``marks`` are horizontal lines (pressure in Pa, label), e.g. Pc and Ph.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(panels), figsize=(4 * len(panels), 3.8),
                             constrained_layout=True, squeeze=False)
    pk = np.asarray(pressure) / 1e3
    st = np.asarray(stable, dtype=bool)
    for ax, (label, curves) in zip(axes[0], panels, strict=True):
        for k, (name, x) in enumerate(curves.items()):
            x = np.asarray(x, dtype=float)
            ax.plot(x, pk, "-", color=f"C{k}", lw=1, label=name)
            if (~st).any():
                ax.plot(x[~st], pk[~st], "x", color=f"C{k}", ms=4)
        for val, name in marks:
            ax.axhline(val / 1e3, color="k", ls="--", lw=0.7)
            ax.text(0.02, val / 1e3, f" {name}", va="bottom", fontsize=7,
                    transform=ax.get_yaxis_transform())
        ax.set_xlabel(label)
        ax.set_ylabel("P (kPa)")
        ax.grid(alpha=0.3)
        if len(curves) > 1:
            ax.legend(fontsize=7)
    fig.suptitle(title + ("  (x: unstable points)" if (~st).any() else ""), fontsize=10)
    fig.savefig(path, dpi=120)
    plt.close(fig)


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
    g = geometry
    outer = [(0.0, 0.0, 0.0, g.width, n_cells * g.length, g.height)]
    inner = [(g.ws, k * g.length + g.df, g.hb, g.wc, g.dc, g.hc) for k in range(n_cells)]
    # affine map, row-major 3 × 4: y' = y + k x − k w/2
    shear = None
    if tilt:
        k = math.tan(tilt)
        shear = [1, 0, 0, 0, k, 1, 0, -k * 0.5 * g.width, 0, 0, 1, 0]
    export_box_solid(outer, inner, path, min(g.ht, g.ws, g.df, g.hb), affine=shear)


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
        s = 1e3  # CAD in mm
        solids = []
        for outer, inner, affine in pieces:
            boxes = [(3, occ.addBox(*(v * s for v in b))) for b in outer]
            if len(boxes) > 1:
                boxes, _ = occ.fuse(boxes[:1], boxes[1:])
            holes = [(3, occ.addBox(*(v * s for v in b))) for b in inner]
            solid, _ = occ.cut(boxes, holes) if holes else (boxes, None)
            if affine is not None:
                a = list(affine)
                occ.affineTransform(solid, [*a[0:3], a[3] * s, *a[4:7], a[7] * s,
                                            *a[8:11], a[11] * s])
            solids += solid
        if len(solids) > 1:
            solids, _ = occ.fuse(solids[:1], solids[1:])
        occ.synchronize()
        if Path(path).suffix.lower() == ".stl":
            gmsh.option.setNumber("Mesh.MeshSizeMax", stl_size * s)
            gmsh.model.mesh.generate(2)
        with _quiet_stdout():
            gmsh.write(str(path))
        gmsh.model.remove()
    finally:
        if not initialised:
            gmsh.finalize()


def hex_boundary(cells: np.ndarray) -> np.ndarray:
    """The boundary quads of a hexahedral mesh (faces of exactly one element), ordered
    counter-clockwise seen from outside that element: their normals point away from the
    material, out of the outer surface and into every cavity (chambers)."""
    from multimorph.fe._mesh import _HEX_FACES

    faces = cells[:, _HEX_FACES].reshape(-1, 4)
    _, inv, count = np.unique(np.sort(faces, axis=1), axis=0, return_inverse=True,
                              return_counts=True)
    return faces[count[inv.ravel()] == 1]


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


def write_fe_outputs(result: FEResult, folder: Path, *, vtu: bool = True, plots: bool = True,
                     cad: bool = True) -> list[str]:
    """Write every FE output into ``folder``; returns the file names."""
    folder = Path(folder)
    files = ["summary.json", "path.csv"]
    write_json(folder / "summary.json", {**summary(result),
                                         "path": result.response.path.to_dict()})
    write_path_csv(result, folder / "path.csv")
    if plots:
        plot_curves(result, folder / "curves.png")
        plot_snapshots(result, folder / "snapshots.png")
        files += ["curves.png", "snapshots.png"]
    if vtu:
        files += write_vtu_series(result, folder)
    if cad:
        n, tilt = result.mesh.n_cells, result.mesh.tilt
        export_cell_solid(result.mesh.geometry, folder / "cell.step", n, tilt)
        export_cell_solid(result.mesh.geometry, folder / "cell.stl", n, tilt)
        files += ["cell.step", "cell.stl"]
    return files
