"""``multimorph fem``: 3D finite-element analysis of a unit cell, module or device (FElupe)."""

from __future__ import annotations

import contextlib
import csv
import math
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated, Any

import typer

from multimorph.cli._common import console, emit_json, err_console, handle_errors

__all__ = ["fem", "register"]


@contextlib.contextmanager
def _progress(label: str, p_end: float, quiet: bool) -> Iterator[Callable[[float, int], None]]:
    """A transient progress bar on stderr (pressure reached, points); yields the callback
    ``progress(pressure_pa, n_points)`` that the FE drivers call."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(TextColumn(f"[bold]{label}[/]"), BarColumn(),
                  TextColumn("{task.fields[p]:.1f} kPa · {task.fields[n]} points"),
                  TimeElapsedColumn(), console=err_console, transient=True,
                  disable=quiet) as bar:
        task = bar.add_task(label, total=p_end, p=0.0, n=0)

        def progress(p: float, n: int) -> None:
            bar.update(task, completed=min(max(p, 0.0), p_end), p=p / 1e3, n=n)

        yield progress


def _checkpoint(spec: Path, folder: Path, options: dict[str, Any], restart: bool) -> Any:
    """The resume folder of an FE run (``<out>.resume`` beside ``--out``), keyed to the
    spec file's bytes, the options and the package version; emptied with ``--restart``."""
    import hashlib
    import json

    from multimorph import __version__
    from multimorph.fe import PathCheckpoint

    h = hashlib.sha256(spec.read_bytes())
    h.update(json.dumps({**options, "version": __version__}, sort_keys=True,
                        default=str).encode())
    ck = PathCheckpoint(folder.with_name(folder.name + ".resume"), h.hexdigest())
    if restart:
        ck.clear()
    return ck


@contextlib.contextmanager
def _resumable(ck: Any, quiet: bool) -> Iterator[None]:
    """Ctrl-C keeps the converged points: say where and how to go on, exit 130."""
    try:
        yield
    except KeyboardInterrupt:
        err_console.print(f"interrupted: {ck.saved} converged points are kept in "
                          f"{ck.folder}/; run the same command again to resume from them "
                          f"(--restart starts afresh)", highlight=False, soft_wrap=True)
        raise typer.Exit(130) from None
    if ck.discarded and not quiet:
        err_console.print(f"note: the points in {ck.folder}/ were not reused "
                          f"({ck.discarded}); started afresh", highlight=False)


def _density(mesh: str, size: float | None, wall_elements: int | None) -> Any:
    """The mesh density of the options: the preset, an explicit in-plane size, and
    ``--wall-elements`` (elements through every wall) over both."""
    from dataclasses import replace

    from multimorph.errors import SpecError
    from multimorph.fe import resolve_density

    dens = resolve_density(mesh, size)
    if wall_elements is None:
        return dens
    if wall_elements < 1:
        raise SpecError(f"--wall-elements: expected at least 1 element through each wall, "
                        f"got {wall_elements}")
    return replace(dens, wall_elements=int(wall_elements))


def _run_note(stats: dict[str, Any], ck: Any) -> str:
    n = int(stats.get("resumed_points", 0))
    k = int(stats.get("restarts", 0))
    return ((f"; resumed from {n} saved points" if n else "")
            + (f"; continuation restarted {k}× where it had turned round" if k else ""))


