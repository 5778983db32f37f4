"""Validate the calibrated model against the FE reference data it never saw.

    python -m multimorph.calibrated.validate [--out docs/validation] [--json FILE]

For every cell kind: the held-out 20 % of each of its sets, for bending also the
24-design grid of docs/fe.md (held out whole), and every design of a kind the model is not
fitted on (tilted cells until their set is large enough); and the mirror-ended twins of
the bending sets (the cell as inside a module), on the designs whose twin the fit never
saw (:func:`unseen_designs`). Each design is predicted by
the calibrated model (the whole run-time chain: emulated Ritz features, GP, path, shared
Pc/Ph definitions) and by the Ritz model, and compared with its stored FE path
(:mod:`._validate`). Writes parity plots of Pc, Ph and the signal at 1.5 Pc, the curves of
the worst five designs, ``metrics.json``, and prints the Markdown tables of
``docs/validation.md``.
"""

from __future__ import annotations

import argparse
import json
import math
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from multimorph.calibrated._dataset import is_holdout, load_reference
from multimorph.calibrated._fit import fe_training_data, twin_set
from multimorph.calibrated._validate import (
    DesignComparison,
    compare,
    fe_response,
    signal_of_loading,
    summary,
)

SIGNAL_LABEL = {"bending": "κd (end rotation per cell, rad)", "stretching": "λ − 1",
                "twisting": "strip shear γ"}
CHECKS = (("bending", "bending"), ("bending", "bending_narrow"), ("bending", "bending_single"),
          ("bending", "bending_single2"),
          ("bending", "grid24"), ("bending", "yeoh"),
          # the bending kind against the cell as inside a module (mirror ends, stop 32)
          ("bending", "bending_mirror"), ("bending", "bending_narrow_mirror"),
          ("bending", "bending_single_mirror"), ("bending", "bending_single2_mirror"),
          ("bending", "bending3_mirror"), ("bending", "bending_softbottom_mirror"),
          # the weak-bottom refinement (stop 51; in the fit since stop 52: its held-out
          # fifth checked, as the other training sets')
          ("bending", "bending_lowbt_mirror"),
          # a third one-elastomer sample (stop 52; in the fit since stop 59: its held-out
          # fifth checked)
          ("bending", "bending_single3_mirror"),
          ("bending", "grid24_mirror"), ("bending", "yeoh_mirror"),
          # Yeoh walls over the box (stop 49): the law map's held-out fifth; a second
          # sample the map never saw (stop 50)
          ("bending", "yeoh2_mirror"), ("bending", "yeoh3_mirror"),
          # never used to choose a fit (stop 42): a second sample of the box, and Jm 9-14
          ("bending", "bending2_mirror"), ("bending", "bending_lowjm_mirror"),
          ("stretching", "stretching_mirror"), ("stretching", "stretching_narrow_mirror"),
          ("stretching", "stretching2_mirror"),
          # Yeoh walls on stretching cells (stop 49): the law map, fitted on bending cells
          ("stretching", "yeoh_stretching_mirror"),
          ("twisting", "twisting"), ("twisting", "twisting2"), ("twisting", "twisting_narrow"),
          ("twisting", "twisting3"),
          # Yeoh walls on tilted cells (stop 50): the law map, fitted on bending cells
          ("twisting", "yeoh_twisting"))

#: The issue's measure is per cell kind: each kind's held-out designs pooled over its sets
#: (stop 42; the per-set rows above it). The bending kind answers as the cell inside a
#: module (mirror ends); its plate-ended sets are pooled apart, and so are the two sets
#: that never chose between fits (the held-out fifths did, since stop 33). `twisting3` is
#: never trained on (all its designs are unseen), pooled with the held-out fifths in a row
#: of its own. Since stop 47 the mirror pool holds `bending3_mirror`'s held-out fifth too
#: (a training set since then), since stop 48 `bending_softbottom_mirror`'s, since stop 52
#: `bending_lowbt_mirror`'s, since stop 59 `bending_single3_mirror`'s. Since stop
#: 49 the Yeoh walls (a law the GPs never saw, placed by the law map, ``_law``): all of
#: `yeoh_mirror` and the held-out fifth of `yeoh2_mirror` (whose rest the map is fitted on);
#: since stop 50 with all of `yeoh3_mirror` too, a second sample the map never saw.
POOLS = (("bending", "mirror ends (the cell inside a module)",
          ("bending_mirror", "bending_narrow_mirror", "bending_single_mirror",
           "bending_single2_mirror", "bending3_mirror", "bending_softbottom_mirror",
           "bending_lowbt_mirror", "bending_single3_mirror")),
         ("bending", "mirror ends, never used to choose a fit", ("bending2_mirror",
                                                                "bending_lowjm_mirror")),
         ("bending", "plate ends", ("bending", "bending_narrow", "bending_single",
                                    "bending_single2")),
         ("stretching", "mirror ends", ("stretching_mirror", "stretching_narrow_mirror",
                                        "stretching2_mirror")),
         ("twisting", "held-out fifths", ("twisting", "twisting2", "twisting_narrow")),
         ("twisting", "held-out fifths and twisting3", ("twisting", "twisting2",
                                                        "twisting_narrow", "twisting3")),
         ("bending", "Yeoh walls, mirror ends", ("yeoh_mirror", "yeoh2_mirror")),
         ("bending", "Yeoh walls, mirror ends, and yeoh3_mirror (never fitted on)",
          ("yeoh_mirror", "yeoh2_mirror", "yeoh3_mirror")))


