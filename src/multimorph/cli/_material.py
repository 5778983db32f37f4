"""``multimorph material``: list and show the built-in library, fit a law to test data."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer

from multimorph.cli._common import console, default_out, emit_json, handle_errors, warn
from multimorph.cli._help import PlainHelpCommand, PlainHelpGroup

__all__ = ["material_app", "register"]

#: Files ``material fit`` writes into its output folder.
FIT_FILES = ("fit.json", "fit.png")

material_app = typer.Typer(
    cls=PlainHelpGroup,
    help="Hyperelastic materials: the built-in library and fits to tensile data.\n\n"
         "Example: multimorph material show dragon-skin-30",
    no_args_is_help=True,
)


def _fmt_param(value: float, unit: str) -> str:
    if unit != "Pa":
        return f"{value:.4g}"
    return f"{value / 1e3:.4g} kPa"  # kPa throughout (silicones: tens to hundreds)


def _fmt_pct(x: float | None) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{100 * x:.1f} %"


@material_app.command("list", cls=PlainHelpCommand)
def material_list(
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON (SI units).")] = False,
) -> None:
    """List the library materials with their Gent parameters and break stretch.

    Example: multimorph material list --json
    """
    from rich.table import Table

    from multimorph.materials.library import get_material, library_entry, list_materials

    with handle_errors(as_json):
        rows: list[dict[str, Any]] = []
        for name in list_materials():
            entry = library_entry(name)
            m = get_material(name)
            stats = entry["models"][m.model].get("stats", {})
            rows.append({
                "name": name, "title": entry["title"], "model": m.model,
                "shear_modulus": m.shear_modulus,
                "jm": m.jm if math.isfinite(m.jm) else None,
                "relative_rms": stats.get("relative_rms"),
                "break_stretch": entry.get("break_stretch"),
                "models": list(entry["models"]), "doi": entry["source"].get("doi"),
            })
        if as_json:
            emit_json({"materials": rows})
            return
        t = Table(title="material library (μ: small-strain shear modulus; Gent fits over "
                        "λ ≤ 4)")
        for col in ("name", "model", "μ", "Jm", "rel. RMS", "λ break"):
            t.add_column(col, no_wrap=True)
        for r in rows:
            t.add_row(r["name"], r["model"], _fmt_param(r["shear_modulus"], "Pa"),
                      "-" if r["jm"] is None else f"{r['jm']:.3g}",
                      _fmt_pct(r["relative_rms"]),
                      "-" if r["break_stretch"] is None else f"{r['break_stretch']:.3g}")
        console.print(t)
        console.print("Every material has more models: multimorph material show NAME; "
                      "Marechal et al. 2021 data, ODbL 1.0.", highlight=False)


def _membrane_words(membrane: dict[str, Any]) -> str:
    """A thin balloon of the law, in words (``calibrated._law.membrane_summary``)."""
    if membrane["limit_point"]:
        return (f"snaps (pressure maximum at hoop stretch {membrane['limit_stretch']:.3g})")
    if membrane["limit_point"] is None:
        return "locks before V/V0 = 25 (a knee, whether or not it snaps)"
    if not membrane["cells_activate"]:
        return ("no pressure maximum up to V/V0 = 25: stretching and tilted cells of it have "
                "no knee (no Pc or Ph; docs/validation.md §2, Other laws)")
    return "no pressure maximum up to V/V0 = 25"


@material_app.command("show", cls=PlainHelpCommand)
def material_show(
    name: Annotated[str, typer.Argument(help="Library name, e.g. dragon-skin-30 "
                                             "(or dragon-skin-30:yeoh).")],
    model: Annotated[str | None, typer.Option(
        "--model", "-m", help="Law: gent (default), yeoh, reduced-polynomial, ogden …")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON (SI units).")] = False,
) -> None:
    """Show a library material: parameters with units, provenance and fit statistics.

    Example: multimorph material show ecoflex-00-30 --model yeoh
    """
    from multimorph.materials.library import get_material, library_entry

    with handle_errors(as_json):
        m = get_material(name, model)
        entry = library_entry(m.name)
        stats = entry["models"][m.model].get("stats")
        from multimorph.calibrated._law import membrane_summary

        membrane = membrane_summary(m)
        if as_json:
            emit_json({"name": m.name, "title": entry["title"], "supplier": entry["supplier"],
                       "material": m.to_dict(), "shear_modulus": m.shear_modulus,
                       "stats": stats, "models": list(entry["models"]),
                       "membrane": membrane})
            return
        law = m.law
        console.print(f"[bold]{m.name}[/] — {entry['title']}"
                      + (f" ({entry['supplier']})" if entry.get("supplier") else ""))
        console.print(f"model: {law.title} ({m.model})"
                      + (f", convention {m.convention}" if m.convention else ""), markup=False)
        for k, u in zip(law.param_names, law.param_units, strict=True):
            console.print(f"  {k:>8} = {_fmt_param(m.params[k], u)}")
        console.print(f"  small-strain shear modulus μ = {_fmt_param(m.shear_modulus, 'Pa')}")
        if m.break_stretch:
            console.print(f"  uniaxial stretch at break = {m.break_stretch:.3g}")
        console.print(f"  balloon: {_membrane_words(membrane)}", highlight=False)
        if stats:
            console.print(f"fit: {stats['status']}, relative RMS {_fmt_pct(stats['relative_rms'])}"
                          f", median relative error {_fmt_pct(stats['median_relative_error'])}, "
                          f"{stats['n_points']} points, Drucker-stable: "
                          f"{all(stats['drucker_stable'].values())}")
        p = m.provenance
        if p is not None:
            console.print(f"source: {p.source}" + (f", doi:{p.doi}" if p.doi else ""),
                          highlight=False)
            for k in ("licence", "data_file", "fit_range", "residual", "note"):
                v = getattr(p, k)
                if v:
                    console.print(f"  {k}: {v}", highlight=False)
        console.print(f"models available: {', '.join(entry['models'])}")


@material_app.command("fit", cls=PlainHelpCommand)
def material_fit(
    file: Annotated[Path, typer.Argument(help="Test data CSV (Marechal format, plain "
                                              "stretch/stress with units, or force-"
                                              "displacement).")],
    model: Annotated[str, typer.Option("--model", "-m", help="Law to fit: gent, yeoh, "
                                       "reduced-polynomial, ogden, mooney-rivlin …")] = "gent",
    order: Annotated[int | None, typer.Option(
        help="Order N for reduced-polynomial (1..6) or ogden (terms).")] = None,
    stretch_max: Annotated[float | None, typer.Option(
        "--range", help="Fit only points with stretch ≤ this (design range), e.g. 4.")] = None,
    case: Annotated[str | None, typer.Option(
        help="Load case of the file's rows (uniaxial, equibiaxial, pure_shear) when it has "
             "no case column.")] = None,
    residual: Annotated[str, typer.Option(help="relative or absolute residuals.")
                        ] = "relative",
    fmt: Annotated[str, typer.Option("--format", help="auto, marechal, plain or force.")
                   ] = "auto",
    gauge_length: Annotated[str | None, typer.Option(
        help="Force files: gauge length with unit (default from the file's comments, else "
             "ASTM D412 die C: 33 mm).")] = None,
    width: Annotated[str | None, typer.Option(
        help="Force files: specimen width with unit (default 6 mm).")] = None,
    thickness: Annotated[str | None, typer.Option(
        help="Force files: specimen thickness with unit (default 3 mm).")] = None,
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Output folder (default multimorph-out/fit-<file stem>).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON (SI units).")] = False,
) -> None:
    """Fit a hyperelastic law to tensile data; write fit.json and fit.png to a folder.

    Example: multimorph material fit dragon_skin_30.csv --model gent --range 4 --json

    Force-displacement files: multimorph material fit pull.csv --gauge-length "25 mm"
    """
    from multimorph.io import atomic_output_dir, claim_output, write_json
    from multimorph.materials import fit_material, read_test_data

    with handle_errors(as_json):
        # everything is checked before the fit runs
        law = _fit_options(model, order, stretch_max, case, residual, fmt)
        specimen = _specimen({"gauge_length": gauge_length, "width": width,
                              "thickness": thickness})
        data = read_test_data(file, case=case, format=fmt, specimen=specimen)
        if stretch_max is not None:
            _check_range(data, law, stretch_max, residual)
        folder = out if out is not None else default_out("fit", file)
        for note in data.notes:
            warn(f"{file}: {note}")
        with claim_output(folder, files=FIT_FILES):
            res = fit_material(model, data, order=order, residual=residual,
                               stretch_range=stretch_max)
            from multimorph.viz._fitplot import plot_fit

            doc = {**res.to_dict(), "data_file": str(file), "warnings": list(data.notes)}
            with atomic_output_dir(folder) as tmp:
                write_json(tmp / "fit.json", doc)
                plot_fit(res, data.curves, tmp / "fit.png")
        files = [str(folder / "fit.json"), str(folder / "fit.png")]
        if as_json:
            emit_json({**doc, "files": files})
            return
        law = res.material.law
        console.print(f"[bold]{res.material.model}[/] fit to {file} "
                      f"({res.n_points} points, {', '.join(res.per_case)}): {res.status}")
        for k, u in zip(law.param_names, law.param_units, strict=True):
            console.print(f"  {k:>8} = {_fmt_param(res.params[k], u)}  "
                          f"± {_fmt_param(res.stderr[k], u)}")
        console.print(f"  μ = {_fmt_param(res.material.shear_modulus, 'Pa')}")
        for c, s in res.per_case.items():
            console.print(f"  {c}: R² = {s.r2:.4f}, relative RMS {_fmt_pct(s.relative_rms)}, "
                          f"median {_fmt_pct(s.median_relative_error)}")
        unstable = [c for c, ok in res.stability.stable.items() if not ok]
        console.print(f"  Drucker-stable for λ {res.stability.stretch_range[0]:g}–"
                      f"{res.stability.stretch_range[1]:g}: "
                      + ("yes, every load case" if not unstable else
                         "NO in " + ", ".join(f"{c} (from λ = {res.stability.first_unstable[c]})"
                                              for c in unstable)), highlight=False)
        if res.material.break_stretch:
            console.print(f"  stretch at break (data) = {res.material.break_stretch:.3g}")
        console.print(f"  residual: {res.residual_definition}", highlight=False)
        console.print(f"wrote {folder}/fit.json, fit.png")


def _fit_options(model: str, order: int | None, stretch_max: float | None, case: str | None,
                 residual: str, fmt: str) -> Any:
    """The law to fit; every option of ``material fit`` checked (SpecError naming it)."""
    from multimorph.errors import SpecError
    from multimorph.materials import get_law
    from multimorph.materials._fit import RESIDUALS
    from multimorph.materials._loadcases import canonical_case
    from multimorph.materials._readers import FORMATS

    try:
        law = get_law(model, order)
    except SpecError as exc:
        opt = "--order" if order is not None and "order" in str(exc) else "--model"
        raise SpecError(f"{opt}: {exc}") from None
    if stretch_max is not None and not (math.isfinite(stretch_max) and stretch_max > 1.0):
        raise SpecError(f"--range: the largest stretch to fit must be a number above 1, got "
                        f"{stretch_max:g}")
    if case is not None:
        try:
            canonical_case(case)
        except SpecError as exc:
            raise SpecError(f"--case: {exc}") from None
    if residual not in RESIDUALS:
        raise SpecError(f"--residual: expected {' or '.join(RESIDUALS)}, got {residual!r}")
    if fmt not in FORMATS:
        raise SpecError(f"--format: expected one of {', '.join(FORMATS)}, got {fmt!r}")
    return law


def _specimen(dims: dict[str, str | None]) -> Any:
    """Specimen dimensions from the options (None when none is given)."""
    if all(v is None for v in dims.values()):
        return None
    from multimorph.errors import SpecError
    from multimorph.materials import Specimen
    from multimorph.units import to_si

    base = Specimen()
    kw = {}
    for key, value in dims.items():
        opt = f"--{key.replace('_', '-')}"
        x = getattr(base, key) if value is None else to_si(value, "m", field=opt)
        if not (math.isfinite(x) and x > 0):
            raise SpecError(f"{opt}: must be a positive length, got {value!r}")
        kw[key] = x
    return Specimen(**kw)


def _check_range(data: Any, law: Any, stretch_max: float, residual: str) -> None:
    """Refuse a --range that leaves fewer usable points than the law has parameters."""
    from multimorph.errors import SpecError

    n = 0
    for c in data.curves:
        keep = (c.stretch <= stretch_max) & (c.stretch != 1.0)
        if residual == "relative":
            keep &= c.stress > 0
        n += int(keep.sum())
    if n <= len(law.param_names):
        raise SpecError(f"--range: only {n} usable data point(s) with stretch <= "
                        f"{stretch_max:g}; {law.name} has {len(law.param_names)} parameters "
                        "and needs more points")


@material_app.command("rebuild-library", cls=PlainHelpCommand)
def material_rebuild(
    check: Annotated[bool, typer.Option(
        "--check", help="Do not write; exit 1 if the shipped library differs.")] = False,
) -> None:
    """Refit the built-in library from the shipped data (deterministic).

    Example: multimorph material rebuild-library --check
    """
    from multimorph.materials.build_library import main as build_main

    code = build_main(["--check"] if check else [])
    raise typer.Exit(code)


def register(app: typer.Typer) -> None:
    app.add_typer(material_app, name="material")