def fem(
    spec: Annotated[Path, typer.Argument(
        help="Cell spec (TOML) with a [cell] table, or a device spec with [device] and "
             "[[module]] tables.")],
    mesh: Annotated[str, typer.Option(help="Mesh density: coarse, medium or fine.")
                    ] = "coarse",
    element_size: Annotated[str | None, typer.Option(
        help="Explicit element edge length, e.g. '1 mm' (overrides the preset's size).")
                            ] = None,
    wall_elements: Annotated[int | None, typer.Option(
        "--wall-elements", help="Elements through the thickness of every wall (overrides "
                                "the preset's 2, 3 or 4; 1 for a quick, stiffer look at a "
                                "large device or twisting module).")] = None,
    pmax: Annotated[str | None, typer.Option(
        help="Highest pressure, e.g. '60 kPa' (default: the wall shear modulus).")] = None,
    method: Annotated[str, typer.Option(
        help="auto (pressure steps, arc-length past stalls), pressure or arc-length.")
                      ] = "auto",
    solver: Annotated[str, typer.Option(help="Linear solver: auto, pardiso or superlu.")
                      ] = "auto",
    full: Annotated[bool, typer.Option("--full", help="Mesh the whole cell (or series "
                                                        "device), not half.")
                    ] = False,
    cells: Annotated[int, typer.Option(
        "--cells", help="Cells in series along the axis (a bending or stretching module "
                        "mounted at one end); 1: a single cell.")] = 1,
    tilt: Annotated[str | None, typer.Option(
        help="Tilt the chambers in the strip plane by this angle, e.g. '30 deg' (a twisting "
             "strip; full model): the strip's shear is measured, and with --compare set "
             "against the reduced model's twisting kinematics.")] = None,
    vtu: Annotated[bool, typer.Option(help="Write the VTU time series for ParaView.")
                   ] = True,
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Output folder (default multimorph-out/fem-<spec name>).")] = None,
    compare: Annotated[bool, typer.Option(
        "--compare", help="Also run the reduced model and report Pc, Ph, κ(P) side by side.")
                       ] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the JSON summary.")] = False,
    module: Annotated[str | None, typer.Option(
        "--module", help="Device spec: run FE of this one module, clamped at its start (a "
                         "twisting module: its strips around the shaft; a bending or "
                         "stretching module: one copy as a one-module device).")] = None,
    restart: Annotated[bool, typer.Option(
        "--restart", help="Ignore the points an interrupted run of this command kept in "
                          "<out>.resume and start afresh.")] = False,
) -> None:
    """Inflate a cell (or a module of --cells cells in series) with 3D FE: path, Pc/Ph,
    curves, VTU series, STEP/STL. A device spec ([device], [[module]]: bending, stretching
    and twisting modules in series at any orientation, parallel branches such as fingers on
    a rigid hub) is
    meshed and inflated as one problem, each module (and each copy) measured on its own
    (Pc, Ph, bend and twist angle, stretch).

    Example: multimorph fem examples/fe_cell.toml --mesh medium --pmax "60 kPa" --out out/fe

    With --compare the reduced model runs on the same spec and comparison.json holds Pc, Ph
    and κ(P) of both (per module for a device) with relative differences (rom − fe)/fe.

    With --module NAME (device spec) only that module runs: a twisting module as its strips
    around the shaft, measured by the twist angle of its free end; --compare sets the twist
    angle, axial stretch, Pc and Ph against the reduced model's module strains.

    Interrupting (Ctrl-C) keeps every converged point in <out>.resume; the same command
    again resumes from them (--restart starts afresh). The folder goes once the results
    are written.
    """

    from multimorph.errors import SpecError
    from multimorph.fe import FESettings, simulate_cell
    from multimorph.fe._output import summary, write_fe_outputs
    from multimorph.geometry import CellGeometry
    from multimorph.io import atomic_output_dir, load_toml
    from multimorph.units import to_angle, to_si

    with handle_errors(as_json):
        table = load_toml(spec)
        options = {"mesh": mesh, "element_size": element_size,
                   "wall_elements": wall_elements, "pmax": pmax,
                   "method": method, "solver": solver, "full": full, "cells": cells,
                   "tilt": tilt, "module": module}
        if module is not None:
            if "device" not in table:
                raise SpecError(f"--module: applies to a device spec ([device] and [[module]] "
                                f"tables); {spec} has none")
            if cells != 1 or tilt is not None:
                raise SpecError(f"--{'cells' if cells != 1 else 'tilt'}: applies to a cell "
                                f"spec; with --module the module table gives them")
            _fem_module(spec, table, module, mesh=mesh, element_size=element_size,
                        wall_elements=wall_elements, pmax=pmax,
                        method=method, solver=solver, full=full, vtu=vtu, out=out,
                        compare=compare, as_json=as_json, options=options, restart=restart)
            return
        if "device" in table:
            if cells != 1:
                raise SpecError("--cells: applies to a cell spec; a device spec gives the "
                                "cells of each module in its module table")
            if tilt is not None:
                raise SpecError("--tilt: applies to a cell spec; FE devices take bending "
                                "and stretching modules only")
            _fem_device(spec, table, mesh=mesh, element_size=element_size,
                        wall_elements=wall_elements, pmax=pmax,
                        method=method, solver=solver, full=full, vtu=vtu, out=out,
                        compare=compare, as_json=as_json, options=options, restart=restart)
            return
        if "cell" not in table:
            raise SpecError(f"{spec}: missing [cell] table (or a device table with modules)")
        geometry = CellGeometry.from_spec(table["cell"])
        if cells < 1:
            raise SpecError(f"--cells: expected a positive number of cells, got {cells}")
        p_max = to_si(pmax, "Pa", field="--pmax") if pmax else None
        size = to_si(element_size, "m", field="--element-size") if element_size else None
        beta = to_angle(tilt, field="--tilt") if tilt is not None else 0.0
        if tilt is not None:
            from multimorph.fe._mesh import MAX_TILT

            if not (math.isfinite(beta) and 0.0 < abs(beta) < MAX_TILT):
                raise SpecError(f"--tilt: expected an angle with 0 < |tilt| < "
                                f"{math.degrees(MAX_TILT):.0f} deg, got {tilt!r}")
        # a tilted strip has no mirror plane: always the full model
        settings = FESettings(mesh=_density(mesh, size, wall_elements), half=not (full or beta),
                              p_max=p_max, method=method, solver=solver)
        p_end = p_max if p_max is not None else geometry.mu
        folder = out if out is not None else Path("multimorph-out") / f"fem-{spec.stem}"
        ck = _checkpoint(spec, folder, options, restart)
        with _resumable(ck, as_json), _progress("fem", p_end, as_json) as progress:
            result = simulate_cell(geometry, settings, progress=progress, n_cells=cells,
                                   tilt=beta, checkpoint=ck)
        info = summary(result)
        comparison = None
        shear = None
        if compare and beta:
            from multimorph.fe._compare import compare_shear_responses
            from multimorph.rom import simulate_cell as rom_simulate

            shear = compare_shear_responses(rom_simulate(geometry, p_end), result.response,
                                            geometry, beta)
            info["shear_comparison"] = shear.to_dict()
        elif compare:
            from multimorph.fe._compare import compare_responses
            from multimorph.rom import simulate_cell as rom_simulate

            comparison = compare_responses(rom_simulate(geometry, p_end), result.response)
            info["comparison"] = comparison.to_dict()
        with atomic_output_dir(folder) as tmp:
            info["files"] = write_fe_outputs(result, tmp, vtu=vtu)
            if comparison is not None or shear is not None:
                from multimorph.io import write_json

                write_json(tmp / "comparison.json", (comparison or shear).to_dict())
                info["files"].append("comparison.json")
        ck.clear()
        info["out"] = str(folder)
        if as_json:
            emit_json(info)
            return
        c = result.response.characteristic
        st = result.stats

        def kpa(v: float | None) -> str:
            return "—" if v is None else f"{v / 1e3:.3g} kPa"

        what = "FE cell" if cells == 1 else f"FE module of {cells} cells"
        if beta:
            what = f"FE tilted strip of {cells} cell{'s' if cells > 1 else ''}"
        console.print(f"[bold]{what}[/] {st['nfree']} DOF, {st['points']} points, "
                      f"{st['newton_iterations']} Newton iterations, {st['solver']}, "
                      f"{st['wall_time']:.1f} s ({st['stop_reason'] or st['status']})"
                      f"{_run_note(st, ck)}")
        console.print(f"Pc = {kpa(c.critical)} ({c.critical_kind}), Ph = {kpa(c.hardening)}, "
                      f"failure = {kpa(c.failure)}")
        fin = info["final"]
        console.print(f"at {fin['pressure_pa'] / 1e3:.3g} kPa: κd = "
                      f"{fin['curvature_1_per_m'] * geometry.length:.3f} per cell, bend "
                      f"{fin['bend_angle_deg']:.1f}°, V/V0 = {fin['volume_ratio']:.2f}, "
                      f"peak stretch {fin['peak_stretch']:.2f}")
        if beta:
            ex = result.response.path.extra
            console.print(f"tilted strip (β = {math.degrees(beta):.3g}°): shear γ = "
                          f"{ex['shear'][-1]:+.4f}, axial strain "
                          f"{ex['strip_axial_strain'][-1]:+.4f} at the highest pressure")
        if shear is not None:
            mid = len(shear.pressure) // 2
            console.print(f"ROM twisting kinematics vs FE: γ_fe/γ_rom = "
                          f"{shear.ratio[mid]:.3g} at {shear.pressure[mid] / 1e3:.3g} kPa, "
                          f"{shear.ratio[-1]:.3g} at {shear.pressure[-1] / 1e3:.3g} kPa")
        if comparison is not None:
            def rel(v: float | None) -> str:
                return "—" if v is None else f"{100 * v:+.1f} %"

            console.print(f"ROM vs FE: Pc {kpa(comparison.pc_rom)} vs {kpa(comparison.pc_fe)}"
                          f" ({rel(comparison.pc_rel)}), Ph {kpa(comparison.ph_rom)} vs "
                          f"{kpa(comparison.ph_fe)} ({rel(comparison.ph_rel)}), " + (
                              f"on the axial stretch, max |Δλ|/(λ − 1) "
                              f"{rel(comparison.stretch_rel_max)}"
                              if comparison.signal == "axial_stretch" else
                              f"max |Δκ|/κ {rel(comparison.kappa_rel_max)}"))
        console.print(f"files in {folder}/")


