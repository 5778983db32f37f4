"""The cell model over many designs at once: one ``vmap``-ed, jitted trace per law pair.

:func:`solve_batch` takes a :class:`CellBatch` (arrays of dimensionless geometry and material
parameters) and returns a :class:`ResponseBatch` of padded arrays (fast: no Python per
design); :meth:`ResponseBatch.response` builds the full :class:`Response` of one design on
demand. :func:`simulate_cells` is the list-in/list-out convenience used by sweeps and the
designer (``Response`` or the exception of a design that failed, per cell).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from multimorph.errors import SpecError
from multimorph.geometry import CellGeometry
from multimorph.outcome import Outcome
from multimorph.response import EquilibriumPath, Response, build_response
from multimorph.rom._cell_energy import COORDINATES, GEOMETRY_KEYS, RomOptions, cell_kernel
from multimorph.rom._continuation import (
    REASON_TEXT,
    ContinuationError,
    TracerSettings,
    make_tracer,
)
from multimorph.rom._model import (
    DEFAULT_SETTINGS,
    cell_theta,
    cell_tracer,
    free_settings,
    options_for,
    padded_measures,
    runaway_points,
    runaway_record,
)
from multimorph.rom._notice import announced

__all__ = ["CellBatch", "ResponseBatch", "simulate_cells", "solve_batch"]


@dataclass(frozen=True, eq=False)
class CellBatch:
    """Many cell designs sharing one wall law and one bottom law (arrays of shape (B,)).

    Attributes
    ----------
    length : ndarray (B,)
        Cell length d (m).
    ratios : dict of str to ndarray (B,)
        Lengths over d: ``w, h, ht, hb, ws, df`` (see :data:`GEOMETRY_KEYS`).
    mu : ndarray (B,)
        Wall shear modulus (Pa).
    wall_law, bottom_law : str
        Law names (invariant-based).
    wall_params, bottom_params : dict of str to ndarray (B,)
        Law parameters with moduli divided by the wall μ.
    break_stretch : ndarray (B,)
        Wall break stretch (NaN when unknown).
    symmetric : bool
        Mirror-symmetric (stretching) cells: traced with ``RomOptions(mirror=True)``, Pc/Ph
        read on the axial stretch.
    """

    length: np.ndarray
    ratios: dict[str, np.ndarray]
    mu: np.ndarray
    wall_law: str
    bottom_law: str
    wall_params: dict[str, np.ndarray]
    bottom_params: dict[str, np.ndarray]
    break_stretch: np.ndarray = field(default_factory=lambda: np.zeros(0))
    symmetric: bool = False

    def __len__(self) -> int:
        return int(np.asarray(self.length).shape[0])

    @classmethod
    def from_cells(cls, cells: Sequence[CellGeometry]) -> CellBatch:
        """Stack cells that share their wall and bottom laws."""
        if not cells:
            raise SpecError("empty batch of cells")
        laws = {(c.material.model, c.bottom_material.model) for c in cells}  # type: ignore[union-attr]
        if len(laws) > 1:
            raise SpecError(f"a CellBatch needs one wall law and one bottom law; got {laws}")
        wall_law, bottom_law = laws.pop()
        sym = {c.symmetric for c in cells}
        if len(sym) > 1:
            raise SpecError("a CellBatch needs cells that are all mirror-symmetric or all not "
                            "(CellGeometry.symmetric)")
        thetas = [cell_theta(c) for c in cells]
        return cls(
            length=np.array([c.length for c in cells]),
            ratios={k: np.array([t[k] for t in thetas]) for k in GEOMETRY_KEYS},
            mu=np.array([c.mu for c in cells]),
            wall_law=wall_law, bottom_law=bottom_law,
            wall_params={k: np.array([t["mw"][k] for t in thetas]) for k in thetas[0]["mw"]},
            bottom_params={k: np.array([t["mb"][k] for t in thetas]) for k in thetas[0]["mb"]},
            break_stretch=np.array([c.material.break_stretch or np.nan for c in cells]),
            symmetric=sym.pop(),
        )

    def theta(self) -> dict[str, Any]:
        th: dict[str, Any] = {k: jnp.asarray(v, float) for k, v in self.ratios.items()}
        th["mw"] = {k: jnp.asarray(v, float) for k, v in self.wall_params.items()}
        th["mb"] = {k: jnp.asarray(v, float) for k, v in self.bottom_params.items()}
        return th


@dataclass(frozen=True, eq=False)
class ResponseBatch:
    """Equilibrium paths of a batch (padded arrays; row i valid up to ``count[i]``).

    Attributes
    ----------
    pressure : ndarray (B, N)
        Pa.
    curvature : ndarray (B, N)
        1/m.
    q : ndarray (B, N, 5)
        Coordinates (κd, φt, φs, e, ψ) (ψ = 0 unless ``side_lean``).
    stable : ndarray (B, N) of bool
    tangent_p : ndarray (B, N)
    count : ndarray (B,)
        Number of valid points per design.
    status : ndarray (B,)
        The :attr:`~multimorph.outcome.Outcome.code` of how each trace ended (0 = reached
        p_max).
    reason, fail_p : ndarray (B,)
        Why and at which P/μ a failed trace stopped.
    cells : CellBatch
    options : RomOptions
    n_eval : ndarray (B,)
        Gradient/Hessian evaluations per design (the tracer's cost unit).
    """

    pressure: np.ndarray
    curvature: np.ndarray
    q: np.ndarray
    stable: np.ndarray
    tangent_p: np.ndarray
    count: np.ndarray
    status: np.ndarray
    reason: np.ndarray
    fail_p: np.ndarray
    n_rejected: np.ndarray
    cells: CellBatch
    options: RomOptions
    n_eval: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))

    def __len__(self) -> int:
        return int(self.count.shape[0])

    @property
    def ok(self) -> np.ndarray:
        """Designs whose path reached p_max."""
        return self.status == Outcome.COMPLETED.code

    def message(self, i: int) -> str:
        """Status of design ``i`` in words."""
        outcome = Outcome.from_code(int(self.status[i]))
        msg = outcome.message
        if outcome is Outcome.STALLED:
            msg += (f" at P = {self.fail_p[i] * self.cells.mu[i] / 1e3:.4g} kPa: "
                    f"{REASON_TEXT.get(int(self.reason[i]), '')}")
        return msg

    def path(self, i: int) -> EquilibriumPath:
        """The equilibrium path of design ``i`` (volume and peak stretch evaluated now)."""
        c = self.cells
        m = int(self.count[i])
        ck = cell_kernel(c.wall_law, c.bottom_law, self.options)
        th = jax.tree_util.tree_map(lambda a: jnp.asarray(a[i]), c.theta())
        free = list(self.options.free)
        qf = self.q[i, :m][:, free]
        p = self.pressure[i, :m] / c.mu[i]
        meas = padded_measures(_measures(c.wall_law, c.bottom_law, self.options), qf, p, th)
        del ck
        d = float(c.length[i])
        r = c.ratios
        wc = (r["w"][i] - 2 * r["ws"][i]) * d
        hc = (r["h"][i] - r["ht"][i] - r["hb"][i]) * d
        dc = (1 - 2 * r["df"][i]) * d
        return EquilibriumPath(
            pressure=self.pressure[i, :m], curvature=self.curvature[i, :m],
            twist_rate=np.zeros(m), axial_stretch=1.0 + self.q[i, :m, 3],
            volume=wc * hc * dc + np.asarray(meas["volume"]) * d**3,
            peak_stretch=np.asarray(meas["peak_stretch"]), stable=self.stable[i, :m],
            extra={"q": self.q[i, :m], "lockup": np.asarray(meas["lockup"]),
                   "tangent_p": self.tangent_p[i, :m]})

    def response(self, i: int) -> Response:
        """Full :class:`Response` of design ``i``; raises if its trace failed. A trace that
        ran out of steps on a runaway (:func:`~multimorph.rom.runaway_points`) is answered
        with its path up to the runaway's volume, as :func:`solve_cell` answers it."""
        runs_out = int(self.status[i]) == Outcome.MAX_STEPS.code
        if not self.ok[i] and not runs_out:
            raise ContinuationError(f"cell ROM, design {i}: {self.message(i)}")
        path = self.path(i)
        meta: dict[str, Any] = {}
        if not self.ok[i]:
            keep = runaway_points(path.pressure, path.volume)
            if keep is None:
                raise ContinuationError(f"cell ROM, design {i}: {self.message(i)}")
            path = path.take(slice(0, keep))
            meta["runaway"] = runaway_record(path)
        bs = float(self.cells.break_stretch[i]) if self.cells.break_stretch.size else np.nan
        return build_response(path, length=float(self.cells.length[i]),
                              shear_modulus=float(self.cells.mu[i]), backend="rom",
                              break_stretch=None if np.isnan(bs) else bs,
                              signal="axial_stretch" if self.options.mirror else "curvature",
                              meta={"model": "cell-ritz", "batch_index": i,
                                    "points": len(path),
                                    "rejected_steps": int(self.n_rejected[i]), **meta})


@lru_cache(maxsize=16)
def _measures(wall_law: str, bottom_law: str, options: RomOptions) -> Any:
    ck = cell_kernel(wall_law, bottom_law, options)
    return jax.jit(jax.vmap(ck.measures, in_axes=(0, 0, None)))


@lru_cache(maxsize=16)
def _batched(wall_law: str, bottom_law: str, options: RomOptions,
             settings: TracerSettings) -> Any:
    ck = cell_kernel(wall_law, bottom_law, options)
    kernel = make_tracer(ck.energy, ck.n_free, free_settings(settings, options),
                         ck.admissible, ck.derivatives)
    return announced(jax.jit(jax.vmap(kernel, in_axes=(None, 0, 0))),
                     f"vmapped tracer {wall_law} {bottom_law} {options!r} {settings!r}"
                     ), ck.n_free


@lru_cache(maxsize=16)
def _single(wall_law: str, bottom_law: str, options: RomOptions,
            settings: TracerSettings) -> Any:
    ck, tracer, _ = cell_tracer(wall_law, bottom_law, options, settings)
    return tracer, ck.n_free


def vectorise_default() -> bool:
    """Whether :func:`solve_batch` vectorises by default: on accelerators (GPU/TPU) yes; on
    CPUs no. Measured on the 2-core CPU machine: one gradient/Hessian evaluation costs the
    same per design inside a vmapped batch as alone (~0.17 vs ~0.12 ms: arithmetic, not
    dispatch, dominates), and a vmapped batch runs every design to the slowest one's number
    of evaluations, so a loop of single traces is faster (35 vs 29 curves/s) and one hard
    design cannot stall its chunk."""
    return jax.default_backend() != "cpu"


def solve_batch(cells: CellBatch | Sequence[CellGeometry], p_max: float | np.ndarray, *,
                options: RomOptions | None = None,
                settings: TracerSettings | None = None,
                vectorise: bool | None = None) -> ResponseBatch:
    """Trace the equilibrium paths of many designs.

    Parameters
    ----------
    cells : CellBatch or sequence of CellGeometry
        Designs sharing one wall law and one bottom law.
    p_max : float or ndarray (B,)
        Largest pressure per design (Pa).
    options : RomOptions, optional
    settings : TracerSettings, optional
    vectorise : bool, optional
        ``True``: one vmapped, jitted call for the whole batch (padded to a bucket size);
        ``False``: the same jitted tracer design by design. Default:
        :func:`vectorise_default` (vectorised on accelerators only). Both give the same
        paths.

    Returns
    -------
    ResponseBatch
        Padded arrays; never NaN (failed designs keep their last converged state and a
        non-zero ``status``).
    """
    batch = cells if isinstance(cells, CellBatch) else CellBatch.from_cells(list(cells))
    opts = options_for(batch.symmetric, options)
    st = settings or DEFAULT_SETTINGS
    pm = np.broadcast_to(np.asarray(p_max, float), (len(batch),)) / batch.mu
    if not np.all(np.isfinite(pm) & (pm > 0)):
        raise SpecError("p_max must be a positive pressure for every design")
    B = len(batch)
    vec = vectorise_default() if vectorise is None else bool(vectorise)
    if vec:
        fn, nf = _batched(batch.wall_law, batch.bottom_law, opts, st)
        # pad to a bucket size (1, then powers of two from 4 up to 256, then multiples of
        # 256) so that batches of similar size reuse one compiled kernel
        if B == 1:
            Bp = 1
        elif B <= 256:
            Bp = max(4, 1 << (B - 1).bit_length())
        else:
            Bp = -(-B // 256) * 256
        pad = np.concatenate([np.arange(B), np.full(Bp - B, B - 1)]).astype(int)
        theta = jax.tree_util.tree_map(lambda a: a[pad], batch.theta())
        out = fn(jnp.zeros(nf), theta, jnp.asarray(pm[pad]))
        out = {k: np.asarray(v)[:B] for k, v in out.items()}
    else:
        fn, nf = _single(batch.wall_law, batch.bottom_law, opts, st)
        theta = batch.theta()
        q0 = jnp.zeros(nf)
        rows = []
        for i in range(B):
            th = jax.tree_util.tree_map(lambda a, i=i: jnp.asarray(a[i]), theta)
            rows.append({k: np.asarray(v) for k, v in fn(q0, th, jnp.asarray(pm[i])).items()})
        out = {k: np.stack([r[k] for r in rows]) for k in rows[0]}
    u = out["u"]
    q = np.zeros((*u.shape[:2], len(COORDINATES)))
    q[:, :, list(opts.free)] = u[:, :, :nf]
    mu = batch.mu[:, None]
    return ResponseBatch(
        pressure=u[:, :, nf] * mu, curvature=q[:, :, 0] / batch.length[:, None], q=q,
        stable=out["stable"].astype(bool), tangent_p=out["tp"], count=out["count"],
        status=out["status"], reason=out["reason"], fail_p=out["fail_p"],
        n_rejected=out["n_rej"], cells=batch, options=opts, n_eval=out["n_eval"])


def simulate_cells(cells: Sequence[CellGeometry], p_max: float, **options: Any,
                   ) -> list[Response | Exception]:
    """Responses of many cells (vectorised per law pair); a failed design gives its error.

    Parameters
    ----------
    cells : sequence of CellGeometry
    p_max : float
        Largest pressure (Pa).
    **options
        :class:`RomOptions` fields (e.g. ``rigid_bottom=True``).
    """
    opts = RomOptions(**options)
    groups: dict[tuple[str, str, bool], list[int]] = {}
    for i, c in enumerate(cells):
        groups.setdefault((c.material.model, c.bottom_material.model, c.symmetric),  # type: ignore[union-attr]
                          []).append(i)
    out: list[Response | Exception] = [SpecError("not evaluated")] * len(cells)
    for idx in groups.values():
        try:
            rb = solve_batch([cells[i] for i in idx], p_max, options=opts)
        except Exception as exc:  # a whole group cannot be set up (e.g. Ogden walls)
            for i in idx:
                out[i] = exc
            continue
        for j, i in enumerate(idx):
            try:
                out[i] = rb.response(j)
            except Exception as exc:
                out[i] = exc
    return out
