"""How a wall of another law is placed in the Gent-calibrated model (stop 49).

The calibrated model learned Gent walls. A wall of another law enters as an *effective
Gent wall*: since stop 49 a Yeoh-like wall (any law whose uniaxial curve a Yeoh law
carries: Yeoh, reduced polynomial, Mooney-Rivlin with a stiffening curve) is placed by a
mapping calibrated on FE of Yeoh-walled cells (the ``yeoh2_mirror`` set), an implicit
space mapping of the law:

* the law's **shape** ``k`` is the c20/c10 of the Yeoh law (c10 = μ/2, c30 = 0) closest to
  its uniaxial nominal stress over λ ∈ [1.05, 3] (relative least squares, closed form): a
  Yeoh wall's own c20/c10 (c30 = 0), how fast the wall's modulus rises with I1;
* its effective Gent wall has μ_eff = s(k) μ and Jm_eff(k), ln s and ln Jm_eff linear in
  ln k, fitted so that the calibrated model of the effective cell reproduces the FE of the
  Yeoh cells (Pc, Ph and the curve as a graph; :mod:`._law_fit`).

Why not the Gent law closest to the wall's stress curve (``_box.equivalent_jm``, the
placement until stop 48): the cell's Pc is set by moderate strains and its curve past Pc
by large ones, and no one Gent curve of the wall's μ matches a Yeoh curve at both. On the
`yeoh` sets the closest Gent (λ ≤ 3) read Pc well and the curves 25-38 % off as graphs
(the Gent wall locks, the Yeoh wall does not); fitted to λ ≤ 4 or equibiaxially, the
curves came closer and Pc went 7-10 % off (docs/validation.md §4, stop 49). A wall whose
shape lies outside the mapping's calibrated range (neo-Hooke k = 0, an Ogden rubber)
keeps the closest-Gent placement (and is answered by the Ritz model where that Jm is
outside the box).

Whether a placed wall's *stretching or tilted* cell activates at all (stop 50) is the
wall's own law's to say, not its effective Gent wall's: the Gent stretching cells of the
data set activate (383 of 393: a limit point, or below Jm ≈ 18 a knee as the wall locks),
while in FE a Yeoh-walled stretching cell snaps up to c20/c10 = 0.036 and above 0.043
stretches without a knee (``yeoh_stretching_mirror``, 30 of 30), and a tilted one twists
without a knee above it on 9 of 12 (``yeoh_twisting``; a weak max-slope knee on the other
3). The threshold is the one at which a thin spherical membrane of the law loses its
pressure maximum (c20/c10 = 0.0424 for Yeoh): :func:`membrane_limit_point`, read on the
law's own equibiaxial stress. Bending cells of such walls still activate in FE.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from multimorph.geometry import CellGeometry, TiltedCell

__all__ = ["KNEELESS_KINDS", "LAW_MAP_SET", "MEMBRANE_VOLUME_RATIO", "SHAPE_STRETCH",
           "drucker_limit", "effective_cell", "effective_material", "law_shape",
           "membrane_limit_point", "membrane_summary", "unstable_laws", "wall_activates",
           "widen_band"]

#: The FE set the mapping is calibrated on (its training designs; the held-out fifth
#: checks it, with the `yeoh` sets).
LAW_MAP_SET = "yeoh2_mirror"
#: The uniaxial stretches over which a law's shape is read.
SHAPE_STRETCH = (1.05, 3.0)
#: Relative tolerance on the mapping's calibrated range of k (as ``_box.EDGE_RTOL``).
SHAPE_RTOL = 0.02
#: The cell kinds whose activation is the wall's membrane's to say (:func:`wall_activates`).
KNEELESS_KINDS = ("stretching", "twisting")
#: How far a wall's spherical membrane is inflated when its limit point is sought (V/V0:
#: the chamber volume to which the FE data set traces its cells).
MEMBRANE_VOLUME_RATIO = 25.0


def law_shape(material: Any) -> float:
    """c20/c10 of the Yeoh law (c10 = μ/2, c30 = 0) nearest to ``material``'s uniaxial
    nominal stress over :data:`SHAPE_STRETCH` (relative least squares); a Yeoh wall with
    c30 = 0 gives its own c20/c10. NaN where the law's curve cannot be read."""
    if material.model == "yeoh" and not material.params.get("c30", 0.0):
        return float(material.params["c20"]) / float(material.params["c10"])
    lam = np.linspace(*SHAPE_STRETCH, 60)
    try:
        s = np.asarray(material.nominal_stress("uniaxial", lam), float)
    except Exception:  # a law locking inside the range: no Yeoh shape
        return math.nan
    c10 = 0.5 * material.shear_modulus
    x = lam ** 2 + 2.0 / lam - 3.0
    w1 = s / (2.0 * (lam - lam ** -2))        # the law's dW/dI1 along the curve (I1 laws)
    if not (np.all(np.isfinite(w1)) and np.all(w1 > 0) and c10 > 0):
        return math.nan
    a = 2.0 * x / w1
    b = (w1 - c10) / w1
    return float(np.dot(a, b) / np.dot(a, a)) / c10