def unseen_designs(manifest: dict[str, Any], kind: str, set_name: str, design: np.ndarray,
                   holdout: np.ndarray) -> np.ndarray:
    """The designs of ``set_name`` the model's fit never saw in any form: a kind the model
    is not fitted on has seen none; a set it is fitted on, its held-out split; a set whose
    twin (the same designs, the other end condition) it is fitted on, the designs held out
    of the twin; any other set, its held-out split (a validation set: all)."""
    info = manifest.get("kinds", {}).get(kind)
    if info is None:
        return np.ones(len(holdout), bool)
    trained = set(info.get("sets", ()))
    if set_name not in trained and twin_set(set_name) in trained:
        return np.array([is_holdout(twin_set(set_name), int(d)) for d in design], bool)
    return np.asarray(holdout, bool)


def at_end_of(model: Any, kind: str, set_name: str) -> tuple[Any, float | None]:
    """The model predicting at the end condition of ``set_name``'s cells, and that end
    input (None: the kind has no end input). A kind fitted on plate-ended and mirror-ended
    sets (``_fit.end_column``) answers every command as mirror-ended (1, the cell inside a
    module); a plate-ended set is checked on its own level (0), which shows the fit of
    both levels; its distance from the mirror level is the plate's stiffening. The
    twisting kind reads its straight cell at an end level (``straight_end``): the
    plate-ended tilted FE cells are checked with the straight cell at 0."""
    import copy
    from dataclasses import replace

    from multimorph.calibrated._dataset import reference_spec

    k = model.kinds.get(kind)
    if k is None and kind == "twisting" and "bending" in model.kinds:
        # tilted cells on their straight cell (``_model._straight_for_tilted``): its level
        from multimorph.calibrated._shear import plate_level

        b = model.kinds["bending"]
        if b.end_input is None:
            return model, None
        if reference_spec(set_name).options.get("end") == "mirror":
            return model, 1.0
        return plate_level(model), 0.0
    field = ("end_input" if k is not None and k.end_input is not None else
             "straight_end" if k is not None and k.straight_end is not None else None)
    if k is None or field is None:
        return model, None
    end = 1.0 if reference_spec(set_name).options.get("end") == "mirror" else 0.0
    if end == getattr(k, field):
        return model, end
    other = copy.copy(model)
    other.kinds = {**model.kinds, kind: replace(k, **{field: end})}
    if kind in model.fast_kinds and getattr(model.fast_kinds[kind], field) is not None:
        other.fast_kinds = {**model.fast_kinds,
                            kind: replace(model.fast_kinds[kind], **{field: end})}
    return other, end


def requested_pressure(set_name: str, design: int, path: dict[str, np.ndarray]) -> float:
    """The pressure the model is traced to for a design: the one its FE run was asked to
    reach (``meta["p_max"]``: the spec's 0.85 × Ritz Pc), at least the highest FE pressure.

    Until stop 40 it was the highest FE pressure alone. Where FE turns back at its limit
    point (a snap: the arc-length path's pressure falls while κ jumps), that is FE's Pc, and
    a model whose own limit point lies a fraction of a per cent above it was cut off before
    its jump: no Pc of its own (a one-sided miss) and a curve ending below FE's jump."""
    top = float(np.nanmax(np.asarray(path["pressure"], float)))
    ref = load_reference().get(set_name)
    if ref is None:
        return top
    rows = np.flatnonzero(np.asarray(ref.design) == design)
    if rows.size == 0:
        return top
    asked = ref.meta[int(rows[0])].get("p_max")
    if asked is None or not math.isfinite(float(asked)):
        return top
    return max(top, float(asked))


