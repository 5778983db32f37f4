"""``multimorph cell``: one unit cell (κ(P), Pc, Ph, plots) by the chosen cell model."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from multimorph.cli._common import (
    check_tables,
    console,
    default_out,
    emit_json,
    handle_errors,
    in_file,
    pressure_option,
)
from multimorph.cli._help import PlainHelpCommand

__all__ = ["cell", "cell_summary", "register"]

#: Files written into the output folder.
FILES = ("response.json", "curvature.png")


def cell_summary(response: Any) -> dict[str, Any]:
    """The JSON document of ``multimorph cell`` (SI units; null where not reached)."""
    import numpy as np

    path = response.path
    ch = response.characteristic
    d = response.length
    return {
        "pressure": path.pressure.tolist(),
        "curvature": path.curvature.tolist(),
        "bend_angle": (path.curvature * d).tolist(),
        "stable": path.stable.astype(bool).tolist(),
        "critical_pressure": ch.critical,
        "hardening_pressure": ch.hardening,
        "failure_pressure": ch.failure,
        "critical_kind": ch.critical_kind,
        "curvature_at": dict(ch.curvature_at),
        "signal": ch.signal,
        "axial_stretch": path.axial_stretch.tolist(),
        "shear_modulus": response.shear_modulus,
        "length": d,
        "volume": path.volume.tolist(),
        "peak_stretch": path.peak_stretch.tolist(),
        "loading": {"pressure": response.loading.pressure.tolist(),
                    "curvature": response.loading.curvature.tolist()},
        "unloading": {"pressure": response.unloading.pressure.tolist(),
                      "curvature": response.unloading.curvature.tolist()},
        "max_bend_angle": float(np.max(path.curvature * d)),
        "max_bend_angle_deg": float(np.degrees(np.max(path.curvature * d))),
        "backend": response.backend,
        "model": response.meta.get("model", response.backend),
        **({"calibration": response.meta["calibration"]}
           if "calibration" in response.meta else {}),
        **({"runaway": response.meta["runaway"]} if "runaway" in response.meta else {}),
    }


def _disagreement(anchors: dict[str, Any]) -> str:
    """A note where the calibrated model left its Pc anchor out because it disagrees with
    the path's own reading by more than its kind's factor (``_anchor.max_factor``; its band
    then spans both: ``_model.unused_anchor_band``): on such cells the model's Pc can be
    off severalfold either way (docs/validation.md §4, stop 44)."""
    from multimorph.calibrated._anchor import readings_disagree

    if not readings_disagree(anchors):
        return ""
    own, anchor = anchors["path_critical_pressure"], anchors["critical_pressure"]
    return (f"; its path reads Pc {own / 1e3:.3g} kPa, its anchor {anchor / 1e3:.3g} kPa: "
            "the two disagree, so Pc is uncertain here")


def _law_note(law: dict[str, Any] | None) -> str:
    """How a wall of another law than Gent was placed in the calibrated model
    (``calibration.law``, :mod:`multimorph.calibrated._law`)."""
    wall = (law or {}).get("wall")
    if not wall:
        return ""
    if wall.get("rule") == "yeoh-shape map":
        return (f"; its {wall['model']} wall (c20/c10 {wall['shape_c20_c10']:.3g}) answered "
                f"as a Gent wall of {wall['mu_factor']:.3g} × its μ and Jm "
                f"{wall['effective_jm']:.3g} (the law map fitted on FE of Yeoh-walled cells; "
                "docs/validation.md §2, Other laws)")
    return (f"; its {wall['model']} wall answered as the closest Gent wall (Jm "
            f"{wall['effective_jm']:.3g}): a law the model was not calibrated on")


def model_line(data: dict[str, Any]) -> str:
    """Which model produced a cell result, and how far that model is from 3D FE."""
    name = data.get("model", data.get("backend"))
    cal = data.get("calibration") or {}
    if name in ("calibrated", "calibrated-fast"):
        lo, hi = cal.get("critical_pressure_range") or (None, None)
        band = (f"; Pc within {lo / 1e3:.3g} … {hi / 1e3:.3g} kPa (±1σ)"
                if lo is not None and hi is not None else "")
        band += _disagreement(cal.get("anchors") or {})
        band += _law_note(cal.get("law"))
        act = cal.get("activation") or {}
        if act.get("activates") is False:
            band += f"; no activation: {act.get('reason', '')}"
        how = ("Ritz corrected against 3D FE" if name == "calibrated" else
               "Ritz corrected against 3D FE, on emulated Ritz features")
        return f"{name} ({how}; held-out error in docs/validation.md){band}"
    if name in ("ritz", "rom"):
        why = (f" — outside the calibrated model's support ({cal['reason']})"
               if cal.get("inside") is False else "")
        return f"ritz (reduced model; Pc about 2 × the 3D FE's){why}"
    return str(name)


def _plot(response: Any, file: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    p, r = response.path, response
    ch = r.characteristic
    mu, d = r.shear_modulus, r.length
    stretch = ch.signal == "axial_stretch"      # a symmetric cell: plot what activates
    sig, scale = ("axial_stretch", 1.0) if stretch else ("curvature", d)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    a1.plot(p.pressure / 1e3, getattr(p, sig), "-", color="0.6", lw=1,
            label="equilibrium path")
    a1.plot(r.loading.pressure / 1e3, getattr(r.loading, sig), "C0-", lw=2, label="loading")
    a2.plot(p.pressure / mu, getattr(p, sig) * scale, "C0-", lw=2, label="equilibrium path")
    for key, value, color in (("Pc", ch.critical, "C3"), ("Ph", ch.hardening, "C2")):
        if value is None:
            continue
        kap = (float(np.interp(value, r.loading.pressure, r.loading.axial_stretch))
               if stretch else ch.curvature_at["critical" if key == "Pc" else "hardening"])
        a1.axvline(value / 1e3, color=color, ls="--", lw=1)
        a1.plot([value / 1e3], [kap], "o", color=color, label=f"{key} = {value / 1e3:.3g} kPa")
        a2.axvline(value / mu, color=color, ls="--", lw=1)
        a2.plot([value / mu], [kap * scale], "o", color=color,
                label=f"{key}/μ = {value / mu:.3g}")
    a1.set(xlabel="pressure P (kPa)",
           ylabel="axial stretch λ (-)" if stretch else "curvature κ (1/m)", title=title)
    a2.set(xlabel="P/μ (-)", ylabel="λ (-)" if stretch else "κd (-)", title="dimensionless")
    a1.legend(fontsize=8)
    a2.legend(fontsize=8)
    fig.savefig(file, dpi=120)
    plt.close(fig)


def cell(
    spec: Annotated[Path, typer.Argument(help="Cell spec (TOML) with a [cell] table.")],
    pmax: Annotated[str | None, typer.Option(
        help="Highest pressure, e.g. '60 kPa' (default: the wall shear modulus).")] = None,
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Output folder (default multimorph-out/cell-<spec name>).")
                   ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the JSON summary.")] = False,
    model: Annotated[str | None, typer.Option(
        "--model", help="Cell model: calibrated-fast (the default: Ritz corrected "
                        "against 3D FE, on emulated Ritz features; ~1 ms a cell), calibrated "
                        "(the same with a Ritz trace per cell: a first call of ~45 s), ritz "
                        "(alias rom: the reduced model, about twice as stiff "
                        "as FE) or fe (3D FE, minutes). Default: "
                        "multimorph.models.DEFAULT_MODEL.")] = None,
) -> None:
    """A unit cell by the chosen cell model: κ(P), Pc, Ph and a plot.

    Example: multimorph cell examples/cell.toml --pmax "300 kPa" --out out/cell

    Writes response.json (the --json document) and curvature.png (κ(P) and κd vs P/μ with
    Pc and Ph marked) atomically into the output folder.
    """
    from multimorph.errors import SpecError
    from multimorph.geometry import CellGeometry
    from multimorph.io import atomic_output_dir, claim_output, load_toml, write_json
    from multimorph.models import cell_model, model_name

    with handle_errors(as_json):
        # everything is checked before the model runs
        name = model_name(model, field="--model")
        table = load_toml(spec)
        check_tables(table, ("cell",), spec)
        if "cell" not in table:
            raise SpecError(f"{spec}: missing [cell] table")
        with in_file(spec):
            geometry = CellGeometry.from_spec(table["cell"])
        p_max = (geometry.mu if pmax is None
                 else pressure_option(pmax, "--pmax", mu=geometry.mu))
        folder = out if out is not None else default_out("cell", spec)
        with claim_output(folder, files=FILES):
            response = cell_model(name)(geometry, p_max)
            data = cell_summary(response)
            with atomic_output_dir(folder) as tmp:
                write_json(tmp / "response.json", data)
                _plot(response, tmp / "curvature.png", spec.stem)
    if as_json:
        emit_json(data)
        return
    ch = response.characteristic
    mu = response.shear_modulus

    def kpa(v: float | None) -> str:
        return "not reached" if v is None else f"{v / 1e3:.4g} kPa (P/μ = {v / mu:.3g})"

    console.print(f"[bold]cell[/] {spec} — μ = {mu / 1e3:.4g} kPa, d = "
                  f"{response.length * 1e3:.4g} mm, {len(response.path)} path points up to "
                  f"{p_max / 1e3:.4g} kPa")
    console.print(f"  model: {model_line(data)}", highlight=False)
    kind = f" ({ch.critical_kind})" if ch.critical_kind else ""
    none = (((data.get("calibration") or {}).get("activation") or {}).get("activates")
            is False)
    console.print(f"  critical pressure Pc{kind}: "
                  f"{'none (no knee: see the model line)' if none else kpa(ch.critical)}")
    console.print(f"  hardening pressure Ph: {'none' if none else kpa(ch.hardening)}")
    console.print(f"  failure pressure: {kpa(ch.failure)}")
    if "runaway" in data:
        console.print(f"  runaway at Pc: {data['runaway']['reason']}", highlight=False)
    if ch.signal == "axial_stretch":
        console.print(f"  symmetric (stretching) cell: Pc and Ph read on the axial stretch; "
                      f"max axial stretch {max(data['axial_stretch']):.4g}")
    else:
        console.print(f"  max curvature {max(data['curvature']):.4g} 1/m, bend angle "
                      f"{data['max_bend_angle_deg']:.3g} deg per cell")
    console.print(f"  files in {folder}: {', '.join(FILES)}", highlight=False)


def register(app: typer.Typer) -> None:
    app.command("cell", cls=PlainHelpCommand)(cell)