def _membrane_pressure(material: Any) -> tuple[np.ndarray, np.ndarray] | None:
    """Hoop stretch and pressure (up to a constant) of a thin spherical membrane of
    ``material`` inflated to :data:`MEMBRANE_VOLUME_RATIO` × its volume: P = 2 H0 s(λ) /
    (R0 λ²), s the law's equibiaxial nominal stress (``Material.nominal_stress``). None
    where the law's curve cannot be read (it locks inside the range)."""
    lam = np.linspace(1.0005, MEMBRANE_VOLUME_RATIO ** (1.0 / 3.0), 600)
    try:
        s = np.asarray(material.nominal_stress("equibiaxial", lam), float)
    except Exception:   # lock-up inside the range
        return None
    p = s / lam ** 2
    return (lam, p) if np.all(np.isfinite(p)) else None


def membrane_limit_point(material: Any) -> bool | None:
    """Whether a thin spherical membrane of ``material``, inflated to
    :data:`MEMBRANE_VOLUME_RATIO` × its volume, passes a pressure maximum (snaps), read on
    the law's own energy function (:func:`_membrane_pressure`). A Yeoh law keeps the
    maximum up to c20/c10 = 0.0424 (neo-Hooke always, Gent above Jm ≈ 17.7). None where
    the law's curve cannot be read (it locks inside the range: a locking wall stiffens to
    a knee whether or not it snaps)."""
    curve = _membrane_pressure(material)
    return None if curve is None else bool(np.any(np.diff(curve[1]) < 0.0))


#: :func:`drucker_limit` per (law, parameters).
_DRUCKER: dict[tuple[Any, ...], float | None] = {}


def drucker_limit(material: Any) -> float | None:
    """The equibiaxial stretch at which ``material`` loses Drucker stability in tension,
    within the stretches a chamber wall reaches (up to :data:`MEMBRANE_VOLUME_RATIO`^(1/3),
    a balloon's hoop stretch at that volume), or None where it stays stable there.

    A law fitted to uniaxial data alone can lose it early: every Mooney–Rivlin fit of the
    library has c01 < 0 and loses it at λ ≈ 1.04–1.7 (its balloon "peaks" at a hoop
    stretch of 1.03–1.27), where its Gent, Yeoh, reduced-polynomial and neo-Hooke fits stay
    stable. A cell model on such a wall describes the fit, not the elastomer (``multimorph
    material show NAME --model LAW`` prints "Drucker-stable: False"). Cached per law and
    parameters (:data:`_DRUCKER`)."""
    if material.model in ("gent", "neo-hooke"):
        return None                      # stable for every admissible parameter set
    if ((material.model == "yeoh" or material.model.startswith("reduced-polynomial"))
            and all(float(v) >= 0.0 for v in material.params.values())):
        return None                      # W convex and rising in I1: stable (no check)
    key = (material.model, tuple(sorted((k, float(v)) for k, v in material.params.items())))
    if key not in _DRUCKER:
        from multimorph.materials import drucker_stability

        report = drucker_stability(material, (0.5, MEMBRANE_VOLUME_RATIO ** (1.0 / 3.0)))
        _DRUCKER[key] = report.first_unstable["equibiaxial"][1]
    return _DRUCKER[key]


def unstable_laws(cell: CellGeometry | TiltedCell) -> dict[str, dict[str, Any]]:
    """The cell's elastomers (``"wall"``, ``"bottom"``) whose law loses Drucker stability
    where a chamber wall is stretched (:func:`drucker_limit`): ``{elastomer: {"model",
    "name", "equibiaxial_stretch"}}``; empty where both are stable."""
    c = cell.cell if isinstance(cell, TiltedCell) else cell
    out: dict[str, dict[str, Any]] = {}
    for which, m in (("wall", c.material), ("bottom", c.bottom_material)):
        lam = None if m is None else drucker_limit(m)
        if lam is not None:
            out[which] = {"model": m.model, "name": m.name, "equibiaxial_stretch": lam}
    return out


def membrane_summary(material: Any) -> dict[str, Any]:
    """What a thin balloon of ``material`` does (:func:`membrane_limit_point`) and what
    that means for the calibrated model's stretching and tilted cells
    (:func:`wall_activates`): ``{"limit_point", "limit_stretch", "cells_activate"}``."""
    curve = _membrane_pressure(material)
    lp = None if curve is None else bool(np.any(np.diff(curve[1]) < 0.0))
    at = None
    if curve is not None and lp:
        lam, p = curve
        at = float(lam[int(np.argmax(np.diff(p) < 0.0))])
    return {"limit_point": lp, "limit_stretch": at,
            "cells_activate": wall_activates(material)}


