"""FE result files: the JSON summary, CSV paths, VTU time series (+ PVD index for ParaView),
plots and solids of a cell, device or twisting-module run.

Everything is written into a given folder; the CLI wraps it in
:func:`multimorph.io.atomic_output_dir`, so an interrupted run leaves nothing half-written.
:func:`write_outcome` writes every file of one :class:`~multimorph.fe.analyses.FEOutcome`.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from multimorph.fe._deps import require
from multimorph.fe.analyses import (
    STRIP_KEYS,
    FEDeviceResult,
    FEOutcome,
    FEResult,
    FETwistResult,
    peak_summary,
)
from multimorph.fe.mesh import device_pieces, hex_boundary
from multimorph.fe.report._cad import export_box_pieces, export_cell_solid, write_surface_stl
from multimorph.fe.report._comparison import comparison_curves, plot_comparison
from multimorph.fe.report._html import write_report_html
from multimorph.fe.report._plots import plot_curves, plot_device, plot_snapshots, plot_twist
from multimorph.fe.report._text import describe
from multimorph.io import write_json

__all__ = ["TWISTING_CAD_NOTE", "summary", "write_comparison_figure", "write_device_csv",
           "write_device_outputs", "write_device_solid", "write_device_vtu",
           "write_fe_outputs", "write_hex_series", "write_outcome", "write_path_csv",
           "write_twist_csv", "write_twist_outputs", "write_twist_vtu", "write_vtu_series"]

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


#: a twisting module's solid is no union of boxes: no STEP, the STL is the mesh's surface
TWISTING_CAD_NOTE = ("device.step not written (a twisting module's solid is not a union of "
                     "boxes); device.stl is the undeformed FE mesh's surface")


def _rows(path: Path, header: Sequence[str], rows: Any) -> None:
    """Write a CSV file: ``header``, then every row of ``rows``."""
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(header)
        writer.writerows(rows)


def _number(value: float) -> str:
    return f"{value:.8g}"


# ------------------------------------------------------------------ cell
def summary(result: FEResult) -> dict[str, Any]:
    """JSON-able summary: characteristic pressures, final state, solver statistics."""
    response = result.response
    path = response.path
    strip = {f"strip_{k}" if not k.startswith("strip_") else k: float(path.extra[k][-1])
             for k in STRIP_KEYS if k in path.extra}
    return {
        "backend": "fe",
        "characteristic": response.characteristic.to_dict(),
        "final": {
            "pressure_pa": float(path.pressure[-1]),
            "curvature_1_per_m": float(path.curvature[-1]),
            "bend_angle_deg": float(np.degrees(path.extra["bend_angle"][-1])),
            "volume_ratio": float(path.extra["volume_ratio"][-1]),
            "axial_stretch": float(path.axial_stretch[-1]),
            **peak_summary(path),
            **strip,
        },
        "max_pressure_pa": float(np.max(path.pressure)),
        "unstable_points": int(np.sum(~path.stable)),
        "length_m": response.length,
        "cells": int(result.mesh.n_cells),
        "shear_modulus_pa": response.shear_modulus,
        "stats": result.stats,
    }


def write_path_csv(result: FEResult, path: Path) -> None:
    """A cell's path as CSV (SI, angles in degrees; with the strip strains of a full
    model)."""
    data = result.response.path
    cols = [(name, np.asarray(f(data))) for name, f in _CSV_COLUMNS]
    cols += [(k, np.asarray(data.extra[k])) for k in STRIP_KEYS if k in data.extra]
    cols.append(("pressure_kpa", np.asarray(data.pressure) / 1e3))  # last: added columns
    _rows(path, [name for name, _ in cols],
          ([_number(values[i]) for _, values in cols] for i in range(len(data))))


def write_hex_series(folder: Path, stem: str, points: np.ndarray, cells: np.ndarray,
                     displacements: Sequence[np.ndarray], stretch: Sequence[np.ndarray],
                     pressure: Sequence[float], tags: Mapping[str, np.ndarray]) -> list[str]:
    """One VTU per path point (the deformed hexahedral mesh with its displacement, max
    principal stretch and integer cell ``tags``) and a ``.pvd`` collection that ParaView
    opens as a time series whose time is the pressure in kPa (``timestep``; the point's
    number and pressure in ``name``); returns the file names."""
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
        # ParaView's time is the pressure (kPa); the name keeps the path point's number
        lines.append(f'    <DataSet timestep="{float(pressure[i]) / 1e3:.9g}" group="" '
                     f'part="0" file="{name}" name="{i:04d} P={float(pressure[i]) / 1e3:.4g}kPa"'
                     f'/>')
        files.append(name)
    lines += ["  </Collection>", "</VTKFile>"]
    (folder / f"{stem}.pvd").write_text("\n".join(lines) + "\n")
    return [f"{stem}.pvd", *files]


def write_vtu_series(result: FEResult, folder: Path, stem: str = "cell") -> list[str]:
    """The cell's VTU series (:func:`write_hex_series`, tagged by ``region``)."""
    mesh = result.mesh
    return write_hex_series(folder, stem, mesh.points, mesh.cells, result.displacements,
                            result.stretch, result.response.path.pressure,
                            {"region": mesh.region})


