"""A wall without strain hardening within reach (neo-Hooke) balloons past its limit point
with the pressure falling: a runaway. The Ritz model answers it (Pc the limit point, no Ph,
the path up to V/V0 = 25, ``meta["runaway"]``) instead of failing with "ran out of steps …
a maximum pressure below 0.09 kPa can be traced" (before stop 61, also for every neo-Hooke
library fit: the calibrated model hands such walls to the Ritz model)."""

from __future__ import annotations

import numpy as np
import pytest

from multimorph.geometry import CellGeometry
from multimorph.materials import Material
from multimorph.rom import RUNAWAY_VOLUME_RATIO, runaway_points, simulate_cells, solve_cell

MU = 2.45e5


def _cell(wall: Material) -> CellGeometry:
    return CellGeometry(20e-3, 10e-3, 8e-3, 0.8e-3, 2e-3, 1.5e-3, 1.5e-3, material=wall,
                        bottom_material=wall.scaled(4.9))


def test_runaway_points_keeps_a_falling_path_to_the_volume_cap() -> None:
    P = np.array([0.0, 1.0, 2.0, 1.5, 1.0, 0.8, 0.7])
    V = np.array([1.0, 1.5, 2.0, 6.0, 20.0, 30.0, 50.0])
    assert runaway_points(P, V) == 6                       # up to the first point past 25
    assert runaway_points(P, np.sqrt(V)) is None           # never got that far (7 V0)
    assert runaway_points(P[:5], V[:5]) is None
    rising = P.copy()
    rising[4] = 1.6                                        # the pressure turns up again
    assert runaway_points(rising, V) is None
    assert runaway_points(np.array([0.0, 1.0, 2.0]), np.array([1.0, 30.0, 40.0])) is None


def test_a_neo_hookean_cell_runs_away_at_its_limit_point() -> None:
    r = solve_cell(_cell(Material("neo-hooke", {"mu": MU})), MU)
    ch = r.characteristic
    P, V = r.path.pressure, r.path.volume / r.path.volume[0]
    i = int(np.argmax(P))
    assert ch.critical_kind == "limit_point" and ch.hardening is None
    assert ch.critical == pytest.approx(P[i], rel=2e-3)        # the vertex of the fold
    assert np.all(np.diff(P[i:]) <= 0)                          # falls all the way
    assert V[-2] < RUNAWAY_VOLUME_RATIO <= V[-1]                 # ends at the volume cap
    assert r.meta["runaway"]["limit_pressure"] == pytest.approx(P[i])
    # under pressure control the loading curve ends at the fold: nothing to land on
    assert r.loading.pressure.max() == pytest.approx(P[i]) and not r.path.stable[-1]
    # the batch path answers the same
    b = simulate_cells([_cell(Material("neo-hooke", {"mu": MU}))], MU)[0]
    assert b.characteristic.critical == pytest.approx(ch.critical, rel=1e-9)
    assert b.meta["runaway"]["reason"] == r.meta["runaway"]["reason"]
    assert b.meta["runaway"]["volume_ratio_end"] == pytest.approx(
        r.meta["runaway"]["volume_ratio_end"], rel=1e-12)


def test_gent_walls_tend_to_the_neo_hookean_runaway_as_jm_grows() -> None:
    """Gent → neo-Hooke as Jm → ∞: a Jm of 10⁴ has no hardening before V/V0 = 25 either,
    and its limit point is the neo-Hookean one; Jm = 20 hardens and reaches p_max."""
    nh = solve_cell(_cell(Material("neo-hooke", {"mu": MU})), MU).characteristic.critical
    big = solve_cell(_cell(Material("gent", {"mu": MU, "jm": 1e4})), MU)
    assert "runaway" in big.meta
    assert big.characteristic.critical == pytest.approx(nh, rel=5e-3)
    small = solve_cell(_cell(Material("gent", {"mu": MU, "jm": 20.0})), MU)
    assert "runaway" not in small.meta and small.characteristic.hardening is not None