def wall_activates(material: Any) -> bool:
    """Whether a stretching or tilted cell (:data:`KNEELESS_KINDS`) of a ``material`` wall
    answered through an effective Gent wall activates: False for a stiffening non-Gent law
    (a positive Yeoh shape, the family FE checked) whose membrane has no limit point
    (:func:`membrane_limit_point`); True otherwise (Gent walls, which the model learned,
    and laws FE has not told about). A bending cell of such a wall still activates in FE
    (its κ rises steeply as the top wall bulges: `yeoh2_mirror`)."""
    if material.model == "gent":
        return True
    k = law_shape(material)
    if not (math.isfinite(k) and k > 0):
        return True
    return membrane_limit_point(material) is not False


def effective_material(material: Any, law_map: dict[str, Any] | None
                       ) -> tuple[Any, dict[str, Any] | None]:
    """The effective Gent wall of ``material`` and how it was placed (None for a Gent
    wall, which is itself). Without a mapping, or with a shape outside its range: None
    (the caller keeps the closest-Gent placement, ``_box.equivalent_jm``)."""
    if material.model == "gent" or not law_map:
        return material, None
    k = law_shape(material)
    lo, hi = law_map["shape_range"]
    if not (math.isfinite(k) and lo * (1 - SHAPE_RTOL) <= k <= hi * (1 + SHAPE_RTOL)):
        return material, None
    from multimorph.materials import Material

    lk = math.log(k)
    # held to the walls the fit searched (as it read them: ``_law_fit.fit_law_map``)
    s = float(np.clip(math.exp(law_map["log_mu_factor"][0] + law_map["log_mu_factor"][1] * lk),
                      SEARCH_MU_FACTOR[0], SEARCH_MU_FACTOR[-1]))
    jm = float(np.clip(math.exp(law_map["log_jm"][0] + law_map["log_jm"][1] * lk),
                       SEARCH_JM[0], SEARCH_JM[-1]))
    eff = Material("gent", {"mu": material.shear_modulus * s, "jm": jm},
                   name=f"{material.name or material.model} (effective Gent wall)",
                   break_stretch=material.break_stretch, density=material.density)
    return eff, {"model": material.model, "shape_c20_c10": k, "mu_factor": s,
                 "effective_jm": jm, "rule": "yeoh-shape map",
                 "calibrated_on": law_map.get("set", LAW_MAP_SET)}


def effective_cell(cell: CellGeometry | TiltedCell, law_map: dict[str, Any] | None
                   ) -> tuple[CellGeometry | TiltedCell, dict[str, Any] | None]:
    """``cell`` with each non-Gent elastomer replaced by its effective Gent wall (itself
    and None where nothing is replaced). A Gent bottom at least as stiff as the wall stays
    at least as stiff as its effective wall (``bottom_clamped`` in the record)."""
    c = cell.cell if isinstance(cell, TiltedCell) else cell
    wall, info = effective_material(c.material, law_map)
    bottom, binfo = (effective_material(c.bottom_material, law_map)
                     if c.bottom_material is not None else (None, None))
    if info is None and binfo is None:
        return cell, None
    if c.bottom_material is not None and c.bottom_material == c.material:
        bottom = wall                      # one elastomer stays one elastomer
    clamp = None
    if (info is not None and binfo is None and bottom is not None and bottom is not wall
            and bottom.model == "gent"
            and c.mu <= bottom.shear_modulus < wall.shear_modulus):
        # a bottom at least as stiff as the wall stays so: the map's μ factor would put a
        # bottom of μb/μ just above 1 below the box's edge (μb/μ ≥ 1), out to the Ritz
        # model, for a factor the map applies to the wall alone (stop 50)
        clamp = {"mu_b_over_mu": bottom.shear_modulus / c.mu,
                 "placed_mu_b_over_mu": bottom.shear_modulus / wall.shear_modulus}
        bottom = replace(bottom, params={**bottom.params, "mu": wall.shear_modulus})
    placed = replace(c, material=wall, bottom_material=bottom)
    out: dict[str, Any] = {"wall": info} if info is not None else {}
    if binfo is not None:
        out["bottom"] = binfo
    if clamp is not None:
        out["bottom_clamped"] = clamp
    return (replace(cell, cell=placed) if isinstance(cell, TiltedCell) else placed), out


# ------------------------------------------------ the walls the map may give (``_law_fit``)
#: The effective walls searched per training design: μ factor and Gent Jm (the box's).
SEARCH_MU_FACTOR = np.geomspace(0.7, 1.6, 19)
SEARCH_JM = np.geomspace(9.0, 80.0, 19)
#: The cost of a Pc or Ph one side has and the other lacks although its path got there.
ONE_SIDED_COST = 0.1


def widen_band(value: float | None, band: list[float | None], sigma: float
               ) -> list[float | None]:
    """``band`` (a ±1σ range around ``value``) widened by ``sigma`` of log P in quadrature."""
    lo, hi = band
    if value is None or lo is None or hi is None or not (sigma > 0 and value > 0):
        return band
    s_lo = math.hypot(math.log(value / lo), sigma) if lo > 0 else sigma
    s_hi = math.hypot(math.log(hi / value), sigma) if hi > 0 else sigma
    return [value * math.exp(-s_lo), value * math.exp(s_hi)]
