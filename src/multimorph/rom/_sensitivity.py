r"""Sensitivities of a traced cell path to the cell's lengths, by the implicit function theorem.

Every point (q_i, p_i) of a traced path is an equilibrium, R(q, p, θ) = ∂Π/∂q = 0, with θ the
dimensionless geometry (lengths over the cell length d, :func:`~multimorph.rom.cell_theta`).
Perturbing the lengths G = (d, w, h, ht, hb, ws, df) (m) moves the whole path; the IFT gives
the first-order move of each point from derivatives at that point alone (the tracer is never
differentiated and the model never re-run):

* **at fixed pressure** (regular points): ``dq/dG = −K⁻¹ ∂R/∂G`` with K = ∂²Π/∂q²;
* **normal to the path** (everywhere, limit points included): the bordered system

  .. math::  \begin{bmatrix} K & R_p \\ c^T \end{bmatrix}
             \begin{bmatrix} δq \\ δp \end{bmatrix} = \begin{bmatrix} −R_G\,δG \\ 0 \end{bmatrix}

  with c the path's secant direction at the point (scaled units; any c not orthogonal to the
  tangent gives the same perturbed curve to first order, the node only slides along it). It
  stays regular at a limit point, where it reduces to the classical
  dp*/dG = v·R_G / (v·∂ΔV/∂q) (v the null vector of K): the shift of the pressure maximum.

The moved path (:meth:`PathSensitivity.perturbed`) moves each node normal to the path, but
the last node at fixed pressure (the trace ends at p_max); the fixed-pressure form is the
normal one slid along the tangent, δq − t_q δp / t_p.

K, R_p and R_G come from one nested forward-mode AD pass over (q, p, G) of the same kernel
energy the tracer uses (:func:`~multimorph.rom.cell_kernel`, one source of truth; its
structured derivatives equal the plain AD ones, tested, but compile slower on their own).
The dimensional quantities follow by the chain rule: P = p μ (μ fixed: the materials are
held), κ = k/d, axial stretch 1 + e (volume and peak stretch are not linearised).
Characteristic pressures are functionals of the discrete curve: apply the estimators of
:mod:`multimorph.response` to :meth:`PathSensitivity.perturbed` paths (their derivative is
exact for the linearised curve; see ``docs/design.md``).

Reference: H. B. Keller, *Numerical solution of bifurcation and nonlinear eigenvalue
problems* (1977), for the bordered (pseudo-arc-length) system; W. C. Rheinboldt, *Numerical
analysis of parametrized nonlinear equations* (1986), for sensitivities along paths.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from multimorph.errors import SpecError
from multimorph.geometry import CellGeometry
from multimorph.response import EquilibriumPath
from multimorph.rom._cell_energy import COORDINATES, GEOMETRY_KEYS, RomOptions, cell_kernel
from multimorph.rom._continuation import TracerSettings
from multimorph.rom._exported import cache_folder, exported
from multimorph.rom._kernels import solve_small
from multimorph.rom._model import DEFAULT_SETTINGS, cell_theta, free_settings, options_for

__all__ = ["LENGTHS", "PathSensitivity", "characteristic_sensitivity", "path_sensitivity"]

#: The cell lengths the sensitivities are taken with respect to, in column order (m).
LENGTHS = ("length", "width", "height", "top_wall", "bottom_wall", "side_wall", "end_wall")
#: A point counts as a limit point (fixed-pressure sensitivity undefined) where the unit
#: tangent's pressure component (scaled units) is below this.
LIMIT_TANGENT = 1e-3
#: Path points per compiled call (paths are split into chunks of this size, the last padded).
CHUNK = 64


@dataclass(frozen=True, eq=False)
class PathSensitivity:
    """First-order motion of every point of a traced path per unit change of each length.

    Arrays are (m, 7): rows the path points, columns :data:`LENGTHS` (per metre).

    Attributes
    ----------
    pressure, curvature, axial_stretch : ndarray (m, 7)
        Motion of each node (Pa/m, 1/m², 1/m) normal to the path, defined everywhere, limit
        points included; the last node moves at fixed pressure (the path ends at p_max).
        Sliding a node along the path leaves the moved curve unchanged to first order, but
        the normal motion follows the features of the curve as the adaptive nodes of a
        re-traced path do, so the estimators of Pc and Ph see the smallest change of their
        discretisation error (fixed-pressure nodes bias dPc/dG by ~5 %, measured).
    curvature_at_pressure : ndarray (m, 7)
        dκ/dG at the point's own fixed pressure (1/m²); zero where ``regular`` is False.
    regular : ndarray (m,) of bool
        False at limit points (|dp/ds| < :data:`LIMIT_TANGENT`), where κ at fixed pressure is
        not differentiable.
    """

    pressure: np.ndarray
    curvature: np.ndarray
    axial_stretch: np.ndarray
    curvature_at_pressure: np.ndarray
    regular: np.ndarray

    def perturbed(self, path: EquilibriumPath, delta: np.ndarray) -> EquilibriumPath:
        """The linearised path after the lengths change by ``delta`` (m, shape (7,)).

        Stability flags, volume, peak stretch and the extras are kept (their change is not
        linearised).
        """
        dg = np.asarray(delta, float)
        return EquilibriumPath(
            pressure=path.pressure + self.pressure @ dg,
            curvature=path.curvature + self.curvature @ dg,
            twist_rate=path.twist_rate, axial_stretch=path.axial_stretch
            + self.axial_stretch @ dg, volume=path.volume,
            peak_stretch=path.peak_stretch, stable=path.stable,
            extra=dict(path.extra))


def _theta(G: Any, materials: dict[str, Any]) -> dict[str, Any]:
    th = {k: G[j + 1] / G[0] for j, k in enumerate(GEOMETRY_KEYS)}
    th.update(materials)
    return th


@lru_cache(maxsize=16)
def _kernel(wall_law: str, bottom_law: str, options: RomOptions,
            settings: TracerSettings) -> Any:
    ck = cell_kernel(wall_law, bottom_law, options)
    n = ck.n_free
    st = free_settings(settings, options)
    qs = jnp.asarray(st.q_scale if st.q_scale else (1.0,) * n, dtype=float)
    scale = jnp.concatenate([qs, jnp.array([float(st.p_scale)])])
    e_last = jnp.zeros(n + 1).at[n].set(1.0)

    def point(qf: Any, p: Any, c: Any, G: Any, mat: dict[str, Any]) -> dict[str, Any]:
        # one nested forward pass over x = (q, p, G): K, R_p and R_G of the kernel energy
        def resid(x: Any) -> Any:
            return jax.jacfwd(ck.energy)(x[:n], x[n], _theta(x[n + 1:], mat))

        J = jax.jacfwd(resid)(jnp.concatenate([qf, jnp.reshape(p, (1,)), G]))
        A = jnp.concatenate([J[:, :n + 1] * (qs[:, None] * scale[None, :]), c[None, :]],
                            axis=0)                         # bordered, scaled (q, p)
        RG = J[:, n + 1:] * qs[:, None]
        rhs = jnp.concatenate([-RG, jnp.zeros((1, RG.shape[1]))], axis=0)
        du = jax.vmap(lambda b: solve_small(A, b), in_axes=1, out_axes=1)(rhs) * scale[:, None]
        tau = solve_small(A, e_last)
        tau = tau / jnp.sqrt(jnp.sum(tau * tau))
        tq, tp = tau[:n] * qs, tau[n] * scale[n]
        regular = jnp.abs(tau[n]) > LIMIT_TANGENT
        safe = jnp.where(regular, tp, 1.0)
        dq_fixed = jnp.where(regular, du[:n] - tq[:, None] * du[n][None, :] / safe, 0.0)
        return {"dq": du[:n], "dp": du[n], "dq_fixed": dq_fixed, "regular": regular}

    # traced once and kept across processes (its ~10–30 s compile is mostly tracing)
    return exported(jax.jit(jax.vmap(point, in_axes=(0, 0, 0, None, None))),
                    f"sensitivity {wall_law} {bottom_law} {options!r} {settings!r}",
                    cache_folder)


def _secants(u: np.ndarray) -> np.ndarray:
    """Unit secant direction of a polyline at each node (central, one-sided at the ends)."""
    m = u.shape[0]
    if m < 2:
        return np.tile(np.eye(u.shape[1])[-1], (m, 1))
    c = np.empty_like(u)
    c[1:-1] = u[2:] - u[:-2]
    c[0] = u[1] - u[0]
    c[-1] = u[-1] - u[-2]
    nrm = np.linalg.norm(c, axis=1, keepdims=True)
    return c / np.where(nrm > 0, nrm, 1.0)


def path_sensitivity(cell: CellGeometry, path: EquilibriumPath, *,
                     options: RomOptions | None = None,
                     settings: TracerSettings | None = None) -> PathSensitivity:
    """IFT sensitivities of every point of a traced cell path to the cell's lengths.

    Parameters
    ----------
    cell : CellGeometry
        The traced cell (lengths in m; materials held fixed).
    path : EquilibriumPath
        Its equilibrium path from the reduced model, with the coordinates in
        ``path.extra["q"]`` (as :func:`~multimorph.rom.solve_cell` returns it; pressure in Pa).
    options : RomOptions, optional
        The model options the path was traced with (default options; ``mirror`` for a
        symmetric cell, as :func:`~multimorph.rom.solve_cell` traces it).
    settings : TracerSettings, optional
        Only its coordinate scales are used, to make the bordered system well scaled.

    Returns
    -------
    PathSensitivity
        d(P, κ, axial stretch)/d(lengths) at every point, per metre.

    Raises
    ------
    SpecError
        When the path carries no generalised coordinates (not a reduced-model path).

    Examples
    --------
    >>> from multimorph.materials import Material
    >>> from multimorph.rom import solve_cell
    >>> m = Material("gent", {"mu": 2.45e5, "jm": 20.0})
    >>> cell = CellGeometry(20e-3, 10e-3, 8e-3, 0.8e-3, 2e-3, 1.5e-3, 1.5e-3, material=m,
    ...                     bottom_material=m.scaled(5.0))
    >>> r = solve_cell(cell, 150e3)
    >>> s = path_sensitivity(cell, r.path)
    >>> s.curvature.shape
    (76, 7)
    """
    opts = options_for(cell.symmetric, options)
    st = settings or DEFAULT_SETTINGS
    q = path.extra.get("q") if path.extra else None
    if q is None or np.asarray(q).ndim != 2 or np.asarray(q).shape[1] != len(COORDINATES):
        raise SpecError(f"path_sensitivity needs a reduced-model path with its coordinates "
                        f"({', '.join(COORDINATES)}) in path.extra['q'] (from rom.solve_cell)")
    assert cell.bottom_material is not None
    mu, d = cell.mu, cell.length
    free = list(opts.free)
    qf = np.asarray(q, float)[:, free]
    p = np.asarray(path.pressure, float) / mu
    fs = free_settings(st, opts)
    qs = np.asarray(fs.q_scale if fs.q_scale else (1.0,) * len(free), float)
    u = np.concatenate([qf / qs, (p / fs.p_scale)[:, None]], axis=1)
    c = _secants(u)
    m = qf.shape[0]
    nb = -(-m // CHUNK) * CHUNK                            # whole chunks: one compiled shape
    pad = np.minimum(np.arange(nb), m - 1)
    th = cell_theta(cell)
    G = jnp.asarray([getattr(cell, k) for k in LENGTHS])
    mat = jax.tree_util.tree_map(jnp.asarray, {"mw": th["mw"], "mb": th["mb"]})
    fn = _kernel(cell.material.model, cell.bottom_material.model, opts, st)
    parts = [fn(jnp.asarray(qf[pad[a:a + CHUNK]]), jnp.asarray(p[pad[a:a + CHUNK]]),
                jnp.asarray(c[pad[a:a + CHUNK]]), G, mat) for a in range(0, nb, CHUNK)]
    out = {k: np.concatenate([np.asarray(o[k]) for o in parts])[:m] for k in parts[0]}
    ik = free.index(0) if 0 in free else None
    ie = free.index(3) if 3 in free else None
    k = np.asarray(q, float)[:, 0]

    def kappa(dq: np.ndarray) -> np.ndarray:
        dk = dq[:, ik, :] / d if ik is not None else np.zeros((m, len(LENGTHS)))
        dk[:, 0] -= k / d**2                                 # κ = k/d
        return dk

    regular = out["regular"].astype(bool)
    dq, dp = out["dq"], out["dp"]
    if m and regular[-1]:                                    # the trace ends at p_max
        dq[-1], dp[-1] = out["dq_fixed"][-1], 0.0
    dkp = kappa(out["dq_fixed"])
    dkp[~regular] = 0.0
    zero = np.zeros((m, len(LENGTHS)))
    return PathSensitivity(
        pressure=mu * dp, curvature=kappa(dq),
        axial_stretch=dq[:, ie, :] if ie is not None else zero,
        curvature_at_pressure=dkp, regular=regular)


def characteristic_sensitivity(path: EquilibriumPath, sensitivity: PathSensitivity,
                               lengths: np.ndarray, *, rel_step: float = 1e-6,
                               signal: str = "curvature") -> dict[str, np.ndarray | None]:
    """dPc/dG and dPh/dG (Pa/m) of the discrete estimators on the linearised path.

    The estimators of :func:`~multimorph.response.characteristic_pressures` (limit point or
    steepest rise, knee) are applied to the paths perturbed by ±``rel_step``·G_j along each
    length (:meth:`PathSensitivity.perturbed`), and differenced centrally. The perturbed
    curves are exact first-order images of the path, so this differentiates the estimator,
    not the tracer; no model is re-run.

    Parameters
    ----------
    path : EquilibriumPath
        The traced path (Pa, 1/m).
    sensitivity : PathSensitivity
        Its IFT sensitivities (:func:`path_sensitivity`).
    lengths : ndarray (7,)
        The cell's lengths G (m), in :data:`LENGTHS` order (sets the step of each column).
    rel_step : float
        Relative step of the central difference of the estimator.
    signal : {"curvature", "axial_stretch"}
        What Pc and Ph are read on (``cell.signal``: the axial stretch of a symmetric cell).

    Returns
    -------
    dict
        ``"critical"`` and ``"hardening"``: arrays (7,) in Pa/m, or ``None`` where the
        pressure is not reached on either side of the step or its kind changes.
    """
    from multimorph.response import characteristic_pressures

    G = np.asarray(lengths, float)
    out: dict[str, list[float] | None] = {"critical": [], "hardening": []}
    for j in range(len(LENGTHS)):
        h = rel_step * G[j]
        e = np.zeros(len(LENGTHS))
        e[j] = h
        cp = characteristic_pressures(sensitivity.perturbed(path, e), signal=signal)
        cm = characteristic_pressures(sensitivity.perturbed(path, -e), signal=signal)
        for key in ("critical", "hardening"):
            col = out[key]
            a, b = getattr(cp, key), getattr(cm, key)
            if col is None or a is None or b is None or cp.critical_kind != cm.critical_kind:
                out[key] = None
                continue
            col.append((a - b) / (2.0 * h))
    return {k: (None if v is None else np.asarray(v)) for k, v in out.items()}