def write_fe_outputs(result: FEResult, folder: Path, *, vtu: bool = True, plots: bool = True,
                     cad: bool = True) -> list[str]:
    """Write every file of a cell run into ``folder``; returns the file names."""
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


# ------------------------------------------------------------------ device
def write_device_csv(result: FEDeviceResult, folder: Path) -> list[str]:
    """``curves.csv`` (every module's path: bend angle, curvature, stretch, volume, peak
    stretch, stability, twist) and ``tip.csv`` (the tip's position and angle) in
    ``folder`` (SI, angles in degrees); returns the file names."""
    folder = Path(folder)
    degree = math.degrees(1.0)

    def curves() -> Any:
        for name, response in result.responses.items():
            path = response.path
            cols = (path.pressure, degree * path.extra["bend_angle"], path.curvature,
                    path.axial_stretch, path.volume, path.extra["volume_ratio"],
                    path.peak_stretch)
            twist = (degree * path.extra["twist_angle"], path.twist_rate, path.pressure / 1e3)
            for i in range(len(path)):
                yield [name, *(_number(c[i]) for c in cols), int(path.stable[i]),
                       *(_number(c[i]) for c in twist)]

    _rows(folder / "curves.csv",
          ["module", "pressure_pa", "bend_angle_deg", "curvature_1_per_m", "axial_stretch",
           "chamber_volume_m3", "volume_ratio", "peak_stretch", "stable", "twist_angle_deg",
           "twist_rate_rad_per_m", "pressure_kpa"], curves())
    _rows(folder / "tip.csv",
          ["pressure_pa", "tip_x_m", "tip_y_m", "tip_z_m", "tip_angle_deg", "stable",
           "pressure_kpa"],
          ([_number(P), *(_number(v) for v in tip), _number(math.degrees(angle)), int(stable),
            _number(P / 1e3)]
           for P, tip, angle, stable in zip(result.pressure, result.tip, result.tip_angle,
                                            result.stable, strict=True)))
    return ["curves.csv", "tip.csv"]


def write_device_vtu(result: FEDeviceResult, folder: Path, stem: str = "device") -> list[str]:
    """The device's VTU series (:func:`write_hex_series`), tagged by region, module and
    material."""
    mesh = result.mesh
    return write_hex_series(folder, stem, mesh.points, mesh.cells, result.displacements,
                            result.stretch, result.pressure,
                            {"region": mesh.region, "module": mesh.module,
                             "material": mesh.material})


def write_device_solid(result: FEDeviceResult, folder: Path) -> tuple[list[str], str | None]:
    """``device.step`` and ``device.stl`` of a device of box cells (gmsh OCC); for a device
    with a twisting module only ``device.stl``, the undeformed mesh's surface. Returns the
    file names and a note when the STEP file is not written."""
    folder = Path(folder)
    device = result.device
    if all(module.kind != "twisting" for module in device.modules):
        pieces = device_pieces(device)
        edge = min(min(box[3:]) for outer, inner, _ in pieces for box in [*outer, *inner]) / 2
        for name in ("device.step", "device.stl"):
            export_box_pieces(pieces, folder / name, edge)
        return ["device.step", "device.stl"], None
    mesh = result.mesh
    write_surface_stl(mesh.points, hex_boundary(mesh.cells), folder / "device.stl",
                      name=device.name)
    return ["device.stl"], TWISTING_CAD_NOTE


def write_device_outputs(result: FEDeviceResult, folder: Path, *, vtu: bool = True,
                         comparison: Mapping[str, Any] | None = None,
                         ) -> tuple[list[str], str | None]:
    """Write every file of a device run into ``folder``: ``summary.json``, the CSV files,
    ``comparison.json`` (with a ``comparison``), the plots, the solid and the VTU series.
    Returns the file names and a note on the solid (:func:`write_device_solid`)."""
    folder = Path(folder)
    files = ["summary.json"]
    write_json(folder / "summary.json", {"backend": "fe", "device": result.to_dict()})
    files += write_device_csv(result, folder)
    if comparison is not None:
        write_json(folder / "comparison.json", comparison)
        files.append("comparison.json")
    files += plot_device(result, folder)
    solid, note = write_device_solid(result, folder)
    files += solid
    if vtu:
        files += write_device_vtu(result, folder)
    return files, note


# ------------------------------------------------------------------ twisting module
def write_twist_vtu(result: FETwistResult, folder: Path, stem: str = "module") -> list[str]:
    """The module's VTU series (:func:`write_hex_series`), tagged by region (0 wall, 1 bottom
    layer, 2 shaft), strip (−1: the shaft) and material."""
    mesh = result.mesh
    return write_hex_series(folder, stem, mesh.points, mesh.cells, result.displacements,
                            result.stretch, result.pressure,
                            {"region": mesh.region, "strip": mesh.strip,
                             "material": mesh.material})


