"""Pseudo-arc-length continuation of the equilibria of an energy Π(q, p), generic and batched.

Equilibrium: R(q, p) = ∂Π/∂q = 0 at load parameter p (a dimensionless pressure). The tracer
follows the whole path through limit points (Riks 1979; Crisfield 1981):

* unknowns u = (q/q_scale, p/p_scale); unit tangent t with the orientation carried over from
  the previous step (bordered system ``[[K, R_p], [t_prevᵀ]] τ = e``), so the path never
  reverses at a limit point;
* predictor u + ds·t, Newton corrector on ``R = 0`` and the hyperplane ``t·(u − u_pred) = 0``
  (a fixed number of iterations so the kernel vectorises; convergence is then checked);
* a step is accepted when the corrector converged, everything is finite, the state is
  admissible (e.g. below Gent lock-up) and the tangent turned by less than ``max_turn``;
  otherwise it is rejected and ds halved. A rejected step leaves the state unchanged, so no
  NaN ever reaches the output. ds below ``ds_min`` stops the trace with a status that says
  where (pressure, step) and why;
* the last step lands exactly on p = p_max (the hyperplane is replaced by p = p_max);
* stability at fixed pressure: all Sylvester pivots of K = ∂²Π/∂q² positive.

Everything is one ``lax.while_loop`` (at most ``n_steps`` steps, Newton early exit), so a
trace jit-compiles once and ``vmap`` runs thousands of designs at once (finished designs
idle until the last one is done). :func:`trace_path` is the convenient single-design entry point.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from multimorph.errors import MultimorphError
from multimorph.outcome import Outcome
from multimorph.rom._kernels import pivots, solve_small

__all__ = [
    "REASON_TEXT",
    "ContinuationError",
    "RawPath",
    "TracerSettings",
    "make_tracer",
    "trace_path",
]

# How a trace ends: the integer codes of :class:`~multimorph.outcome.Outcome` in the loop
# state (a trace runs while its status is MAX_STEPS: it stops at p_max or when out of steps)
_DONE, _RUNNING = Outcome.COMPLETED.code, Outcome.MAX_STEPS.code
_UNDERFLOW, _BAD_START = Outcome.STALLED.code, Outcome.BAD_START.code
#: Why the last step was rejected.
REASON_TEXT = {
    0: "",
    1: "Newton corrector did not converge",
    2: "inadmissible state (e.g. Gent lock-up reached: I1 - 3 >= Jm)",
    3: "non-finite energy derivatives",
    4: "path turned too sharply (possible bifurcation or cusp)",
}


class ContinuationError(MultimorphError, RuntimeError):
    """The equilibrium path could not be traced; the message says where and why."""


@dataclass(frozen=True)
class TracerSettings:
    """Step control of the path tracer (all in scaled, dimensionless units).

    Parameters
    ----------
    n_steps : int
        Number of continuation steps (accepted + rejected) of the fixed-length scan.
    ds0, ds_max, ds_min : float
        Initial, largest and smallest arc-length step in scaled (q, p) space.
    n_newton : int
        Newton iterations per corrector (fixed, for vectorisation).
    tol : float
        Converged when max |R| is below ``tol`` times max |∂R/∂p| (the load vector of one
        ``p_scale`` of pressure) and the arc-length equation holds to ``tol``.
    step_tol : float
        Also converged when the Newton correction is below ``step_tol`` (scaled units): the
        corrected point is accepted without another evaluation (Newton converges
        quadratically, so its residual is of order ``step_tol²``); its tangent and
        stability come from the Hessian one correction earlier. 0 disables this.
    max_turn : float
        Largest angle (rad) between successive unit tangents of an accepted step.
    q_scale, p_scale : tuple of float, float
        Scales of the coordinates and of the load parameter (the arc length is measured in
        q/q_scale, p/p_scale). ``q_scale`` may be empty (all ones).
    admissible_max : float
        A state is admissible while ``admissible(q) < admissible_max``.
    """

    n_steps: int = 200
    ds0: float = 0.02
    ds_max: float = 0.1
    ds_min: float = 1e-7
    n_newton: int = 8
    tol: float = 1e-9
    step_tol: float = 1e-5
    max_turn: float = 0.35
    q_scale: tuple[float, ...] = field(default=())
    p_scale: float = 1.0
    admissible_max: float = 0.9995


@dataclass(frozen=True, eq=False)
class RawPath:
    """Result of one trace (NumPy arrays; accepted points only, in path order).

    Attributes
    ----------
    q : ndarray (m, n)
        Coordinates along the path.
    p : ndarray (m,)
        Load parameter.
    stable : ndarray (m,) of bool
        K positive definite at fixed p.
    tangent_p : ndarray (m,)
        dp/ds of the unit tangent (changes sign at limit points).
    status : int
        The :attr:`~multimorph.outcome.Outcome.code` of how the trace ended (0: it reached
        p_max; :attr:`outcome`).
    reason : int
        Why the last rejected step was rejected (:data:`REASON_TEXT`).
    fail_step, fail_p : int, float
        Step index and load parameter where the trace stopped early (status 2).
    n_rejected : int
    n_eval : int
        Evaluations of the energy's gradient and Hessian (Newton iterations, all steps).
    """

    q: np.ndarray
    p: np.ndarray
    stable: np.ndarray
    tangent_p: np.ndarray
    status: int
    reason: int
    fail_step: int
    fail_p: float
    n_rejected: int
    n_eval: int = 0

    @property
    def outcome(self) -> Outcome:
        """How the trace ended."""
        return Outcome.from_code(self.status)

    @property
    def ok(self) -> bool:
        """Whether the trace reached p_max."""
        return self.outcome is Outcome.COMPLETED

    @property
    def message(self) -> str:
        """How the trace ended, in words (where and why a stalled trace stopped)."""
        msg = self.outcome.message
        if self.outcome is Outcome.STALLED:
            msg += (f" at step {self.fail_step}, p = {self.fail_p:.6g}: "
                    f"{REASON_TEXT.get(self.reason, '')}")
        return msg

    def limit_points(self) -> np.ndarray:
        """Indices where dp/ds changes sign (limit points of the load parameter)."""
        s = np.sign(self.tangent_p)
        return np.flatnonzero((s[:-1] > 0) & (s[1:] < 0) | (s[:-1] < 0) & (s[1:] > 0)) + 1


EnergyFn = Callable[[Any, Any, Any], Any]
AdmissibleFn = Callable[[Any, Any], Any]
DerivativesFn = Callable[[Any, Any, Any], tuple[Any, Any]]


def make_tracer(energy: EnergyFn, n: int, settings: TracerSettings,
                admissible: AdmissibleFn | None = None,
                derivatives: DerivativesFn | None = None) -> Callable[..., dict[str, Any]]:
    """Build the (un-jitted, vmappable) tracer kernel for ``energy(q, p, theta)``.

    Parameters
    ----------
    energy : callable
        ``energy(q, p, theta) -> scalar``: q of shape (n,), p scalar, theta any pytree of
        design parameters (batched under vmap). JAX-traceable, twice differentiable.
    n : int
        Number of coordinates.
    settings : TracerSettings
    admissible : callable, optional
        ``admissible(q, theta) -> scalar``; a state is admissible while below
        ``settings.admissible_max`` (e.g. the largest (I1 − 3)/Jm).
    derivatives : callable, optional
        ``derivatives(q, p, theta) -> (g, H)``: gradient (n + 1,) and Hessian (n + 1, n + 1)
        of the energy over (q, p), when the caller has a cheaper form than AD of ``energy``
        as a whole (must agree with it).

    Returns
    -------
    callable
        ``kernel(q0, theta, p_max) -> dict`` of JAX arrays: ``u`` (n_steps+1, n+1) accepted
        states (q, p) in order, the first ``count`` rows valid; ``stable``, ``tp`` (dp/ds of
        the tangent) likewise; scalars ``count``, ``status``, ``reason``, ``fail_step``,
        ``fail_p``, ``n_rej``, ``n_eval`` (derivative evaluations = loop iterations).
    """
    s = settings
    qs = jnp.asarray(s.q_scale if s.q_scale else (1.0,) * n, dtype=float)
    ps = float(s.p_scale)
    scale = jnp.concatenate([qs, jnp.array([ps])])
    e_last = jnp.zeros(n + 1).at[n].set(1.0)
    cos_turn = float(np.cos(s.max_turn))

    def kernel(q0: Any, theta: Any, p_max: Any) -> dict[str, Any]:
        def pi_scaled(u: Any) -> Any:
            x = u * scale
            return energy(x[:n], x[n], theta)

        grad = jax.jacfwd(pi_scaled)

        def derivs(u: Any) -> tuple[Any, Any]:
            if derivatives is not None:
                x = u * scale
                g, H = derivatives(x[:n], x[n], theta)
                return g * scale, H * (scale[:, None] * scale[None, :])
            # forward-over-forward: fewer operations than jacfwd(grad) for a handful of dofs
            H, g = jax.jacfwd(lambda v: (grad(v), grad(v)), has_aux=True)(u)
            return g, H

        def adm(u: Any) -> Any:
            if admissible is None:
                return jnp.asarray(0.0)
            return admissible(u[:n] * qs, theta)

        def bordered(H: Any, c: Any) -> Any:
            return jnp.concatenate([H[:n, :], c[None, :]], axis=0)

        def tangent(H: Any, c: Any) -> Any:
            tau = solve_small(bordered(H, c), e_last)
            return tau / jnp.sqrt(jnp.sum(tau * tau))

        u0 = jnp.concatenate([jnp.asarray(q0, float) / qs, jnp.zeros(1)])
        c0 = jnp.ones(n + 1) / jnp.sqrt(n + 1.0)
        p_max_s = p_max / ps
        N = s.n_steps
        last = jnp.arange(n + 1) == n

        def predictor(u: Any, t: Any, ds: Any, k: Any) -> tuple[Any, Any, Any, Any]:
            """Start of step k: predictor v0, hyperplane normal c and target, final flag."""
            start = k == 0
            up = jnp.where(start, u, u + ds * t)
            final = (up[n] >= p_max_s) & (t[n] > 0) & ~start
            c = jnp.where(final | start, e_last, t)
            target = jnp.where(final, p_max_s, jnp.where(start, 0.0, jnp.dot(t, up)))
            v0 = jnp.where(final & last, p_max_s, up)
            return v0, c, target, final

        # One loop iteration = one derivative evaluation: a Newton iteration of the current
        # step's corrector, or, once it converged (or ran out of iterations), the step's
        # acceptance test and the next step's predictor. Under vmap every design advances on
        # its own schedule (no design waits for another's Newton iterations).
        def iterate(carry: Any) -> Any:
            (u, t, ds, k, m, status, reason, fail_step, fail_p, nrej, nev,
             v, v0, c, target, final, it, U, ST, TP) = carry
            start = k == 0
            g, H = derivs(v)
            # residual relative to the load vector of one p_scale of pressure
            load = jnp.maximum(jnp.max(jnp.abs(H[:n, n])), 1e-300)
            r = jnp.maximum(jnp.max(jnp.abs(g[:n])) / load, jnp.abs(jnp.dot(c, v) - target))
            # Newton update
            F = jnp.concatenate([g[:n], jnp.reshape(jnp.dot(c, v) - target, (1,))])
            dv = solve_small(bordered(H, c), -F)
            v_newton = v + dv
            small = jnp.max(jnp.abs(dv)) < s.step_tol
            conv = (r < s.tol) | small
            v = jnp.where((r >= s.tol) & small & jnp.all(jnp.isfinite(dv)), v_newton, v)
            done = conv | (it >= s.n_newton)
            # end of step: acceptance, tangent, step size, storage
            finite = jnp.all(jnp.isfinite(v)) & jnp.all(jnp.isfinite(H)) & jnp.all(
                jnp.isfinite(g))
            admissible_ok = adm(v) < s.admissible_max
            tau = tangent(H, jnp.where(start, c0, t))
            tau = jnp.where(start & (tau[n] < 0), -tau, tau)
            turn_ok = (jnp.dot(tau, t) > cos_turn) | start
            tau_ok = jnp.all(jnp.isfinite(tau))
            accept = finite & conv & admissible_ok & turn_ok & tau_ok
            why = jnp.where(~finite | ~tau_ok, 3,
                            jnp.where(~admissible_ok, 2,
                                      jnp.where(~conv, 1, jnp.where(~turn_ok, 4, 0))))
            stable = jnp.all(pivots(H[:n, :n]) > 0)
            corr = jnp.sqrt(jnp.sum((v - v0) ** 2)) / ds
            grow = jnp.where(corr < 0.05, 1.6, jnp.where(corr < 0.2, 1.2, 0.9))
            ds_new = jnp.where(accept, jnp.minimum(ds * grow, s.ds_max), ds * 0.5)
            ds_new = jnp.where(start, ds, ds_new)
            underflow = (~accept) & ((ds_new < s.ds_min) | start)
            reached = accept & final
            m_new = m + accept.astype(jnp.int32)
            # one-hot row update (a batched dynamic index would be a slow scatter under vmap)
            hot = done & accept & (jnp.arange(N + 1) == m_new - 1)
            U = jnp.where(hot[:, None], (v * scale)[None, :], U)
            ST = jnp.where(hot, stable, ST)
            TP = jnp.where(hot, tau[n], TP)
            u_new = jnp.where(accept, v, u)
            t_new = jnp.where(accept, tau, t)
            status_new = jnp.where(reached, _DONE, jnp.where(
                underflow, jnp.where(start, _BAD_START, _UNDERFLOW), status))
            nv0, nc, ntarget, nfinal = predictor(u_new, t_new, ds_new, k + 1)

            def pick(a_done: Any, a_cont: Any) -> Any:
                return jnp.where(done, a_done, a_cont)

            return (pick(u_new, u), pick(t_new, t), pick(ds_new, ds), pick(k + 1, k),
                    pick(m_new, m), pick(status_new, status),
                    pick(jnp.where(~accept, why, reason), reason),
                    pick(jnp.where(underflow, k, fail_step), fail_step),
                    pick(jnp.where(underflow, u[n] * ps, fail_p), fail_p),
                    pick(nrej + (~accept).astype(jnp.int32), nrej), nev + 1,
                    pick(nv0, v_newton), pick(nv0, v0), pick(nc, c), pick(ntarget, target),
                    pick(nfinal, final), pick(jnp.zeros_like(it), it + 1), U, ST, TP)

        def running(carry: Any) -> Any:
            k, m, status = carry[3], carry[4], carry[5]
            return (status == _RUNNING) & (k < N + 1) & (m < N + 1)

        U = jnp.zeros((N + 1, n + 1))
        ST = jnp.zeros(N + 1, dtype=bool)
        TP = jnp.zeros(N + 1)
        ds0 = jnp.asarray(s.ds0, float)
        k0 = jnp.asarray(0)
        v0, c, target, final = predictor(u0, c0, ds0, k0)
        carry0 = (u0, c0, ds0, k0, jnp.asarray(0),
                  jnp.asarray(_RUNNING), jnp.asarray(0), jnp.asarray(-1), jnp.asarray(0.0),
                  jnp.asarray(0, jnp.int32), jnp.asarray(0, jnp.int32),
                  v0, v0, c, target, final, jnp.asarray(0), U, ST, TP)
        carry = jax.lax.while_loop(running, iterate, carry0)
        (_, _, _, _, m, status, reason, fail_step, fail_p, nrej, nev,
         *_, U, ST, TP) = carry
        return {"u": U, "count": m, "stable": ST, "tp": TP, "status": status,
                "reason": reason, "fail_step": fail_step, "fail_p": fail_p, "n_rej": nrej,
                "n_eval": nev}

    return kernel


def raw_path_from_arrays(out: dict[str, Any], n: int, index: int | None = None) -> RawPath:
    """Pick one design's accepted points from kernel output (NumPy), as a :class:`RawPath`."""
    def get(key: str) -> np.ndarray:
        a = np.asarray(out[key])
        return a if index is None else a[index]

    m = int(get("count"))
    u = get("u")[:m]
    return RawPath(q=u[:, :n], p=u[:, n], stable=get("stable")[:m].astype(bool),
                   tangent_p=get("tp")[:m], status=int(get("status")),
                   reason=int(get("reason")), fail_step=int(get("fail_step")),
                   fail_p=float(get("fail_p")), n_rejected=int(get("n_rej")),
                   n_eval=int(get("n_eval")) if "n_eval" in out else 0)


