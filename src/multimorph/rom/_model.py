"""The reduced model of one unit cell: from a :class:`CellGeometry` to a :class:`Response`."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from multimorph.errors import SpecError
from multimorph.geometry import CellGeometry
from multimorph.materials._material import Material
from multimorph.outcome import Outcome
from multimorph.response import EquilibriumPath, Response, build_response
from multimorph.rom._cell_energy import COORDINATES, RomOptions, cell_kernel
from multimorph.rom._continuation import (
    REASON_TEXT,
    ContinuationError,
    RawPath,
    TracerSettings,
    make_tracer,
    raw_path_from_arrays,
)
from multimorph.rom._notice import announced

__all__ = ["DEFAULT_SETTINGS", "RUNAWAY_VOLUME_RATIO", "cell_theta", "cell_tracer",
           "material_theta", "options_for", "runaway_points", "runaway_record", "solve_cell"]

#: A trace that ran out of steps while its chamber grew past this volume ratio with the
#: pressure falling all the way from its limit point is a runaway (a wall without strain
#: hardening within reach: neo-Hooke, or Gent of a very large Jm), kept up to the first
#: point past it: the stop of the FE reference data set's runs (``max_volume_ratio``).
RUNAWAY_VOLUME_RATIO = 25.0


def runaway_points(pressure: np.ndarray, volume: np.ndarray) -> int | None:
    """How many points of a trace that ran out of steps make a runaway path, or None.

    A runaway: up to the first point where the chamber has grown past
    :data:`RUNAWAY_VOLUME_RATIO` × its first volume, the pressure reaches its largest value
    at an interior point (the limit point) and falls from there without rising again (to
    10⁻⁹ of it). The path is kept up to that point: under pressure control the cell snaps
    at the limit point with no stable branch to land on before that volume (its loading
    curve ends there, Pc is the limit point, there is no Ph), the volume at which the FE
    reference data set's runs stop too. None where the pressure rises again before it
    (strain hardening ahead: the trace was just too long) or the chamber never got that
    far.

    Examples
    --------
    >>> P = np.array([0.0, 1.0, 2.0, 1.5, 1.0, 0.8, 0.7])
    >>> V = np.array([1.0, 1.5, 2.0, 6.0, 20.0, 30.0, 50.0])
    >>> runaway_points(P, V)
    6
    >>> runaway_points(P, np.sqrt(V)) is None, runaway_points(P[:5], V[:5]) is None
    (True, True)
    """
    p = np.asarray(pressure, float)
    v = np.asarray(volume, float)
    if p.size < 3 or not (v.size == p.size and np.all(np.isfinite(v)) and v[0] > 0):
        return None
    over = np.flatnonzero(v >= RUNAWAY_VOLUME_RATIO * v[0])
    if over.size == 0:
        return None
    end = int(over[0])
    i = int(np.argmax(p[:end + 1]))
    if i == 0 or i >= end or np.any(np.diff(p[i:end + 1]) > 1e-9 * p[i]):
        return None
    return end + 1

#: Step control of the cell tracer: coordinates (κd, φt, φs, e, ψ) and p = P/μ scaled so that
#: one unit of arc length is about a radian of bulge or bend, or 0.2 μ of pressure. A Newton
#: correction below 1e-4 ends a step (the accepted point's residual is then ~1e-8; κ(P)
#: moves by < 1e-8 relative against a fully converged trace, at 40 % fewer evaluations).
#: 600 steps: soft walls traced to many times their μ (P/μ = 4.7 for Ecoflex 00-30 at
#: 70 kPa) need more than 200 steps of 0.024 μ on the hardening plateau.
DEFAULT_SETTINGS = TracerSettings(q_scale=(1.0, 1.0, 1.0, 0.1, 1.0), p_scale=0.2, ds0=0.02,
                                  ds_max=0.12, n_steps=600, n_newton=8, tol=1e-9,
                                  step_tol=1e-4)


def options_for(symmetric: bool, options: RomOptions | None = None) -> RomOptions:
    """The model options for a cell (or a batch of cells): ``options`` (default
    :class:`RomOptions`) with ``mirror`` switched on when ``symmetric`` (a mirror-symmetric,
    stretching cell: ``CellGeometry.symmetric``)."""
    opts = options or RomOptions()
    if symmetric and not opts.mirror:
        opts = replace(opts, mirror=True)
    return opts


def material_theta(material: Material, mu: float) -> dict[str, float]:
    """Law parameters with moduli divided by ``mu`` (dimensionless, for the kernel)."""
    law = material.law
    p = material.params_1972
    return {k: (p[k] / mu if u == "Pa" else p[k])
            for k, u in zip(law.param_names, law.param_units, strict=True)}


def cell_theta(cell: CellGeometry) -> dict[str, Any]:
    """Dimensionless kernel parameters of ``cell``: lengths / d and moduli / μ."""
    d = cell.length
    mu = cell.mu
    assert cell.bottom_material is not None
    return {"w": cell.width / d, "h": cell.height / d, "ht": cell.top_wall / d,
            "hb": cell.bottom_wall / d, "ws": cell.side_wall / d, "df": cell.end_wall / d,
            "mw": material_theta(cell.material, mu),
            "mb": material_theta(cell.bottom_material, mu)}


def free_settings(settings: TracerSettings, options: RomOptions) -> TracerSettings:
    """``settings`` with ``q_scale`` restricted to the free coordinates of ``options``."""
    if len(settings.q_scale) == len(COORDINATES):
        return replace(settings, q_scale=tuple(settings.q_scale[i] for i in options.free))
    return settings


@lru_cache(maxsize=16)
def cell_tracer(wall_law: str, bottom_law: str, options: RomOptions,
             settings: TracerSettings) -> tuple[Any, Any, Any]:
    ck = cell_kernel(wall_law, bottom_law, options)
    tracer = announced(jax.jit(make_tracer(ck.energy, ck.n_free,
                                           free_settings(settings, options),
                                           ck.admissible, ck.derivatives)),
                       f"tracer {wall_law} {bottom_law} {options!r} {settings!r}")
    measures = jax.jit(jax.vmap(ck.measures, in_axes=(0, 0, None)))
    return ck, tracer, measures


def padded_measures(fn: Any, qf: Any, p: Any, theta: Any) -> dict[str, np.ndarray]:
    """Evaluate a vmapped measures kernel on path points padded to a power-of-two length.

    Paths have as many points as the tracer accepted, which differs from design to design;
    padding (by repeating the last point) to bucketed lengths keeps the number of compiled
    shapes small instead of compiling once per path length.
    """
    qf = np.asarray(qf, float)
    p = np.asarray(p, float)
    m = qf.shape[0]
    n = 1 << max(4, (m - 1).bit_length())
    qpad = np.concatenate([qf, np.repeat(qf[-1:], n - m, axis=0)])
    ppad = np.concatenate([p, np.repeat(p[-1:], n - m)])
    out = fn(jnp.asarray(qpad), jnp.asarray(ppad), theta)
    return {k: np.asarray(v)[:m] for k, v in out.items()}


def _check_pmax(p_max: float) -> float:
    p = float(p_max)
    if not (math.isfinite(p) and p > 0):
        raise SpecError(f"p_max must be a positive pressure, got {p_max!r} Pa")
    return p


@dataclass(frozen=True)
class _Solved:
    raw: RawPath
    q: np.ndarray
    meas: dict[str, np.ndarray]


def path_from_raw(cell: CellGeometry, raw: RawPath, q: np.ndarray,
                  meas: dict[str, np.ndarray]) -> EquilibriumPath:
    """Dimensional :class:`EquilibriumPath` of a traced cell (Pa, 1/m, m³)."""
    d, mu = cell.length, cell.mu
    v0 = cell.chamber_width * cell.chamber_height * cell.chamber_length
    return EquilibriumPath(
        pressure=raw.p * mu,
        curvature=q[:, 0] / d,
        twist_rate=np.zeros(len(raw.p)),
        axial_stretch=1.0 + q[:, 3],
        volume=v0 + np.asarray(meas["volume"]) * d**3,
        peak_stretch=np.asarray(meas["peak_stretch"]),
        stable=raw.stable,
        extra={"q": q, "lockup": np.asarray(meas["lockup"]),
               "tangent_p": raw.tangent_p},
    )


def solve_cell(cell: CellGeometry, p_max: float, *, options: RomOptions | None = None,
               settings: TracerSettings | None = None) -> Response:
    """Equilibrium path, observed curves and characteristic pressures of a unit cell.

    Parameters
    ----------
    cell : CellGeometry
        The cell (lengths in m, materials with invariant-based laws).
    p_max : float
        Largest gauge pressure to trace to (Pa).
    options : RomOptions, optional
        Modelling switches (rigid walls/bottom, end taper, wall bending, quadrature);
        ``mirror`` is switched on for a symmetric cell (``cell.symmetric``), whose Pc and Ph
        are then read on the axial stretch.
    settings : TracerSettings, optional
        Step control (defaults to :data:`DEFAULT_SETTINGS`).

    Returns
    -------
    Response
        ``backend = "rom"``; ``path.extra["q"]`` holds the coordinates (κd, φt, φs, e, ψ).

    Raises
    ------
    ContinuationError
        If the path cannot be traced to ``p_max`` (the message gives the pressure, the step
        and the reason, e.g. Gent lock-up or a Newton failure).

    Examples
    --------
    >>> from multimorph.materials import Material
    >>> m = Material("gent", {"mu": 2.45e5, "jm": 20.0})
    >>> cell = CellGeometry(20e-3, 10e-3, 8e-3, 0.8e-3, 2e-3, 1.5e-3, 1.5e-3, material=m,
    ...                     bottom_material=m.scaled(5.0))
    >>> r = solve_cell(cell, 150e3)
    >>> r.characteristic.critical_kind
    'max_slope'
    """
    opts = options_for(cell.symmetric, options)
    st = settings or DEFAULT_SETTINGS
    p_max = _check_pmax(p_max)
    assert cell.bottom_material is not None
    ck, tracer, measures = cell_tracer(cell.material.model, cell.bottom_material.model, opts,
                                      st)
    theta = jax.tree_util.tree_map(jnp.asarray, cell_theta(cell))
    mu = cell.mu
    out = tracer(jnp.zeros(ck.n_free), theta, jnp.asarray(p_max / mu))
    raw = raw_path_from_arrays(out, ck.n_free)
    if not raw.ok and raw.outcome is not Outcome.MAX_STEPS:
        raise _trace_error(raw, p_max, mu)
    qf = raw.q
    meas = padded_measures(measures, qf, raw.p, theta)
    q = np.zeros((qf.shape[0], len(COORDINATES)))
    q[:, list(opts.free)] = qf
    path = path_from_raw(cell, raw, q, meas)
    meta: dict[str, Any] = {}
    if not raw.ok:
        keep = runaway_points(path.pressure, path.volume)
        if keep is None:
            raise _trace_error(raw, p_max, mu)
        path = path.take(slice(0, keep))
        meta["runaway"] = runaway_record(path)
    return build_response(
        path, length=cell.length, shear_modulus=mu, backend="rom",
        break_stretch=cell.material.break_stretch, signal=cell.signal,
        meta={"model": "cell-ritz", "coordinates": list(COORDINATES),
              "options": opts.__dict__.copy(), "points": len(path),
              "rejected_steps": raw.n_rejected, "evaluations": raw.n_eval,
              "p_max": p_max, **meta})


def runaway_record(path: EquilibriumPath) -> dict[str, Any]:
    """What a response says of a runaway path (:func:`runaway_points`)."""
    i = int(np.argmax(path.pressure))
    return {"limit_pressure": float(path.pressure[i]),
            "volume_ratio_end": float(path.volume[-1] / path.volume[0]),
            "reason": ("no strain hardening within reach: past its limit point the pressure "
                       "falls as the chamber grows, up to V/V0 = "
                       f"{RUNAWAY_VOLUME_RATIO:g} (a runaway under pressure control, nothing "
                       "to land on; the path ends there)")}


def _trace_error(raw: RawPath, p_max: float, mu: float) -> ContinuationError:
    stalled = raw.outcome is Outcome.STALLED
    where = (f" at step {raw.fail_step}, P = {raw.fail_p * mu / 1e3:.4g} kPa"
             if stalled else "")
    why = raw.outcome.message + (f": {REASON_TEXT.get(raw.reason, '')}" if stalled else "")
    last = raw.p[-1] * mu / 1e3
    return ContinuationError(
        f"cell ROM: could not trace the equilibrium path to {p_max / 1e3:.4g} kPa"
        f"{where} ({why}; last converged P = {last:.4g} kPa); a maximum pressure below "
        f"{last:.4g} kPa can be traced")