def _fem_device(spec: Path, table: dict[str, Any], *, mesh: str, element_size: str | None,
                wall_elements: int | None = None,
                pmax: str | None, method: str, solver: str, full: bool, vtu: bool,
                out: Path | None, compare: bool, as_json: bool, device: Any = None,
                options: dict[str, Any] | None = None, restart: bool = False) -> None:
    """``multimorph fem DEVICE.toml``: parse, run :func:`multimorph.fe.simulate_device`,
    write the files, print the per-module table (``device``: run this one instead of the
    spec's)."""

    from multimorph.device import device_from_spec
    from multimorph.fe import FESettings, compare_device, fe_device_branches, simulate_device
    from multimorph.fe._device import plot_device, write_device_vtu
    from multimorph.fe._device_mesh import device_pieces
    from multimorph.fe._output import export_box_pieces, hex_boundary, write_surface_stl
    from multimorph.io import atomic_output_dir, write_json
    from multimorph.units import to_si

    device = device if device is not None else device_from_spec(table)
    fe_device_branches(device)  # refuse what FE cannot mesh before any work
    p_max = to_si(pmax, "Pa", field="--pmax") if pmax else device.pmax
    size = to_si(element_size, "m", field="--element-size") if element_size else None
    settings = FESettings(mesh=_density(mesh, size, wall_elements), half=not full, p_max=p_max,
                          method=method, solver=solver)
    folder = out if out is not None else Path("multimorph-out") / f"fem-{spec.stem}"
    ck = _checkpoint(spec, folder, options or {}, restart)
    with _resumable(ck, as_json), _progress("fem device", p_max, as_json) as progress:
        result = simulate_device(device, settings, progress=progress, checkpoint=ck)
    comparison = None
    if compare:  # the reduced-model device to 2 × p_max (it is stiffer than FE)
        comparison = compare_device(result)
    info: dict[str, Any] = {"backend": "fe", "device": result.to_dict(paths=False)}
    if comparison is not None:
        info["comparison"] = comparison
    with atomic_output_dir(folder) as tmp:
        files = ["summary.json", "curves.csv", "tip.csv"]
        write_json(tmp / "summary.json", {"backend": "fe", "device": result.to_dict()})
        with open(tmp / "curves.csv", "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["module", "pressure_pa", "bend_angle_deg", "curvature_1_per_m",
                        "axial_stretch", "chamber_volume_m3", "volume_ratio", "peak_stretch",
                        "stable", "twist_angle_deg", "twist_rate_rad_per_m"])
            for name, r in result.responses.items():
                p = r.path
                cols = (p.pressure, math.degrees(1.0) * p.extra["bend_angle"], p.curvature,
                        p.axial_stretch, p.volume, p.extra["volume_ratio"], p.peak_stretch)
                tw = (math.degrees(1.0) * p.extra["twist_angle"], p.twist_rate)
                for i in range(len(p)):
                    w.writerow([name, *(f"{c[i]:.8g}" for c in cols), int(p.stable[i]),
                                *(f"{c[i]:.8g}" for c in tw)])
        with open(tmp / "tip.csv", "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["pressure_pa", "tip_x_m", "tip_y_m", "tip_z_m", "tip_angle_deg",
                        "stable"])
            for P, t, a, st in zip(result.pressure, result.tip, result.tip_angle,
                                   result.stable, strict=True):
                w.writerow([f"{P:.8g}", *(f"{v:.8g}" for v in t), f"{math.degrees(a):.8g}",
                            int(st)])
        if comparison is not None:
            write_json(tmp / "comparison.json", comparison)
            files.append("comparison.json")
        files += plot_device(result, tmp)
        if all(m.kind != "twisting" for m in device.modules):
            pieces = device_pieces(device)
            edge = min(min(b[3:]) for outer, inner, _ in pieces for b in [*outer, *inner]) / 2
            for name in ("device.step", "device.stl"):
                export_box_pieces(pieces, tmp / name, edge)
                files.append(name)
        else:  # tilted strips on a shaft are not boxes: the STL is the FE mesh's surface
            m = result.mesh
            write_surface_stl(m.points, hex_boundary(m.cells), tmp / "device.stl",
                              name=device.name)
            files.append("device.stl")
            info["cad"] = ("device.step not written (a twisting module's solid is not a union "
                           "of boxes); device.stl is the undeformed FE mesh's surface")
        if vtu:
            files += write_device_vtu(result, tmp)
        info["files"] = files
    ck.clear()
    info["out"] = str(folder)
    if as_json:
        emit_json(info)
        return
    st = result.stats

    def kpa(v: float | None) -> str:
        return "—" if v is None else f"{v / 1e3:.3g}"

    console.print(f"[bold]FE device[/] {device.name}: {len(result.responses)} modules, "
                  f"{st['nfree']} DOF, {st['points']} points, {st['newton_iterations']} Newton "
                  f"iterations, {st['solver']}, {st['wall_time']:.1f} s "
                  f"({st['stop_reason'] or st['status']}){_run_note(st, ck)}",
                  highlight=False)
    head = (f"  {'module':<10} {'kind':<10} {'Pc':>6} {'Ph':>6} {'at P':>6} {'bend°':>6} "
            f"{'twist°':>6} {'stretch':>7}")
    if comparison is not None:
        head += f"  {'ROM Pc':>6} {'rel':>5} {'Ph':>6} {'rel':>5}"
    console.print("modules (Pc, Ph in kPa, — not reached; bend towards the stiff layer, twist "
                  "about the axis and centroid stretch at P, the top of the module's stable "
                  "loading curve):", highlight=False)
    console.print(head, highlight=False, soft_wrap=True)
    for m in result.mesh.modules:
        pc, ph = result.activation(m.name)
        at = result.module_at(m.name)
        kind = f"{m.kind[:7]} {math.degrees(m.orientation):.0f}°"
        line = (f"  {m.name[:10]:<10} {kind:<10} {kpa(pc):>6} {kpa(ph):>6} "
                f"{kpa(at['pressure']):>6} {math.degrees(at['bend_angle']):>6.1f} "
                f"{math.degrees(at['twist_angle']):>6.1f} {at['axial_stretch']:>7.3f}")
        if comparison is not None:
            k = comparison[m.name]
            line += (f"  {kpa(k['pc_rom']):>6} {_pct(k['pc_rel']):>5} {kpa(k['ph_rom']):>6} "
                     f"{_pct(k['ph_rel']):>5}")
        console.print(line, highlight=False, soft_wrap=True)
    fin = {m.name: info["device"]["modules"][m.name]["final"] for m in result.mesh.modules}
    worst = max(fin, key=lambda k: fin[k]["peak_stretch"])
    w = fin[worst]
    console.print(f"peak principal stretch {w['peak_stretch']:.3f} at "
                  f"{w['pressure_pa'] / 1e3:.3g} kPa in module {worst!r} ({w['peak_region']}, "
                  f"at x, y, z = {', '.join(f'{v * 1e3:.1f}' for v in w['peak_location_m'])} mm "
                  f"undeformed)", highlight=False)
    for hub in info["device"].get("hubs", []):
        console.print(f"hub at the end of {hub['parent']!r} (rigid, {hub['tied_nodes']} nodes "
                      f"tied): turned {hub['final_rotation_deg']:.1f}°, carries "
                      f"{', '.join(hub['children'])}", highlight=False)
    where = " (end of the clamped branch)" if result.mesh.hubs else ""
    console.print(f"tip{where} at {result.pressure[-1] / 1e3:.3g} kPa: y = "
                  f"{result.tip[-1, 1] * 1e3:.2f} mm, z = {result.tip[-1, 2] * 1e3:.2f} mm, "
                  f"angle {math.degrees(result.tip_angle[-1]):.1f}°", highlight=False)
    if "cad" in info:
        console.print(info["cad"], highlight=False)
    console.print(f"files in {folder}/")


