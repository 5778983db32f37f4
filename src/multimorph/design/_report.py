"""Outputs of a design run: the device TOML, a report (markdown and JSON) and figures."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from multimorph.design._evaluate import Evaluation
from multimorph.design._optimise import DesignResult
from multimorph.design._robust import RobustnessReport
from multimorph.device import Device
from multimorph.materials import Material
from multimorph.names import kind_name

__all__ = ["TWIST_CAVEAT", "convergence_figure", "device_toml", "report_dict", "report_markdown",
           "robustness_figure", "sequence_figure", "twist_caveat"]


def _q(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _mm(x: float) -> str:
    """A length as written in a designed device: mm rounded to 0.01 mm (a mold's precision;
    the change is at most 0.005 mm, 0.5 % of a 1 mm wall)."""
    return _q(f"{round(x * 1e3, 2):g} mm")


def _is_library(material: Material) -> bool:
    from multimorph.materials import get_material

    try:
        lib = get_material(material.name, material.model)
    except Exception:
        return False
    return dict(lib.params) == dict(material.params)


def device_toml(device: Device, *, header: str = "") -> str:
    """The device as a TOML spec readable by :func:`multimorph.device.device_from_spec`."""
    lines: list[str] = []
    if header:
        lines += [f"# {h}" for h in header.splitlines()] + [""]
    pmax = f"{device.pmax / 1e3:.6g} kPa"
    lines += ["[device]", f"name = {_q(device.name)}", f"pmax = {_q(pmax)}", ""]
    mats: dict[str, Material] = {}
    for module in device.modules:
        for mm in (module.cell.material, module.cell.bottom_material):
            assert mm is not None
            mats.setdefault(mm.name, mm)
    inline = {n: mm for n, mm in mats.items() if not _is_library(mm)}
    for n, mm in inline.items():
        lines.append(f"[materials.{_q(n)}]")
        lines.append(f"model = {_q(mm.model)}")
        units = dict(zip(mm.law.param_names, mm.law.param_units, strict=False))
        for k, v in mm.params.items():
            if units.get(k) == "Pa":            # moduli with their unit, in kPa
                lines.append(f"{k} = {_q(f'{float(v) / 1e3:.6g} kPa')}")
            else:
                lines.append(f"{k} = {float(v)!r}")
        if mm.break_stretch:
            lines.append(f"break_stretch = {float(mm.break_stretch)!r}")
        lines.append("")
    for module in device.modules:
        c = module.cell
        lines.append(f"[cells.{_q(module.name)}]")
        for key in ("length", "width", "height", "top_wall", "bottom_wall", "side_wall",
                    "end_wall"):
            lines.append(f"{key} = {_mm(getattr(c, key))}")
        lines.append(f"material = {_q(c.material.name)}")
        assert c.bottom_material is not None
        lines.append(f"bottom_material = {_q(c.bottom_material.name)}")
        lines.append("")
    for module in device.modules:
        lines += ["[[module]]", f"name = {_q(module.name)}", f"kind = {_q(module.kind)}",
                  f"cell = {_q(module.name)}", f"cells = {module.n_cells}"]
        if module.kind == "twisting":
            lines += [f"tilt = {_q(f'{math.degrees(module.tilt):.1f} deg')}",
                      f"shaft_radius = {_mm(module.shaft_radius)}", f"strips = {module.strips}"]
        if module.orientation:
            lines.append(f"orientation = {_q(f'{math.degrees(module.orientation):.6g} deg')}")
        if module.attach_to is not None:
            lines += [f"attach_to = {_q(module.attach_to)}", f"count = {module.count}",
                      f"radius = {_mm(module.radius)}"]
        lines.append("")
    return "\n".join(lines)


def _fmt_p(p: float | None) -> str:
    return "—" if p is None else f"{p / 1e3:.4g} kPa"


def _fmt_mag(kind: str, v: float | None) -> str:
    if v is None:
        return "—"
    return f"{v * 100:.3g} %" if kind == "stretch" else f"{math.degrees(v):.3g}°"


def report_dict(result: DesignResult, robust: RobustnessReport | None = None,
                sequence: dict[str, Any] | None = None, verification: Any = None,
                simulation_error: str | None = None) -> dict[str, Any]:
    """Everything of a run as a JSON-able dict (SI units)."""
    t = result.target
    out = result.to_dict()
    out["stages"] = [{"name": stage.name, "kind": stage.kind, "magnitude": stage.magnitude,
                      "start_pressure": stage.start_pressure, "end_pressure": stage.end_pressure,
                      "count": stage.count} for stage in t.stages]
    out["tolerance"] = {"pressure": t.tolerance.pressure, "magnitude": t.tolerance.magnitude}
    out["robustness"] = None if robust is None else robust.to_dict()
    out["sequence"] = sequence
    out["simulation_error"] = simulation_error
    out["verification"] = verification
    return out


#: What a twist stage's predicted angle is worth (stop 61, docs/design.md).
TWIST_CAVEAT = ("Twist stages ({stages}): the predicted angle is the strip rule's (τ = γ / R "
                "on the tilted cells' strip shear), and so is the `strip` FE route's. The "
                "whole module inflated on its shaft in 3D FE activates at the predicted "
                "pressures but twists a third to a sixth of that angle (the gripper's "
                "twister, the three-stage turn; docs/design.md): check the angle with "
                "`--verify-fe --fe-twist shaft`.")


def twist_caveat(stages: Any) -> str | None:
    """:data:`TWIST_CAVEAT` for the twist stages among ``stages`` (None: there are none)."""
    twists = [stage.name for stage in stages if stage.kind == "twist"]
    return TWIST_CAVEAT.format(stages=", ".join(twists)) if twists else None


def report_markdown(result: DesignResult, robust: RobustnessReport | None = None,
                    sequence: dict[str, Any] | None = None, verification: Any = None,
                    simulation_error: str | None = None) -> str:
    """A human-readable report of a run."""
    t = result.target
    L = [f"# Design report: {t.name}", ""]
    L.append(f"Verdict: **{'feasible — every target met' if result.feasible else 'INFEASIBLE'}**"
             f" (seed {result.settings.seed}, {result.evaluations} cell-model evaluations in "
             f"{result.model_calls} batched calls, {result.wall_time:.1f} s).")
    L.append("")
    if result.explanation:
        L += ["## Why the target is not met", ""]
        L += [f"- {e}" for e in result.explanation] + [""]
    best = result.best
    if best is not None:
        L += ["## Best design vs target", "",
              f"Tolerances: pressure ±{t.tolerance.pressure:.0%}, magnitude "
              f"±{t.tolerance.magnitude:.0%}.", "",
              "Predicted magnitudes are at Ph; the last column is the motion at the maximum "
              "pressure (hardening slows a module after Ph, it does not stop it).", "",
              "| stage | kind | cells | wanted start | predicted Pc | wanted end | predicted Ph "
              "| wanted | predicted | safety factor | at max pressure |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
        for stage, sr in zip(t.stages, best.stages, strict=True):
            sf = "—" if sr.safety_factor is None else f"{sr.safety_factor:.2f}"
            L.append(f"| {stage.name} | {kind_name(stage.kind)} | {sr.n_cells} | "
                     f"{_fmt_p(stage.start_pressure)} | "
                     f"{_fmt_p(sr.start)} | {_fmt_p(stage.end_pressure)} | {_fmt_p(sr.end)} | "
                     f"{_fmt_mag(stage.kind, abs(stage.magnitude))} | "
                     f"{_fmt_mag(stage.kind, sr.magnitude)} | {sf} | "
                     f"{_fmt_mag(stage.kind, sr.magnitude_at_max)} |")
        graded = result.graded_stages()
        if graded:
            ratio = result.settings.graded_ratio
            L += ["", f"Graded stages (bands wider than Ph/Pc = {ratio:.3g}, "
                  "and stages that ask for `parts`, are realised by modules of the same kind "
                  "in series, each with its own cell; the stage starts at its first part's "
                  "Pc and completes at its last part's Ph):", "",
                  "| stage | parts | wanted start | start | wanted end | end | wanted | "
                  "predicted | met |", "|---|---|---|---|---|---|---|---|---|"]
            kinds = {value.name: value.kind for value in t.stages}
            for name, parts in graded.items():
                w, pr = parts["wanted"], parts.get("predicted", {})
                kind = kinds[parts["parts"][0]]
                L.append(f"| {name} | {', '.join(parts['parts'])} | "
                         f"{_fmt_p(w['start_pressure'])} | {_fmt_p(pr.get('start_pressure'))} "
                         f"| {_fmt_p(w['end_pressure'])} | {_fmt_p(pr.get('end_pressure'))} | "
                         f"{_fmt_mag(kind, abs(w['magnitude']))} | "
                         f"{_fmt_mag(kind, pr.get('magnitude'))} | "
                         f"{'yes' if pr.get('met') else 'no'} |")
        L += ["", "Cells of the best design:", ""]
        for stage, c, tilt in zip(t.stages, best.candidate.cells, best.candidate.tilts,
                               strict=True):
            extra = f", tilt {math.degrees(tilt):.3g}°" if stage.kind == "twist" else ""
            assert c.bottom_material is not None
            L.append(f"- {stage.name}: d {c.length * 1e3:.3g} × w {c.width * 1e3:.3g} × h "
                     f"{c.height * 1e3:.3g} mm; walls top {c.top_wall * 1e3:.3g}, bottom "
                     f"{c.bottom_wall * 1e3:.3g}, side {c.side_wall * 1e3:.3g}, end "
                     f"{c.end_wall * 1e3:.3g} mm; {c.material.name} / "
                     f"{c.bottom_material.name}{extra}")
        L.append("")
        caveat = twist_caveat(t.stages)
        if caveat:
            L += [caveat, ""]
        if len(result.designs) > 1:
            L += ["## Ranked designs", "", "| rank | objective | meets | worst distance |",
                  "|---|---|---|---|"]
            for k, e in enumerate(result.designs):
                worst = max((abs(v) for v in e.distances.values()), default=float("nan"))
                L.append(f"| {k + 1} | {e.objective:.3g} | {'yes' if e.meets else 'no'} | "
                         f"{worst:.2f} |")
            L.append("")
    if simulation_error:
        L += ["## Predicted sequence (device simulation)", "", simulation_error, ""]
    if sequence:
        L += ["## Predicted sequence (device simulation)", "",
              f"Order by Pc: {' → '.join(sequence['order'])}.", ""]
        for margin in sequence["margins"]:
            if margin["margin"] is None:
                L.append(f"- {margin['earlier']} → {margin['later']}: undetermined")
            else:
                L.append(f"- {margin['earlier']} → {margin['later']}: {margin['verdict']} "
                         f"(Pc_later − Ph_earlier = {margin['margin'] / 1e3:+.3g} kPa)")
        L.append(f"- first to fail beyond the path: {sequence.get('first_to_fail') or 'none'}")
        L.append("")
    if robust is not None:
        L += ["## Robustness (Monte Carlo)", "",
              f"{robust.n_samples} samples, seed {robust.seed}; walls ±"
              f"{robust.wall_tolerance * 1e3:.3g} mm (uniform); material parameters normal "
              "with:", ""]
        for name, u in robust.uncertainty.items():
            sd = ", ".join(f"{k} ± {v:.3g}" for k, v in u["std"].items())
            L.append(f"- {name}: {u['source']} ({sd}; SI)")
        L += ["", f"Probability that the stage order holds: **{robust.p_order:.1%}**; that "
              f"every target and constraint is met: **{robust.p_meets:.1%}**."]
        if robust.outside_support:
            L += ["", _outside_support_text(robust)]
        L += ["", "| stage | quantity | mean | std | 5 % | 95 % | not reached | "
              "no prediction |", "|---|---|---|---|---|---|---|---|"]
        for stage in t.stages:
            for q, value in robust.stages[stage.name].items():
                out = int(value.get("outside_support") or 0)
                gaps = f"{int(value['missing']) - out} | {out}"
                if value["mean"] is None:
                    L.append(f"| {stage.name} | {q} | — | — | — | — | {gaps} |")
                    continue
                if q == "magnitude":
                    def f(v, k=stage.kind):
                        return (_fmt_mag(k, v))
                else:
                    f = _fmt_p
                L.append(f"| {stage.name} | {q} | {f(value['mean'])} | {f(value['std'])} | "
                         f"{f(value['p05'])} | {f(value['p95'])} | {gaps} |")
        L.append("")
    if result.rounds:
        L += ["## Model corrections (space mapping)", "",
              "The search ran on the fast calibrated variant; each round's best designs were "
              "scored by the calibrated model, and the next round searched on the fast "
              "model corrected by the calibrated/fast ratio of the best one so far (Pc, Ph "
              "and motion per stage), near it.", "",
              "| round | stage | correction on Ph | fast model Ph | calibrated Ph | "
              "calibrated meets |", "|---|---|---|---|---|---|"]
        for rd in result.rounds:
            for i, (want, s_, c_) in enumerate(zip(rd.wanted.stages, rd.search.stages,
                                                   rd.check.stages, strict=True)):
                f = "—" if rd.correction is None else f"× {rd.correction[i]['end_pressure']:.3f}"
                L.append(f"| {rd.index} | {want.name} | {f} | "
                         f"{_fmt_p(s_.end)} | {_fmt_p(c_.end)} | "
                         f"{'yes' if rd.check.meets else 'no'} |")
        L.append("")
    if result.fe_rounds:
        verdict = ("**FE-verified**: 3D FE meets every target" if result.fe_verified
                   else "**not FE-verified**: 3D FE misses a target (below)")
        how = ("each stage's module inflated on its own in 3D FE, on the common pressure "
               "(route `modules`: the coupling through the shared end walls is left out"
               + ("; a twisting module as one tilted cell of its strips in FE, its twist by "
                  "the module's shaft kinematics τ = γ / R" if result.fe_twist == "strip"
                  and any(s.kind == "twist" for s in result.target.stages) else "") + ")"
               if result.fe_route == "modules" else
               "the whole device inflated as one 3D FE problem (route `device`)")
        L += ["## 3D FE verification of the device", "", verdict + ".", "", how + ".", "",
              "| FE round | stage | wanted Pc | model Pc | FE Pc | wanted Ph | model Ph | "
              "FE Ph | wanted | model | FE |", "|---|---|---|---|---|---|---|---|---|---|---|"]
        for rd in result.fe_rounds:
            for want, m_, f_ in zip(rd.wanted.stages, rd.search.stages, rd.check.stages,
                                    strict=True):
                L.append(f"| {rd.index} | {want.name} | {_fmt_p(want.start_pressure)} | "
                         f"{_fmt_p(m_.start)} | {_fmt_p(f_.start)} | "
                         f"{_fmt_p(want.end_pressure)} | {_fmt_p(m_.end)} | {_fmt_p(f_.end)} | "
                         f"{_fmt_mag(want.kind, abs(want.magnitude))} | "
                         f"{_fmt_mag(want.kind, m_.magnitude)} | "
                         f"{_fmt_mag(want.kind, f_.magnitude)} |")
        screened = [(rd.index, e) for rd in result.fe_rounds for e in rd.screened]
        if screened:
            L += ["", "FE screening (`--fe-screen`): other cells of the stage FE missed most, "
                  "each checked in FE in the round's design; `kept`: it replaced the "
                  "search's cell in the round's design (above).", "",
                  "| FE round | stage | model Pc | FE Pc | model Ph | FE Ph | model | FE | "
                  "FE objective | kept |", "|---|---|---|---|---|---|---|---|---|---|"]
            kinds = {st.name: st.kind for st in result.target.stages}
            for k, e in screened:
                kind = kinds.get(e["stage"], "bend")
                L.append(f"| {k} | {e['stage']} | {_fmt_p(e['model_start_pressure'])} | "
                         f"{_fmt_p(e['fe_start_pressure'])} | "
                         f"{_fmt_p(e['model_end_pressure'])} | "
                         f"{_fmt_p(e['fe_end_pressure'])} | "
                         f"{_fmt_mag(kind, e['model_magnitude'])} | "
                         f"{_fmt_mag(kind, e['fe_magnitude'])} | "
                         f"{e['fe_objective']:.3g} | {'yes' if e['kept'] else 'no'} |")
        last = result.fe_rounds[-1]
        if not last.check.meets and last.check.message:
            L += ["", f"FE notes: {last.check.message}"]
        L.append("")
    if verification is not None:
        L += ["## FE verification", "", "```", str(verification), "```", ""]
    return "\n".join(L)


def fe_figure(result: DesignResult) -> Any:
    """Model vs device FE per stage and FE round: Pc, Ph (kPa) and magnitude, with the
    target and its tolerance band."""
    import matplotlib.pyplot as plt

    rounds = result.fe_rounds
    stages = rounds[0].wanted.stages
    tol = rounds[0].wanted.tolerance
    fig, axes = plt.subplots(len(stages), 3, figsize=(10, 2.4 * len(stages)), squeeze=False)
    x = np.arange(len(rounds))
    for i, stage in enumerate(stages):
        stretch = stage.kind == "stretch"
        for j, (what, wanted, unit) in enumerate((
                ("start", stage.start_pressure, "kPa"), ("end", stage.end_pressure, "kPa"),
                ("magnitude", abs(stage.magnitude), "%" if stretch else "deg"))):
            ax = axes[i, j]

            def conv(v: float | None, _j: int = j, _st: bool = stretch) -> float:
                if v is None:
                    return float("nan")
                if _j < 2:
                    return v / 1e3
                return v * 100 if _st else math.degrees(v)

            model = [conv(getattr(rd.search.stages[i], what)) for rd in rounds]
            fe = [conv(getattr(rd.check.stages[i], what)) for rd in rounds]
            ax.plot(x, model, "o-", color="tab:blue", label="model (calibrated)")
            ax.plot(x, fe, "s-", color="tab:red", label="3D FE")
            if wanted is not None:
                w = conv(wanted)
                t = tol.magnitude if j == 2 else tol.pressure
                ax.axhspan(w * (1 - t), w * (1 + t), color="0.85", zorder=0,
                           label="target ± tolerance")
                ax.axhline(w, color="k", lw=0.8)
            label = {"start": "Pc", "end": "Ph", "magnitude": "motion at Ph"}[what]
            ax.set_ylabel(f"{label} ({unit})")
            ax.set_title(f"{stage.name} ({kind_name(stage.kind)}): {label}", fontsize=9)
            ax.set_xticks(x)
            ax.set_xlabel("FE round")
            if i == 0 and j == 0:
                ax.legend(fontsize=7)
    fig.suptitle(f"{result.target.name}: model vs device FE per round "
                 f"({'FE-verified' if result.fe_verified else 'not FE-verified'})")
    fig.tight_layout()
    return fig


def sequence_figure(device_result: Any, target: Any) -> Any:
    """The device's sequence chart with the target pressures marked."""
    from multimorph.viz._device_plots import module_curves_figure

    fig = module_curves_figure(device_result)
    ax = fig.axes[0]
    for stage in target.stages:
        ax.axvline(stage.end_pressure / 1e3, color="k", lw=0.8, ls="--")
        if stage.start_pressure is not None:
            ax.axvline(stage.start_pressure / 1e3, color="k", lw=0.8, ls=":")
    return fig


