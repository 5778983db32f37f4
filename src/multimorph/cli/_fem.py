"""``multimorph fem``: 3D finite-element analysis of a unit cell (FElupe)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from multimorph.cli._common import console, emit_json, err_console, handle_errors

__all__ = ["fem", "register"]


def fem(
    spec: Annotated[Path, typer.Argument(help="Cell spec (TOML) with a [cell] table.")],
    mesh: Annotated[str, typer.Option(help="Mesh density: coarse, medium or fine.")
                    ] = "coarse",
    element_size: Annotated[str | None, typer.Option(
        help="Explicit element edge length, e.g. '1 mm' (overrides the preset's size).")
                            ] = None,
    pmax: Annotated[str | None, typer.Option(
        help="Highest pressure, e.g. '60 kPa' (default: the wall shear modulus).")] = None,
    method: Annotated[str, typer.Option(
        help="auto (pressure steps, arc-length past stalls), pressure or arc-length.")
                      ] = "auto",
    solver: Annotated[str, typer.Option(help="Linear solver: auto, pardiso or superlu.")
                      ] = "auto",
    full: Annotated[bool, typer.Option("--full", help="Mesh the whole cell, not half.")
                    ] = False,
    cells: Annotated[int, typer.Option(
        "--cells", help="Cells in series along the axis (a bending or stretching module "
                        "mounted at one end); 1: a single cell.")] = 1,
    vtu: Annotated[bool, typer.Option(help="Write the VTU time series for ParaView.")
                   ] = True,
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Output folder (default multimorph-out/fem-<spec name>).")] = None,
    compare: Annotated[bool, typer.Option(
        "--compare", help="Also run the reduced model and report Pc, Ph, κ(P) side by side.")
                       ] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the JSON summary.")] = False,
) -> None:
    """Inflate a cell (or a module of --cells cells in series) with 3D FE: path, Pc/Ph,
    curves, VTU series, STEP/STL.

    Example: multimorph fem examples/fe_cell.toml --mesh medium --pmax "60 kPa" --out out/fe

    With --compare the reduced model runs on the same spec and comparison.json holds Pc, Ph
    and κ(P) of both with relative differences (rom − fe)/fe.
    """
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from multimorph.errors import SpecError
    from multimorph.fe import FESettings, simulate_cell
    from multimorph.fe._output import summary, write_fe_outputs
    from multimorph.geometry import CellGeometry
    from multimorph.io import atomic_output_dir, load_toml
    from multimorph.units import to_si

    with handle_errors(as_json):
        table = load_toml(spec)
        if "cell" not in table:
            raise SpecError(f"{spec}: missing [cell] table")
        geometry = CellGeometry.from_spec(table["cell"])
        if cells < 1:
            raise SpecError(f"--cells: expected a positive number of cells, got {cells}")
        p_max = to_si(pmax, "Pa", field="--pmax") if pmax else None
        size = to_si(element_size, "m", field="--element-size") if element_size else None
        settings = FESettings(mesh=mesh, element_size=size, half=not full, p_max=p_max,
                              method=method, solver=solver)
        p_end = p_max if p_max is not None else geometry.mu
        folder = out if out is not None else Path("multimorph-out") / f"fem-{spec.stem}"
        with Progress(TextColumn("[bold]fem[/]"), BarColumn(),
                      TextColumn("{task.fields[p]:.1f} kPa · {task.fields[n]} points"),
                      TimeElapsedColumn(), console=err_console, transient=True,
                      disable=as_json) as bar:
            task = bar.add_task("fem", total=p_end, p=0.0, n=0)

            def progress(p: float, n: int) -> None:
                bar.update(task, completed=min(max(p, 0.0), p_end), p=p / 1e3, n=n)

            result = simulate_cell(geometry, settings, progress=progress, n_cells=cells)
        info = summary(result)
        comparison = None
        if compare:
            from multimorph.fe._compare import compare_responses
            from multimorph.rom import simulate_cell as rom_simulate

            comparison = compare_responses(rom_simulate(geometry, p_end), result.response)
            info["comparison"] = comparison.to_dict()
        with atomic_output_dir(folder) as tmp:
            info["files"] = write_fe_outputs(result, tmp, vtu=vtu)
            if comparison is not None:
                from multimorph.io import write_json

                write_json(tmp / "comparison.json", comparison.to_dict())
                info["files"].append("comparison.json")
        info["out"] = str(folder)
        if as_json:
            emit_json(info)
            return
        c = result.response.characteristic
        st = result.stats

        def kpa(v: float | None) -> str:
            return "—" if v is None else f"{v / 1e3:.3g} kPa"

        what = "FE cell" if cells == 1 else f"FE module of {cells} cells"
        console.print(f"[bold]{what}[/] {st['nfree']} DOF, {st['points']} points, "
                      f"{st['newton_iterations']} Newton iterations, {st['solver']}, "
                      f"{st['wall_time']:.1f} s ({st['stop_reason'] or st['status']})")
        console.print(f"Pc = {kpa(c.critical)} ({c.critical_kind}), Ph = {kpa(c.hardening)}, "
                      f"failure = {kpa(c.failure)}")
        fin = info["final"]
        console.print(f"at {fin['pressure_pa'] / 1e3:.3g} kPa: κd = "
                      f"{fin['curvature_1_per_m'] * geometry.length:.3f} per cell, bend "
                      f"{fin['bend_angle_deg']:.1f}°, V/V0 = {fin['volume_ratio']:.2f}, "
                      f"peak stretch {fin['peak_stretch']:.2f}")
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


def register(app: typer.Typer) -> None:
    app.command("fem")(fem)