def write_twist_csv(result: FETwistResult, path: Path) -> None:
    """The path as CSV: pressure, signed twist angle and rate, axial stretch, chamber volume,
    volume ratio, peak stretch, stability, arc-length step (SI, angles in degrees)."""
    data = result.response.path
    cols = {"pressure_pa": data.pressure, "twist_angle_deg": np.degrees(result.twist_angle),
            "twist_rate_rad_per_m": result.twist_angle / result.module.length,
            "axial_stretch": data.axial_stretch, "chamber_volume_m3": data.volume,
            "volume_ratio": data.extra["volume_ratio"], "peak_stretch": data.peak_stretch}
    _rows(path, [*cols, "stable", "arc_length_step", "pressure_kpa"],
          ([*(_number(c[i]) for c in cols.values()), int(data.stable[i]),
            int(data.extra["arc_length"][i]), _number(data.pressure[i] / 1e3)]
           for i in range(len(data))))


def write_twist_outputs(result: FETwistResult, folder: Path, *, vtu: bool = True,
                        comparison: Mapping[str, Any] | None = None) -> list[str]:
    """Write every file of a twisting-module run into ``folder``: ``summary.json``,
    ``path.csv``, ``comparison.json`` (with a ``comparison``), the plots and the VTU
    series; returns the file names."""
    folder = Path(folder)
    files = ["summary.json", "path.csv"]
    write_json(folder / "summary.json", {"backend": "fe", "module": result.to_dict()})
    write_twist_csv(result, folder / "path.csv")
    if comparison is not None:
        write_json(folder / "comparison.json", comparison)
        files.append("comparison.json")
    files += plot_twist(result, folder)
    if vtu:
        files += write_twist_vtu(result, folder)
    return files


# ------------------------------------------------------------------ one run of any kind
def write_outcome(outcome: FEOutcome, folder: Path, *, vtu: bool = True,
                  html: bool = True) -> dict[str, Any]:
    """Write every file of an FE run (:func:`~multimorph.fe.analyses.run_job`) into
    ``folder``, with ``html`` its ``report.html`` (:func:`write_report_html`); returns its
    JSON summary, with ``files`` (the file names written)."""
    folder = Path(folder)
    result, comparison = outcome.result, outcome.comparison
    if isinstance(result, FEResult):
        info = summary(result)
        if comparison is not None:
            key = "shear_comparison" if outcome.job.tilt else "comparison"
            info[key] = comparison.to_dict()
        files = write_fe_outputs(result, folder, vtu=vtu)
        if comparison is not None:
            write_json(folder / "comparison.json", comparison.to_dict())
            files.append("comparison.json")
    elif isinstance(result, FEDeviceResult):
        info = {"backend": "fe", "device": result.to_dict(paths=False)}
        if comparison is not None:
            info["comparison"] = comparison
        files, note = write_device_outputs(result, folder, vtu=vtu, comparison=comparison)
        if note is not None:
            info["cad"] = note
    else:
        info = {"backend": "fe", "module": result.to_dict(paths=False)}
        if comparison is not None:
            info["comparison"] = comparison
        files = write_twist_outputs(result, folder, vtu=vtu, comparison=comparison)
    if comparison is not None:
        write_comparison_figure(outcome, folder / "comparison.png")
        files.append("comparison.png")
    if html:
        title, lines = describe(outcome, info)
        write_report_html(outcome, folder / "report.html", title=title, lines=lines)
        files.append("report.html")
    info["files"] = files
    return info


def write_comparison_figure(outcome: FEOutcome, path: Path) -> None:
    """``comparison.png`` of a run with a comparison: the reduced model's curve against
    FE's (per module for a device), Pc and Ph of both marked
    (:func:`~multimorph.fe.report.plot_comparison`)."""
    job = outcome.job
    what = {"cell": "cell" if job.n_cells == 1 else f"module of {job.n_cells} cells",
            "device": f"device {job.device.name if job.device else ''}",
            "twisting": f"twisting module {job.module.name if job.module else ''}"}[job.kind]
    if job.tilt:
        what = f"strip of {job.n_cells} cells tilted {math.degrees(job.tilt):.3g}°"
    plot_comparison(comparison_curves(outcome.comparison), path,
                    title=f"{what}: {_compared_model(outcome.comparison)} model vs 3D FE")


def _compared_model(comparison: Any) -> str:
    """The cell model a comparison ran (``calibrated``, ``ritz`` …; "reduced" where it does
    not say): a cell's ``meta["model"]``, a twisting module's ``model``, a device's
    modules' ``model``."""
    meta = getattr(comparison, "meta", None)
    if isinstance(meta, dict) and meta.get("model"):
        return str(meta["model"])
    if isinstance(comparison, dict):
        if isinstance(comparison.get("model"), str):
            return comparison["model"]
        names = sorted({str(m["model"]) for m in comparison.values()
                        if isinstance(m, dict) and m.get("model")})
        if names:
            return " / ".join(names)
    return "reduced"