def convergence_figure(result: DesignResult) -> Any:
    """Best objective vs model call."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.0, 3.6), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    h = np.asarray(result.history, float)
    if h.size:
        ax.semilogy(np.arange(1, h.size + 1), np.maximum(h, 1e-6), "-o", ms=3)
    ax.set_xlabel("batched model call")
    ax.set_ylabel("best objective")
    ax.set_title(f"{result.target.name}: search convergence", fontsize=10)
    ax.grid(alpha=0.3)
    return fig


def _outside_support_text(robust: RobustnessReport) -> str:
    """What the probabilities mean where the model left samples unanswered."""
    n, out = robust.n_samples, robust.outside_support
    over = (f"over the {n - out} it answered: order {robust.p_order_supported:.1%}, every "
            f"target {robust.p_meets_supported:.1%}" if robust.p_order_supported is not None
            else "it answered none")
    return (f"{out} of the {n} samples have a cell outside the calibrated model's support "
            f"(its walls ±{robust.wall_tolerance * 1e3:.3g} mm take it past the calibrated "
            f"box): the model gives no prediction there, and the probabilities above count "
            f"them as failing; {over}. Check such a design in FE (`--verify-fe`) or keep it "
            f"further inside the box.")


def robustness_figure(robust: RobustnessReport, target: Any) -> Any:
    """Histograms of every stage's start and completion pressure over the samples."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 3.8), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    for i, stage in enumerate(target.stages):
        drawn = robust.samples.get(stage.name, {})
        for key, alpha in (("start_pressure", 0.35), ("end_pressure", 0.7)):
            v = np.asarray(drawn.get(key, []), float)
            v = v[np.isfinite(v)]
            if v.size:
                ax.hist(v / 1e3, bins=20, alpha=alpha, color=f"C{i}",
                        label=f"{stage.name} {key.split('_')[0]}")
        ax.axvline(stage.end_pressure / 1e3, color=f"C{i}", ls="--", lw=1)
    ax.set_xlabel("pressure (kPa)")
    ax.set_ylabel("samples")
    title = f"robustness: P(order holds) = {robust.p_order:.0%}"
    if robust.outside_support:
        title += (f" ({robust.outside_support} of {robust.n_samples} samples outside the "
                  "calibrated support, counted as failing)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8)
    return fig


def best_device(result: DesignResult) -> Device | None:
    """The best design's device (None when there is no design)."""
    best: Evaluation | None = result.best
    return None if best is None else best.device