@lru_cache(maxsize=32)
def _jitted(energy: EnergyFn, n: int, settings: TracerSettings,
            admissible: AdmissibleFn | None) -> Callable[..., Any]:
    return jax.jit(make_tracer(energy, n, settings, admissible))


def trace_path(energy: EnergyFn, q0: Any, theta: Any, p_max: float, *,
               settings: TracerSettings | None = None,
               admissible: AdmissibleFn | None = None, raise_on_failure: bool = True,
               what: str = "equilibrium path") -> RawPath:
    """Trace the equilibrium path of ``energy(q, p, theta)`` from ``q0`` at p = 0 to ``p_max``.

    Parameters
    ----------
    energy : callable
        ``energy(q, p, theta) -> scalar`` (JAX-traceable). Use a module-level function (it
        keys the compile cache).
    q0 : array_like (n,)
        Reference equilibrium at p = 0.
    theta : pytree
        Parameters passed through to ``energy`` (traced, so new values do not recompile).
    p_max : float
        Final load parameter (same units as ``p``).
    settings : TracerSettings, optional
    admissible : callable, optional
        See :func:`make_tracer`.
    raise_on_failure : bool
        Raise :class:`ContinuationError` (saying where and why) if p_max is not reached.

    Returns
    -------
    RawPath

    Examples
    --------
    >>> import jax.numpy as jnp
    >>> def sphere(q, p, theta):  # thin neo-Hookean balloon, p = P R/(mu H)
    ...     lam = q[0]
    ...     return 0.5 * (2 * lam**2 + lam**-4 - 3) - p * (lam**3 - 1) / 3
    >>> path = trace_path(sphere, [1.0], {}, 1.0)
    >>> bool(path.ok), round(float(path.p[-1]), 6)
    (True, 1.0)
    """
    s = settings or TracerSettings()
    q0 = np.atleast_1d(np.asarray(q0, float))
    n = q0.shape[0]
    kernel = _jitted(energy, n, s, admissible)
    out = kernel(jnp.asarray(q0), theta, jnp.asarray(float(p_max)))
    raw = raw_path_from_arrays(out, n)
    if raise_on_failure and not raw.ok:
        raise ContinuationError(f"{what}: {raw.message} (reached p = {raw.p[-1]:.6g} of "
                                f"{p_max:.6g} after {len(raw.p)} points)")
    return raw