def evaluate(kind: str, set_name: str) -> dict[str, Any]:
    """Model and Ritz against FE on the held-out designs of ``set_name`` (the model at
    the set's end condition, :func:`at_end_of`)."""
    from multimorph.calibrated import CalibrationWarning, load_model
    from multimorph.models import batch_model

    data = fe_training_data(kind, set_names=(set_name,), ritz=False)
    model, _end = at_end_of(load_model(), kind, set_name)
    unseen = unseen_designs(model.manifest, kind, set_name, data.design, data.holdout)
    rows = np.flatnonzero(unseen)
    ritz = batch_model("ritz")
    out: dict[str, Any] = {"kind": kind, "set": set_name, "calibrated": [], "ritz": [],
                           "calibrated-fast": [],
                           "curves": []}
    if rows.size == 0:
        return out
    cells = [data.cells[r] for r in rows]
    fes = [fe_response(data.paths[r], data.cells[r], kind) for r in rows]
    pmax = [requested_pressure(set_name, int(data.design[r]), data.paths[r]) for r in rows]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CalibrationWarning)
        cal = [model.responses([c], p)[0] for c, p in zip(cells, pmax, strict=True)]
    fast: list[Any] = [None] * len(cells)
    if model.fast_kinds:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", CalibrationWarning)
            fast = [model.responses([c], p, fast=True)[0]
                    for c, p in zip(cells, pmax, strict=True)]
    rz = [ritz([c.cell if hasattr(c, "tilt") else c], 3.0 * p)[0]
          for c, p in zip(cells, pmax, strict=True)]
    for j, r in enumerate(rows):
        for name, resp in (("calibrated", cal[j]), ("ritz", rz[j]),
                           ("calibrated-fast", fast[j])):
            if resp is None:
                continue
            if isinstance(resp, Exception):
                out[name].append(None)
                continue
            if name == "ritz" and kind == "twisting":
                from dataclasses import replace

                from multimorph.calibrated._ritz import signal_of
                from multimorph.response import build_response

                path = replace(resp.path, twist_rate=signal_of(resp.path, cells[j]))
                resp = build_response(path, length=resp.length,
                                      shear_modulus=resp.shear_modulus, backend="rom",
                                      signal="twist_rate")
            out[name].append(compare(resp, fes[j], kind, set_name, int(data.design[r])))
        out["curves"].append((fes[j], cal[j], rz[j]))
    return out


def _table(rows: list[DesignComparison | None]) -> dict[str, Any]:
    return summary([r for r in rows if r is not None])


def _fmt(s: dict[str, Any], key: str) -> str:
    d = s[key]
    miss = s.get(f"{key}_missing", 0)
    unknown = s.get(f"{key}_unknown", 0)
    n = (f"{d.get('n', 0)}" + (f" (+{miss} one-sided)" if miss else "")
         + (f" ({unknown} beyond the other's path)" if unknown else ""))
    if not d.get("n"):
        return f"{n} | — | — | —"
    return (f"{n} | {100 * d['median']:.1f} % | {100 * d['p90']:.1f} % | "
            f"{100 * d['max']:.1f} %")


def _pct(d: dict[str, Any], key: str) -> str:
    return f"{100 * d[key]:.1f} %" if d.get("n") else "—"


def _share(v: float) -> str:
    return f"{100 * v:.0f} %" if math.isfinite(v) else "—"


