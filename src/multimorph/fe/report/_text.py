"""The console summary of an FE run: a headline and a few lines of the numbers that matter
(Pc, Ph, the final state, the peak stretch, a fast cell model vs FE)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from multimorph.fe.analyses import FEOutcome

__all__ = ["describe"]


def describe(outcome: FEOutcome, info: Mapping[str, Any]) -> tuple[str, list[str]]:
    """The console summary of an FE run and its JSON summary ``info``
    (:func:`~multimorph.fe.report.write_outcome`): the title (``"FE cell"``, ``"FE device"``,
    ``"FE twisting module"`` …) and the lines, the first of which goes on after the title."""
    kind = outcome.job.kind
    lines = {"cell": _cell_lines, "device": _device_lines, "twisting": _module_lines}[kind]
    return lines(outcome, info)


def _kpa(value: float | None, unit: str = " kPa") -> str:
    return "—" if value is None else f"{value / 1e3:.3g}{unit}"


def _pct(value: float | None) -> str:
    return "—" if value is None else f"{100 * value:+.0f}%"


def _headline(what: str, stats: Mapping[str, Any]) -> str:
    """The rest of a run's first line: its size, solver work, time and why it ended."""
    resumed, restarts = int(stats.get("resumed_points", 0)), int(stats.get("restarts", 0))
    note = ((f"; resumed from {resumed} saved points" if resumed else "")
            + (f"; continuation restarted {restarts}× where it had turned round"
               if restarts else ""))
    return (f"{what} {stats['nfree']} DOF, {stats['points']} points, "
            f"{stats['newton_iterations']} Newton iterations, {stats['solver']}, "
            f"{stats['wall_time']:.1f} s ({stats['stop_reason'] or stats['status']}){note}")


def _cell_lines(outcome: FEOutcome, info: Mapping[str, Any]) -> tuple[str, list[str]]:
    """A cell run: the headline, Pc/Ph, the final state, the strip shear, the model vs FE."""
    job, result, comparison = outcome.job, outcome.result, outcome.comparison
    cells, beta = job.n_cells, job.tilt
    what = "FE cell" if cells == 1 else f"FE module of {cells} cells"
    if beta:
        what = f"FE tilted strip of {cells} cell{'s' if cells > 1 else ''}"
    lines = [_headline("", result.stats)]
    c = result.response.characteristic
    lines.append(f"Pc = {_kpa(c.critical)} ({c.critical_kind}), Ph = {_kpa(c.hardening)}, "
                 f"failure = {_kpa(c.failure)}")
    final = info["final"]
    lines.append(f"at {final['pressure_pa'] / 1e3:.3g} kPa: κd = "
                 f"{final['curvature_1_per_m'] * job.geometry.length:.3f} per cell, bend "
                 f"{final['bend_angle_deg']:.1f}°, V/V0 = {final['volume_ratio']:.2f}, "
                 f"peak stretch {final['peak_stretch']:.2f}")
    if beta:
        extra = result.response.path.extra
        lines.append(f"tilted strip (β = {math.degrees(beta):.3g}°): shear γ = "
                     f"{extra['shear'][-1]:+.4f}, axial strain "
                     f"{extra['strip_axial_strain'][-1]:+.4f} at the highest pressure")
    if comparison is not None and beta:
        mid = len(comparison.pressure) // 2
        lines.append(f"{comparison.meta.get('model', 'model')} twisting kinematics vs FE: "
                     f"γ_fe/γ_model = "
                     f"{comparison.ratio[mid]:.3g} at {comparison.pressure[mid] / 1e3:.3g} "
                     f"kPa, {comparison.ratio[-1]:.3g} at {comparison.pressure[-1] / 1e3:.3g} kPa")
    elif comparison is not None:
        def rel(v: float | None) -> str:
            return "—" if v is None else f"{100 * v:+.1f} %"

        lines.append(f"{comparison.meta.get('model', 'model')} vs FE: Pc "
                     f"{_kpa(comparison.pc_rom)} vs {_kpa(comparison.pc_fe)}"
                     f" ({rel(comparison.pc_rel)}), Ph {_kpa(comparison.ph_rom)} vs "
                     f"{_kpa(comparison.ph_fe)} ({rel(comparison.ph_rel)}), " + (
                         f"on the axial stretch, max |Δλ|/(λ − 1) "
                         f"{rel(comparison.stretch_rel_max)}"
                         if comparison.signal == "axial_stretch" else
                         f"max |Δκ|/κ {rel(comparison.kappa_rel_max)}"))
    return what, lines


