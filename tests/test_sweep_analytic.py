"""A test-only analytic sweep backend (thin Gent sphere), and its own oracle checks.

NOT the physics of a pneu-net cell: it maps a cell to a thin sphere of radius
R = min(wc, dc)/2 and wall thickness H = ht so that the sweep machinery (batching, store,
resume, schedulers) can be tested before and independently of the reduced model. Its
"curvature" is a proxy κ = (λ − 1)/d with λ the hoop stretch.

Thin sphere, incompressible Gent (derived by equilibrium of a hemisphere with membrane
stretches λ, λ, λ⁻²):  P R/(μ H) = 2 (λ⁻¹ − λ⁻⁷) / (1 − (2λ² + λ⁻⁴ − 3)/Jm).
Neo-Hookean limit (Jm → ∞): maximum at λ = 7^(1/6), P R/(μ H) = 12/(7·7^(1/6)) ≈ 1.2395.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pytest

from multimorph.geometry import CellGeometry
from multimorph.materials import Material
from multimorph.response import CharacteristicPressures, EquilibriumPath, Response
from multimorph.sweep import register_backend


def sphere_pressure(lam: np.ndarray, mu: float, jm: float, h_over_r: float) -> np.ndarray:
    """Gauge pressure (Pa) of a thin Gent sphere at hoop stretch ``lam``."""
    i1m3 = 2 * lam**2 + lam**-4 - 3
    return mu * h_over_r * 2 * (1 / lam - lam**-7) / (1 - i1m3 / jm)


class SphereBackend:
    """Thin-sphere stand-in model (test only). Options: ``fail_top_wall_above`` (m): designs
    with a thicker top wall raise (only while the file ``fail_while_exists`` exists, if
    given); ``delay`` (s): sleep per batch; ``n_points``."""

    name = "sphere"
    batch_size = 4

    def evaluate_batch(self, designs: Sequence[CellGeometry], pmax: float,
                       outputs: Sequence[str], options: Mapping[str, Any]) -> list[Any]:
        time.sleep(float(options.get("delay", 0.0)))
        limit = options.get("fail_top_wall_above")
        flag = options.get("fail_while_exists")
        if flag is not None and not os.path.exists(flag):
            limit = None
        if limit is not None and any(d.top_wall > limit for d in designs):
            raise ValueError("synthetic failure (batch)")
        return [self._one(d, pmax, int(options.get("n_points", 60))) for d in designs]

    @staticmethod
    def _one(cell: CellGeometry, pmax: float, n: int) -> Response:
        r = 0.5 * min(cell.chamber_width, cell.chamber_length)
        jm = cell.material.jm
        lam_max = 6.0
        if math.isfinite(jm):  # 2λ² + λ⁻⁴ − 3 = 0.98 Jm
            lam_max = min(lam_max, math.sqrt((0.98 * jm + 3) / 2))
        lam = np.linspace(1.0, lam_max, n)
        p = sphere_pressure(lam, cell.mu, jm, cell.top_wall / r)
        keep = np.cumsum(p > pmax) == 0
        lam, p = lam[keep], p[keep]
        kappa = (lam - 1.0) / cell.length
        dp = np.gradient(p, lam)
        stable = dp > 0
        peaks = np.flatnonzero((dp[:-1] > 0) & (dp[1:] <= 0))
        if peaks.size:
            ic, kind = int(peaks[0]), "limit_point"
            valley = ic + int(np.argmin(p[ic:]))
            ih: int | None = valley if valley > ic else None
        else:
            ic, kind, ih = int(np.argmax(np.gradient(kappa, p))), "max_slope", None
        path = EquilibriumPath(p, kappa, 0 * p, lam, 0 * p, lam, stable)
        ch = CharacteristicPressures(
            float(p[ic]), kind, None if ih is None else float(p[ih]), None,
            {"critical": float(kappa[ic]), "hardening": None if ih is None
             else float(kappa[ih]), "failure": None})
        return Response(path, path, path, ch, cell.length, cell.mu, "sphere")


# specs name it "sphere" (a spec names registered backends only, never an import path)
register_backend("sphere", SphereBackend)


def _cell(jm: float = 1e9, ht: float = 1e-4) -> CellGeometry:
    m = Material("gent", {"mu": 1.0, "jm": jm})
    return CellGeometry(20e-3, 10e-3, 8e-3, ht, 2e-3, 2e-3, 2e-3, material=m)


def test_sphere_backend_neo_hookean_limit_point() -> None:
    # chamber 6 mm × 16 mm -> R = 3 mm; H/R = 1/30; neo-Hookean limit P R/(μ H) ≈ 1.2395
    cell = _cell()
    resp = SphereBackend._one(cell, 1e9, 4000)
    p_ref = 12 / (7 * 7 ** (1 / 6)) * cell.top_wall / 3e-3
    assert resp.characteristic.critical_kind == "limit_point"
    # grid resolution 5/4000 in λ; the maximum is flat, error O(Δλ²)
    assert resp.characteristic.critical == pytest.approx(p_ref, rel=1e-5)


def test_sphere_backend_no_limit_point_for_small_jm() -> None:
    # the thin Gent sphere has a limit point only for Jm above ≈ 17.64 (design.md §4)
    resp = SphereBackend._one(_cell(jm=15.0), 1e9, 400)
    assert resp.characteristic.critical_kind == "max_slope"
    resp = SphereBackend._one(_cell(jm=20.0), 1e9, 400)
    assert resp.characteristic.critical_kind == "limit_point"