def _fem_module(spec: Path, table: dict[str, Any], name: str, *, mesh: str,
                element_size: str | None, pmax: str | None, method: str, solver: str,
                wall_elements: int | None = None,
                full: bool, vtu: bool, out: Path | None, compare: bool, as_json: bool,
                options: dict[str, Any] | None = None, restart: bool = False) -> None:
    """``multimorph fem DEVICE.toml --module NAME``: one module of a device spec, clamped at
    its start. Twisting: :func:`multimorph.fe.simulate_twisting_module`; bending and
    stretching: one copy of the module as a one-module device (the device route)."""
    from dataclasses import replace

    from multimorph.device import Device, device_from_spec
    from multimorph.errors import SpecError
    from multimorph.fe import (
        FE_MODULE_KINDS,
        FESettings,
        compare_twisting,
        simulate_twisting_module,
    )
    from multimorph.fe._twist import plot_twist, write_twist_csv, write_twist_vtu
    from multimorph.io import atomic_output_dir, write_json
    from multimorph.units import to_si

    device = device_from_spec(table)
    names = [m.name for m in device.modules]
    if name not in names:
        raise SpecError(f"--module: no module named {name!r} in {spec} (modules: "
                        f"{', '.join(names)})")
    mod = device.module(name)
    if mod.kind in FE_MODULE_KINDS:
        one = Device((replace(mod, start=0.0, attach_to=None, branch="main", count=1,
                              radius=0.0),), name=f"{device.name}: {name}", pmax=device.pmax)
        _fem_device(spec, table, mesh=mesh, element_size=element_size,
                    wall_elements=wall_elements, pmax=pmax,
                    method=method, solver=solver, full=full, vtu=vtu, out=out,
                    compare=compare, as_json=as_json, device=one, options=options,
                    restart=restart)
        return
    if mod.kind != "twisting":
        raise SpecError(f"module {name!r}.kind: {mod.kind!r} is not supported by FE (twisting, "
                        f"{', '.join(FE_MODULE_KINDS)})")
    p_max = to_si(pmax, "Pa", field="--pmax") if pmax else device.pmax
    size = to_si(element_size, "m", field="--element-size") if element_size else None
    settings = FESettings(mesh=_density(mesh, size, wall_elements), half=False, p_max=p_max,
                          method=method, solver=solver)
    folder = out if out is not None else Path("multimorph-out") / f"fem-{spec.stem}-{name}"
    ck = _checkpoint(spec, folder, options or {}, restart)
    with _resumable(ck, as_json), _progress("fem module", p_max, as_json) as progress:
        result = simulate_twisting_module(mod, settings, p_max=p_max, progress=progress,
                                          checkpoint=ck)
    comparison = compare_twisting(result) if compare else None
    info: dict[str, Any] = {"backend": "fe", "module": result.to_dict(paths=False)}
    if comparison is not None:
        info["comparison"] = comparison
    with atomic_output_dir(folder) as tmp:
        files = ["summary.json", "path.csv"]
        write_json(tmp / "summary.json", {"backend": "fe", "module": result.to_dict()})
        write_twist_csv(result, tmp / "path.csv")
        if comparison is not None:
            write_json(tmp / "comparison.json", comparison)
            files.append("comparison.json")
        files += plot_twist(result, tmp)
        if vtu:
            files += write_twist_vtu(result, tmp)
        info["files"] = files
    ck.clear()
    info["out"] = str(folder)
    if as_json:
        emit_json(info)
        return
    st = result.stats
    pc, ph = result.activation()

    def kpa(v: float | None) -> str:
        return "—" if v is None else f"{v / 1e3:.3g} kPa"

    console.print(f"[bold]FE twisting module[/] {name}: {mod.strips} strips of {mod.n_cells} "
                  f"cell{'s' if mod.n_cells > 1 else ''}, tilt {math.degrees(mod.tilt):.3g}°, "
                  f"{st['nfree']} DOF, "
                  f"{st['points']} points, {st['newton_iterations']} Newton iterations, "
                  f"{st['solver']}, {st['wall_time']:.1f} s "
                  f"({st['stop_reason'] or st['status']}){_run_note(st, ck)}",
                  highlight=False)
    fin = info["module"]["final"]
    console.print(f"Pc = {kpa(pc)}, Ph = {kpa(ph)} (on the twist rate); at "
                  f"{fin['pressure_pa'] / 1e3:.3g} kPa: twist {fin['twist_angle_deg']:+.2f}° "
                  f"(right-handed about the axis), axial stretch {fin['axial_stretch']:.4f}, "
                  f"V/V0 = {fin['volume_ratio']:.2f}; peak principal stretch "
                  f"{fin['peak_stretch']:.3f} ({fin['peak_region']}, at x, y, z = "
                  f"{', '.join(f'{v * 1e3:.1f}' for v in fin['peak_location_m'])} mm "
                  f"undeformed)", highlight=False)
    if comparison is not None:
        c = comparison
        console.print(f"ROM vs FE (twist in the sense of the tilt): Pc {kpa(c['pc_rom'])} vs "
                      f"{kpa(c['pc_fe'])} ({_pct(c['pc_rel'])})", highlight=False)
        for P, a, b, la, lb in zip(c["pressure_pa"], c["twist_deg_rom"], c["twist_deg_fe"],
                                   c["stretch_rom"], c["stretch_fe"], strict=True):
            console.print(f"  {P / 1e3:6.3g} kPa: twist {a:7.2f}° vs {b:7.2f}°, stretch "
                          f"{la:.4f} vs {lb:.4f}", highlight=False)
    console.print(f"files in {folder}/")


def _pct(v: float | None) -> str:
    return "—" if v is None else f"{100 * v:+.0f}%"


def register(app: typer.Typer) -> None:
    app.command("fem")(fem)