def _device_lines(outcome: FEOutcome, info: Mapping[str, Any]) -> tuple[str, list[str]]:
    """A device run: the headline, every module's Pc/Ph and state, the peak stretch, the
    hubs and the tip."""
    result, comparison = outcome.result, outcome.comparison
    what = "FE device"
    lines = [_headline(f" {result.device.name}: {len(result.responses)} modules,",
                       result.stats)]
    head = (f"  {'module':<10} {'kind':<15} {'Pc':>6} {'Ph':>6} {'at P':>6} {'bend°':>6} "
            f"{'twist°':>6} {'stretch':>7}")
    if comparison is not None:
        names = sorted({str(row.get("model", "model")) for row in comparison.values()})
        head += f"  {'model Pc':>8} {'rel':>5} {'Ph':>6} {'rel':>5}"
    lines.append("modules (Pc, Ph in kPa, — not reached; bend towards the stiff layer, twist "
                 "about the axis and centroid stretch at P, the top of the module's stable "
                 "loading curve):")
    if comparison is not None:
        lines.append(f"model: {', '.join(names)} (its Pc, Ph and (model − FE)/FE beside FE's)")
    lines.append(head)
    for module in result.mesh.modules:
        pc, ph = result.activation(module.name)
        at = result.module_at(module.name)
        kind = f"{module.kind} {math.degrees(module.orientation):.0f}°"
        line = (f"  {module.name[:10]:<10} {kind:<15} {_kpa(pc, ''):>6} {_kpa(ph, ''):>6} "
                f"{_kpa(at['pressure'], ''):>6} {math.degrees(at['bend_angle']):>6.1f} "
                f"{math.degrees(at['twist_angle']):>6.1f} {at['axial_stretch']:>7.3f}")
        if comparison is not None:
            row = comparison[module.name]
            line += (f"  {_kpa(row['pc_rom'], ''):>8} {_pct(row['pc_rel']):>5} "
                     f"{_kpa(row['ph_rom'], ''):>6} {_pct(row['ph_rel']):>5}")
        lines.append(line)
    final = {name: entry["final"] for name, entry in info["device"]["modules"].items()}
    worst = max(final, key=lambda name: final[name]["peak_stretch"])
    peak = final[worst]
    lines.append(f"peak principal stretch {peak['peak_stretch']:.3f} at "
                 f"{peak['pressure_pa'] / 1e3:.3g} kPa in module {worst!r} "
                 f"({peak['peak_region']}, at x, y, z = "
                 f"{', '.join(f'{v * 1e3:.1f}' for v in peak['peak_location_m'])} mm "
                 f"undeformed)")
    for hub in info["device"].get("hubs", []):
        lines.append(f"hub at the end of {hub['parent']!r} (rigid, {hub['tied_nodes']} nodes "
                     f"tied): turned {hub['final_rotation_deg']:.1f}°, carries "
                     f"{', '.join(hub['children'])}")
    where = " (end of the clamped branch)" if result.mesh.hubs else ""
    lines.append(f"tip{where} at {result.pressure[-1] / 1e3:.3g} kPa: y = "
                 f"{result.tip[-1, 1] * 1e3:.2f} mm, z = {result.tip[-1, 2] * 1e3:.2f} mm, "
                 f"angle {math.degrees(result.tip_angle[-1]):.1f}°")
    if "cad" in info:
        lines.append(info["cad"])
    return what, lines


def _module_lines(outcome: FEOutcome, info: Mapping[str, Any]) -> tuple[str, list[str]]:
    """A twisting-module run: the headline, Pc/Ph, the final state, the model vs FE."""
    result, comparison = outcome.result, outcome.comparison
    module = result.module
    what = "FE twisting module"
    lines = [_headline(f" {module.name}: {module.strips} strips of {module.n_cells} "
                       f"cell{'s' if module.n_cells > 1 else ''}, "
                       f"tilt {math.degrees(module.tilt):.3g}°,", result.stats)]
    pc, ph = result.activation()
    final = info["module"]["final"]
    lines.append(f"Pc = {_kpa(pc)}, Ph = {_kpa(ph)} (on the twist rate); at "
                 f"{final['pressure_pa'] / 1e3:.3g} kPa: twist {final['twist_angle_deg']:+.2f}° "
                 f"(right-handed about the axis), axial stretch {final['axial_stretch']:.4f}, "
                 f"V/V0 = {final['volume_ratio']:.2f}; peak principal stretch "
                 f"{final['peak_stretch']:.3f} ({final['peak_region']}, at x, y, z = "
                 f"{', '.join(f'{v * 1e3:.1f}' for v in final['peak_location_m'])} mm "
                 f"undeformed)")
    if comparison is not None:
        lines.append(f"{comparison.get('model', 'model')} vs FE (twist in the sense of the "
                     f"tilt): Pc "
                     f"{_kpa(comparison['pc_rom'])} vs {_kpa(comparison['pc_fe'])} "
                     f"({_pct(comparison['pc_rel'])})")
        for P, a, b, la, lb in zip(comparison["pressure_pa"], comparison["twist_deg_rom"],
                                   comparison["twist_deg_fe"], comparison["stretch_rom"],
                                   comparison["stretch_fe"], strict=True):
            lines.append(f"  {P / 1e3:6.3g} kPa: twist {a:7.2f}° vs {b:7.2f}°, stretch "
                         f"{la:.4f} vs {lb:.4f}")
    return what, lines