def plot(results: list[dict[str, Any]], out: Path) -> list[str]:
    """Parity plots and worst-five curves (PNG) per kind; returns the file names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    files = []
    for res in results:
        kind, name = res["kind"], res["set"]
        fig, axes = plt.subplots(1, 3, figsize=(13, 4.2))
        panels = (("Pc", "pc_fe", "pc_model"), ("Ph", "ph_fe", "ph_model"),
                  ("signal at 1.5 Pc (FE)", "y15_fe", "y15_model"))
        for ax, (label, a, b) in zip(axes, panels, strict=True):
            for model, mk, col in (("calibrated", "o", "C0"), ("calibrated-fast", "+", "C2"),
                                   ("ritz", "x", "C3")):
                pts = [(getattr(r, a), getattr(r, b)) for r in res[model] if r is not None]
                pts = [(x, y) for x, y in pts if x is not None and y is not None
                       and math.isfinite(x) and math.isfinite(y)]
                if not pts:
                    continue
                x, y = np.array(pts).T
                scale = 1e3 if label in ("Pc", "Ph") else 1.0
                ax.plot(x / scale, y / scale, mk, color=col, ms=4, label=model)
            lims = ax.get_xlim()
            ax.plot(lims, lims, "k-", lw=0.8)
            for f in (0.9, 1.1):
                ax.plot(lims, [f * v for v in lims], "k:", lw=0.6)
            unit = " (kPa)" if label in ("Pc", "Ph") else ""
            ax.set_xlabel(f"FE {label}{unit}")
            ax.set_ylabel(f"model {label}{unit}")
            ax.set_title(f"{label}: {kind}, {name} held out")
            ax.legend(fontsize=8)
        fig.tight_layout()
        f = out / f"parity_{name}.png"
        fig.savefig(f, dpi=110)
        plt.close(fig)
        files.append(f.name)
        # worst five by curve error
        cal = res["calibrated"]
        order = sorted((i for i, r in enumerate(cal) if r is not None
                        and math.isfinite(r.curve_error)),
                       key=lambda i: -cal[i].curve_error)[:5]
        if order:
            fig, axes = plt.subplots(1, len(order), figsize=(3.3 * len(order), 3.4),
                                     squeeze=False)
            for ax, i in zip(axes[0], order, strict=False):
                fe, cm, rz = res["curves"][i]
                for resp, lab, st in ((fe, "FE", "k-"), (cm, "calibrated", "C0--"),
                                      (rz, "ritz", "C3:")):
                    if isinstance(resp, Exception):
                        continue
                    P, y = signal_of_loading(resp, kind)
                    ax.plot(y, P / 1e3, st, label=lab)
                pc = cal[i].pc_fe
                if pc:
                    ax.axhline(1.5 * pc / 1e3, color="grey", lw=0.6)
                ax.set_title(f"#{cal[i].design}: curve err {100 * cal[i].curve_error:.0f} %",
                             fontsize=9)
                ax.set_xlabel(SIGNAL_LABEL[kind], fontsize=8)
                ax.set_ylabel("P (kPa)")
            axes[0][0].legend(fontsize=7)
            fig.tight_layout()
            f = out / f"worst_{name}.png"
            fig.savefig(f, dpi=100)
            plt.close(fig)
            files.append(f.name)
    return files


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs/validation")
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    sets = load_reference()
    results = [evaluate(k, s) for k, s in CHECKS if s in sets]
    files = plot(results, Path(args.out))
    metrics: dict[str, Any] = {}
    print("| kind | set | model | designs | Pc n (one-sided) | Pc median | p90 | max | "
          "Ph n (one-sided) | Ph median | "
          "p90 | max | curve ≤ 10 % | curve n | curve error median | p90 | max | "
          "graph ≤ 10 % | graph n | graph error median | p90 | max |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
          "---|---|")
    for res in results:
        for model in ("calibrated", "calibrated-fast", "ritz"):
            if not res.get(model):
                continue
            s = _table(res[model])
            metrics[f"{res['set']}/{model}"] = s
            within = s.get("curves_within_10pct", math.nan)
            graphs = s.get("graphs_within_10pct", math.nan)
            print(f"| {res['kind']} | {res['set']} | {model} | {s['designs']} | "
                  f"{_fmt(s, 'pc')} | {_fmt(s, 'ph')} | "
                  f"{100 * within:.0f} % | {_fmt(s, 'curve')} | "
                  f"{100 * graphs:.0f} % | {_fmt(s, 'graph')} |")
    print()
    print("| kind | pooled sets | model | designs | Pc median | p90 | Ph median | p90 | "
          "curve ≤ 10 % | graph ≤ 10 % | Pc in ±1σ / ±2σ | Ph in ±1σ / ±2σ |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    by_set = {res["set"]: res for res in results}
    for kind, label, names in POOLS:
        for model in ("calibrated", "calibrated-fast"):
            rows = [r for n in names if n in by_set for r in by_set[n].get(model) or []]
            if not rows:
                continue
            s = _table(rows)
            metrics[f"pooled/{kind}/{label}/{model}"] = {**s, "sets": list(names)}
            print(f"| {kind} | {label} | {model} | {s['designs']} | "
                  f"{_pct(s['pc'], 'median')} | {_pct(s['pc'], 'p90')} | "
                  f"{_pct(s['ph'], 'median')} | {_pct(s['ph'], 'p90')} | "
                  f"{_share(s['curves_within_10pct'])} | {_share(s['graphs_within_10pct'])} | "
                  f"{_share(s['pc_within_1sigma'])} / {_share(s['pc_within_2sigma'])} | "
                  f"{_share(s['ph_within_1sigma'])} / {_share(s['ph_within_2sigma'])} |")
    metrics["figures"] = files
    if args.json:
        Path(args.json).write_text(json.dumps(metrics, indent=1, default=str) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
