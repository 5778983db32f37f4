"""ROM vs FE over a grid of cell designs: Pc, Ph and κ(P) (figures in benchmarks/README.md).

The grid varies the three ratios of the paper's Buckingham analysis around our reference
cell (d = 20 mm, w = 10 mm, h = 8 mm; Gent walls μ = 100 kPa, Jm = 30; bottom 10 μ):
top wall ht ∈ {0.8, 1.0, 1.25, 1.5} mm × side wall ws ∈ {1.5, 2.0, 2.5} mm × end wall
df ∈ {1.5, 2.5} mm = 24 designs. The reduced model runs batched (one compile) to 2 μ; FE runs
on the coarse preset (half model) to 0.6 μ or until the chamber volume has grown tenfold
(past Pc and Ph of these cells), so κ(P) is compared on the common pressure range.

The ``lean`` column is a diagnostic of the FE solution at its Pc: how far the top corner of
the chamber (x = ws, mid-length, top of the side wall) has moved outward, as a fraction of
the top wall's half-chord wc/2. The reduced model holds that corner in place (its side walls
bulge between fixed ends), so a large lean is a mode the ROM does not have.

    python benchmarks/fe_rom_grid.py [--mesh coarse] [--out fe_rom_grid.json]

Resumable: the out file is rewritten (atomically) after every design, and a rerun with the
same settings takes the designs it already holds from it instead of running their FE again
(designs that failed are run again; ``--fresh`` ignores the file).
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import time
from pathlib import Path

import numpy as np

from multimorph.fe import FESettings, compare_responses, simulate_cell
from multimorph.geometry import CellGeometry
from multimorph.materials import Material

MU = 1.0e5
HT = (0.8e-3, 1.0e-3, 1.25e-3, 1.5e-3)
WS = (1.5e-3, 2.0e-3, 2.5e-3)
DF = (1.5e-3, 2.5e-3)


def designs() -> list[CellGeometry]:
    wall = Material("gent", {"mu": MU, "jm": 30.0})
    bottom = Material("gent", {"mu": 10 * MU, "jm": 30.0})
    return [CellGeometry(20e-3, 10e-3, 8e-3, ht, 2e-3, ws, df, material=wall,
                         bottom_material=bottom)
            for ht, ws, df in itertools.product(HT, WS, DF)]


def corner_lean(fe: object, g: CellGeometry) -> float | None:
    """Outward motion of the chamber's top corner at mid-length, at the FE Pc, over wc/2."""
    pc = fe.response.characteristic.critical  # type: ignore[attr-defined]
    if pc is None:
        return None
    X = fe.mesh.points  # type: ignore[attr-defined]
    i = int(np.argmin(np.sum((X - [g.ws, g.length / 2, g.hb + g.hc]) ** 2, axis=1)))
    ux = -fe.displacements[:, i, 0]  # type: ignore[attr-defined]  # outward = −x
    return float(np.interp(pc, fe.response.path.pressure, ux) / (0.5 * g.wc))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mesh", default="coarse")
    ap.add_argument("--pmax", type=float, default=0.6, help="FE p_max / μ")
    ap.add_argument("--rom-pmax", type=float, default=2.0, help="ROM p_max / μ")
    ap.add_argument("--max-volume-ratio", type=float, default=10.0)
    ap.add_argument("--out", default="fe_rom_grid.json")
    ap.add_argument("--fresh", action="store_true", help="ignore the designs in --out")
    args = ap.parse_args()
    rows: list[dict[str, object]] = []
    setup = {"mesh": args.mesh, "pmax": args.pmax, "rom_pmax": args.rom_pmax,
             "max_volume_ratio": args.max_volume_ratio}
    out = Path(args.out)
    done: dict[tuple[float, float, float], dict[str, object]] = {}
    if out.exists() and not args.fresh:
        for r in json.loads(out.read_text()):
            if r.get("settings") == setup and "error" not in r:
                done[(r["ht"], r["ws"], r["df"])] = r

    def save() -> None:
        tmp = out.with_name(f".{out.name}.tmp")
        tmp.write_text(json.dumps(rows, indent=1))
        os.replace(tmp, out)

    print(f"{'ht':>5} {'ws':>5} {'df':>5} | {'Pc rom':>7} {'Pc fe':>7} {'rel':>7} | "
          f"{'Ph rom':>7} {'Ph fe':>7} {'rel':>7} | {'κ rel':>6} {'lean':>6} {'FE s':>6}")
    t0 = time.perf_counter()
    from multimorph.rom import simulate_cells

    cells = designs()
    roms = simulate_cells(cells, args.rom_pmax * MU)
    print(f"ROM: {len(cells)} designs in {time.perf_counter() - t0:.0f} s"
          + (f"; {len(done)} FE designs from {out}" if done else ""), flush=True)
    settings = FESettings(mesh=args.mesh, p_max=args.pmax * MU,
                          max_volume_ratio=args.max_volume_ratio)
    for g, rom in zip(cells, roms, strict=True):
        if (g.ht, g.ws, g.df) in done:
            row = done[(g.ht, g.ws, g.df)]
            rows.append(row)
            cp, hp = row["critical_pressure"], row["hardening_pressure"]
            print(f"{g.ht * 1e3:5.2f} {g.ws * 1e3:5.2f} {g.df * 1e3:5.2f} | Pc rel "
                  f"{cp['rel']}, Ph rel {hp['rel']} (done before)", flush=True)
            continue
        try:
            if isinstance(rom, Exception):
                raise rom
            t = time.perf_counter()
            fe = simulate_cell(g, settings)
            c = compare_responses(rom, fe.response)
            c.meta.update(fe_time=time.perf_counter() - t, fe_dof=fe.stats["nfree"],
                          fe_status=fe.stats["stop_reason"] or fe.stats["status"],
                          fe_critical_kind=fe.response.characteristic.critical_kind,
                          fe_lean_at_pc=corner_lean(fe, g))
        except Exception as exc:  # keep going; the table says which design failed
            print(f"{g.ht * 1e3:5.2f} {g.ws * 1e3:5.2f} {g.df * 1e3:5.2f} | failed: {exc}")
            rows.append({"ht": g.ht, "ws": g.ws, "df": g.df, "error": str(exc),
                         "settings": setup})
            save()
            continue

        def f(v: float | None, scale: float = 1.0) -> str:
            return f"{v / scale:7.3f}" if v is not None else "      —"

        print(f"{g.ht * 1e3:5.2f} {g.ws * 1e3:5.2f} {g.df * 1e3:5.2f} | "
              f"{f(c.pc_rom, MU)} {f(c.pc_fe, MU)} {f(c.pc_rel)} | "
              f"{f(c.ph_rom, MU)} {f(c.ph_fe, MU)} {f(c.ph_rel)} | "
              f"{f(c.kappa_rel_max)[1:]} {f(c.meta['fe_lean_at_pc'])[1:]} "
              f"{c.meta['fe_time']:6.1f}", flush=True)
        rows.append({"ht": g.ht, "ws": g.ws, "df": g.df, **c.to_dict(), "settings": setup})
        save()
    pc = np.array([r["critical_pressure"]["rel"] for r in rows
                   if "critical_pressure" in r and r["critical_pressure"]["rel"] is not None])
    if len(pc):
        print(f"Pc: {len(pc)} designs, median |rel| {np.median(np.abs(pc)):.3f}, "
              f"max |rel| {np.max(np.abs(pc)):.3f}, within 15 %: {np.sum(np.abs(pc) <= 0.15)}")
    print(f"total {time.perf_counter() - t0:.0f} s")
    save()


if __name__ == "__main__":
    main()
