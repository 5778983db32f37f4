"""Ritz energy of a pneu-net unit cell, dimensionless (lengths / d, energies / (μ d³)).

Coordinates (all dimensionless, zero in the reference state)::

    q = (k, phi_t, phi_s, e, psi)
    k      = κ d        bend angle of the cell (curvature × cell length)
    phi_t  top-wall bulge: half-angle (rad) of the circular arc of the top wall's inner face
           across the chamber width, at mid-chamber
    phi_s  side-wall bulge: half-angle of the side walls' arcs across the chamber height
    e      = λ0 − 1     axial strain of the bottom wall's mid-plane (the reference line)
    psi    side-wall lean: outward rotation (rad) of the side walls' chords about their base
           corners (only with ``RomOptions(side_lean=True)``; held at 0 otherwise)

The derivation and assumptions are in ``docs/rom.md``. The energy is

    Π = U_bottom + U_end_blocks + U_top_corners + U_top + 2 U_side − p ΔV,   p = P/μ,

each U a quadrature of the material's energy density (exactly incompressible: the third
stretch is 1/(λ1 λ2)), ΔV the exact change of the chamber volume for the assumed
kinematics. Geometry and material parameters travel in a ``theta`` dict of scalars so one
compiled kernel serves any design (and ``vmap`` serves thousands).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from multimorph.errors import SpecError
from multimorph.materials._math import JAX_MATH
from multimorph.materials._registry import Law, get_law
from multimorph.rom._kernels import c3, dsinc, gauss, sinc

__all__ = ["COORDINATES", "GEOMETRY_KEYS", "CellKernel", "RomOptions", "cell_kernel"]

#: Names of the generalised coordinates, in order.
COORDINATES = ("k", "phi_t", "phi_s", "e", "psi")
#: Dimensionless geometry entries of ``theta`` (lengths divided by the cell length d).
GEOMETRY_KEYS = ("w", "h", "ht", "hb", "ws", "df")


@dataclass(frozen=True)
class RomOptions:
    """Modelling switches and quadrature orders of the cell model.

    Parameters
    ----------
    rigid_walls : bool
        All walls but the top are rigid: only the top-wall bulge is free (k = phi_s = e = 0).
        With ``end_taper=False`` and ``wall_bending=False`` this is exactly the clamped
        plane-strain strip of physics-notes §3.6.
    rigid_bottom : bool
        The bottom wall's mid-plane is inextensible (e = 0); it still bends.
    end_taper : bool
        Bulges vanish at the end walls (finite chamber length): each bulge angle is
        ``phi · g(y)`` with g rising as sin² from 0 at an end wall to 1 over a taper length
        ``taper * span`` (at most half the chamber length). ``False``: plane-strain bulges.
    wall_bending : bool
        Through-thickness quadrature of the arc stretch of the bulging walls (their plate
        bending stiffness). ``False``: membranes.
    side_lean : bool
        Free the side walls' lean ψ (experimental; off by default). 3D FE shows the side
        walls rotating outward about their base corners as the chamber balloons, which
        widens the top wall's span (docs/fe-formulation.md §6). With ψ the side-wall chords
        rotate outward by ψ about their base corners (the arcs φs ride on them), the top
        wall spans wc + 2 hc sin ψ at height hb + hc cos ψ, the chamber section is the
        exact trapezoid, and bending the walls' roots into the floor costs the clamped
        plate's energy D δ²·3/(2 hc³) per wall and unit length (δ = hc sin ψ, D = μ ws³/3
        for an incompressible plate in plane strain). The strips of top wall over the side
        walls keep their height.
    taper : float
        Taper length over the bulging span (chamber width for the top wall, chamber height
        for the side walls).
    n_span, n_thick, n_taper, n_layer : int
        Gauss points across a bulging span (half span for the top wall), through a wall's
        thickness, along each end taper, and through each solid layer.
    """

    rigid_walls: bool = False
    rigid_bottom: bool = False
    end_taper: bool = True
    wall_bending: bool = True
    side_lean: bool = False
    mirror: bool = False
    taper: float = 1.0
    n_span: int = 4
    n_thick: int = 2
    n_taper: int = 4
    n_layer: int = 3

    def __post_init__(self) -> None:
        if self.mirror and (self.rigid_walls or self.rigid_bottom or self.side_lean):
            raise SpecError("RomOptions: mirror (a symmetric stretching cell) cannot be "
                            "combined with rigid_walls, rigid_bottom or side_lean")

    @property
    def free(self) -> tuple[int, ...]:
        """Indices of the free coordinates in :data:`COORDINATES`."""
        if self.mirror:
            return (1, 2, 3)
        lean = (4,) if self.side_lean else ()
        if self.rigid_walls:
            return (1,)
        if self.rigid_bottom:
            return (0, 1, 2, *lean)
        return (0, 1, 2, 3, *lean)


def _law(name: str) -> Law:
    law = get_law(name)
    if law.variables != "invariants":
        raise SpecError(
            f"the reduced cell model needs an invariant-based law (neo-hooke, mooney-rivlin, "
            f"yeoh, reduced-polynomial-N, gent, arruda-boyce); got {law.name}")
    return law


def _arc(phi: Any, s: Any) -> tuple[Any, Any]:
    """Circular arc of half-angle phi over the chord [-1, 1]: chord and bulge coordinates.

    A material point at reference chord coordinate ``s`` (uniform stretch 1/sinc(phi))
    goes to (X, Z) = (sin(phi s), cos(phi s) − cos(phi)) / sin(phi), written with sinc so
    that it is exact at phi = 0 (X = s, Z = 0).
    """
    sp = sinc(phi)
    X = s * sinc(phi * s) / sp
    Z = 0.5 * phi * (1.0 - s * s) * sinc(0.5 * phi * (1.0 + s)) * sinc(0.5 * phi * (1.0 - s)) / sp
    return X, Z


def _arc_dphi(phi: Any, s: Any) -> tuple[Any, Any]:
    """∂X/∂phi and ∂Z/∂phi of :func:`_arc` (analytic, safe at phi = 0)."""
    s0, d0 = sinc(phi), dsinc(phi)
    ss, ds_ = sinc(phi * s), dsinc(phi * s)
    Xp = s * (s * ds_ * s0 - ss * d0) / (s0 * s0)
    u1, u2 = 0.5 * (1.0 + s), 0.5 * (1.0 - s)
    s1, s2 = sinc(phi * u1), sinc(phi * u2)
    z_over_phi = 0.5 * (1.0 - s * s) * s1 * s2 / s0
    Zp = z_over_phi * (1.0 + phi * (u1 * dsinc(phi * u1) / s1 + u2 * dsinc(phi * u2) / s2
                                    - d0 / s0))
    return Xp, Zp


def _segment_area(phi: Any) -> Any:
    """Area of the circular segment over a unit half-chord: (2phi − sin 2phi)/(2 sin² phi)."""
    return 4.0 * phi * c3(2.0 * phi) / sinc(phi) ** 2


_S_VOL, _W_VOL = gauss(8, 0.0, 1.0)


def _segment_moment(phi: Any) -> Any:
    """First moment of the segment about its chord (unit half-chord): ∫ Z²/2 dX (Gauss).

    ``phi`` may be an array; the quadrature runs over a new last axis.
    """
    phi = jnp.asarray(phi)[..., None]
    s = jnp.asarray(_S_VOL)
    X_s = jnp.cos(phi * s) / sinc(phi)
    _, Z = _arc(phi, s)
    return jnp.sum(jnp.asarray(_W_VOL) * Z * Z * X_s, axis=-1)


def _with_jets(raw: Callable[[Any], Any]) -> Callable[[Any], Any]:
    """``raw(phi)`` (element-wise in ``phi``, outputs stacked on a new leading axis) with its
    first and second derivatives supplied as custom JVP rules.

    Under nested forward-mode AD (the Hessian of the cell energy) every tangent lane would
    otherwise carry the whole polynomial evaluation of the arc functions; with the rules,
    ``raw``, its derivative and its second derivative are evaluated once on the primal
    bulge angles and the lanes carry only products. Derivatives are those of ``raw`` itself
    (forward mode in one variable), so nothing is approximated.
    """
    def d1(phi: Any) -> Any:
        return jax.jvp(raw, (phi,), (jnp.ones_like(phi),))[1]

    def d2(phi: Any) -> Any:
        return jax.jvp(d1, (phi,), (jnp.ones_like(phi),))[1]

    f0 = jax.custom_jvp(raw)
    f1 = jax.custom_jvp(d1)

    @f0.defjvp
    def _f0_jvp(primals: Any, tangents: Any) -> Any:
        (phi,), (t,) = primals, tangents
        return f0(phi), f1(phi) * t[None]

    @f1.defjvp
    def _f1_jvp(primals: Any, tangents: Any) -> Any:
        (phi,), (t,) = primals, tangents
        return f1(phi), d2(phi) * t[None]

    return f0


@lru_cache(maxsize=16)
def _arc_pack(s: tuple[float, ...]) -> Callable[[Any], Any]:
    """Arc quantities of a bulging wall at chord nodes ``s`` for half-angles ``phi`` (ny, 1):
    stacked (X, Z, ∂X/∂φ, ∂Z/∂φ, ∂X/∂s, ∂Z/∂s, λs = φ/sin φ, φ sinc φ, cos φs, sin φs),
    each (ny, ns), with exact first/second φ-derivatives as JVP rules."""
    sv = np.asarray(s)[None, :]

    def raw(phi: Any) -> Any:
        X, Z = _arc(phi, sv)
        Xp, Zp = _arc_dphi(phi, sv)
        sp = sinc(phi)
        ps = phi * sv
        Xs = jnp.cos(ps) / sp
        Zs = -ps * sinc(ps) / sp
        ones = jnp.ones_like(ps)
        return jnp.stack([X, Z, Xp, Zp, Xs, Zs, ones / sp, ones * phi * sp, jnp.cos(ps),
                          jnp.sin(ps)])

    return _with_jets(raw)


def _segment_raw(phi: Any) -> Any:
    return jnp.stack([_segment_area(phi), _segment_moment(phi)])


#: (segment area, segment first moment) of a unit half-chord, with φ-derivative rules.
_segment_pack = _with_jets(_segment_raw)


def _taper_nodes(opts: RomOptions, dc: Any, span: Any) -> tuple[Any, Any, Any]:
    """y-quadrature of one bulge over the chamber length: (weights, g, dg/dy), shape (ny,).

    The first node stands for the plateau (g = 1) of length dc − 2ℓ; the others are Gauss
    nodes of the two sin² tapers of length ℓ = min(taper · span, dc/2) (both ends at once).
    """
    if not opts.end_taper:
        return jnp.reshape(dc, (1,)), jnp.ones(1), jnp.zeros(1)
    ell = jnp.minimum(opts.taper * span, 0.5 * dc)
    xi, wx = gauss(opts.n_taper, 0.0, 1.0)
    arg = 0.5 * np.pi * np.asarray(xi)
    g = np.concatenate([[1.0], np.sin(arg) ** 2])
    gp = jnp.concatenate([jnp.zeros(1), (0.5 * np.pi / ell) * np.sin(2.0 * arg)])
    w = jnp.concatenate([jnp.reshape(dc - 2.0 * ell, (1,)), 2.0 * ell * np.asarray(wx)])
    return w, jnp.asarray(g), gp


@dataclass(frozen=True)
class CellKernel:
    """The compiled-once ingredients of the cell model for one pair of laws and options.

    Attributes
    ----------
    energy : callable
        ``energy(qf, p, theta)``: Π/(μ d³) for the free coordinates ``qf`` at p = P/μ.
    derivatives : callable
        ``derivatives(qf, p, theta) -> (g, H)``: gradient (n_free + 1,) and Hessian of Π
        over (qf, p), structured (cheaper than AD of ``energy`` as a whole).
    measures : callable
        ``measures(qf, p, theta) -> dict`` with ``volume`` (ΔV/d³), ``peak_stretch``,
        ``lockup`` (largest (I1 − 3)/Jm, 0 without lock-up).
    admissible : callable
        ``admissible(qf, theta)``: the lock-up fraction (must stay below 1).
    n_free : int
    options : RomOptions
    """

    energy: Callable[..., Any]
    derivatives: Callable[..., Any]
    measures: Callable[..., Any]
    admissible: Callable[..., Any]
    n_free: int
    options: RomOptions
    wall_law: str
    bottom_law: str

    def full(self, qf: Any) -> Any:
        """Full coordinate vector (k, phi_t, phi_s, e, psi) from the free ones."""
        q = jnp.zeros((*qf.shape[:-1], len(COORDINATES)), dtype=float)
        return q.at[..., np.array(self.options.free)].set(qf)


@lru_cache(maxsize=16)
def cell_kernel(wall_law: str, bottom_law: str, options: RomOptions = RomOptions()) -> CellKernel:
    """Build the energy/measure functions for a wall law, a bottom law and options.

    ``theta`` holds the geometry (:data:`GEOMETRY_KEYS`, over d), ``mw`` and ``mb`` (dicts
    of the wall/bottom law parameters with moduli divided by the wall μ).
    """
    lw, lb = _law(wall_law), _law(bottom_law)
    o = options
    free = o.free
    # quadrature (static NumPy): top half-span, side full span, thickness, solid layers
    s_top, w_top = gauss(o.n_span, 0.0, 1.0)
    w_top = 2.0 * w_top
    s_side, w_side = gauss(2 * o.n_span, -1.0, 1.0)
    if o.wall_bending:
        t_nodes, t_w = gauss(o.n_thick, 0.0, 1.0)
    else:
        t_nodes, t_w = np.array([0.5]), np.array([1.0])
    tn = np.asarray(t_nodes)[None, None, :]
    tw = np.asarray(t_w)[None, None, :]
    zl, wl = gauss(o.n_layer, 0.0, 1.0)
    zl2, wl2 = gauss(o.n_layer + 1, 0.0, 1.0)

    def full(qf: Any) -> list[Any]:
        zero = jnp.zeros((), dtype=float)
        return [qf[free.index(i)] if i in free else zero for i in range(len(COORDINATES))]

    def geometry(th: Any) -> dict[str, Any]:
        g = {k: th[k] for k in GEOMETRY_KEYS}
        g["wc"] = g["w"] - 2.0 * g["ws"]
        g["hc"] = g["h"] - g["ht"] - g["hb"]
        g["dc"] = 1.0 - 2.0 * g["df"]
        return g

    def membrane(phi0: Any, a: Any, thick: Any, s: np.ndarray, w_s: np.ndarray, dc: Any,
                 lam_y: Callable[[Any], Any], height: Callable[[Any, Any], Any],
                 normal_z: Callable[[Any, Any], Any], cs: Any = 1.0,
                 ) -> tuple[Any, Any, Any, Any]:
        """Invariants, weights and largest stretch at (y, s, t) nodes of a bulging wall.

        Section at y: a circular arc over the chord (reference half-chord a, stretched by
        ``cs`` to a·cs) of half-angle phi(y) = phi0 g(y) (g = 1 on the plateau, → 0 at the
        end walls).
        """
        ad = a * cs
        wy, gy, gpy = _taper_nodes(o, dc, 2.0 * a)
        phi = phi0 * gy[:, None]                             # (ny, 1)
        dphi = phi0 * gpy[:, None]                           # dphi/dy
        pk = _arc_pack(tuple(float(x) for x in s))(phi)[..., None]   # (10, ny, ns, 1)
        X, Z, Xp, Zp, Xs, Zs, lam_s0, phisinc, cos_ps, sin_ps = pk
        dphi3 = dphi[:, :, None]
        z_in = height(ad * X, ad * Z)
        lam_s = lam_s0 * cs
        lam3m = 1.0 / (lam_s * lam_y(z_in))
        # bending strain of the fibre at t, measured from the mid-surface (curvature 1/ρ)
        curv = phisinc / ad
        fac = 1.0 + (thick * tn - 0.5 * thick) * lam3m * curv if o.wall_bending else 1.0
        G11 = (lam_s * fac) ** 2
        ly = lam_y(z_in + thick * tn * lam3m * normal_z(cos_ps, sin_ps))
        G22 = ly * ly + (ad * dphi3) ** 2 * (Xp * Xp + Zp * Zp)
        G12 = cs * ad * dphi3 * (Xs * Xp + Zs * Zp)
        tr = G11 + G22
        det = G11 * G22 - G12 * G12
        I1 = tr + 1.0 / det
        I2 = det + tr / det
        w = wy[:, None, None] * np.asarray(w_s)[None, :, None] * tw * a * thick
        r = jnp.sqrt(0.25 * (G11 - G22) ** 2 + G12 * G12)
        lam_max = jnp.sqrt(jnp.maximum(0.5 * tr + r, 1.0 / det))
        return I1, I2, w, lam_max

    def solid_fields(k: Any, e: Any, th: Any) -> dict[str, Any]:
        """Uniaxial regions: the bottom wall (full length), the end blocks (2 df long, full
        section above the bottom) and the top-wall strips over the side walls."""
        g = geometry(th)
        hb, hc, ht, ws, dc, w = g["hb"], g["hc"], g["ht"], g["ws"], g["dc"], g["w"]
        zb = 0.5 * hb
        z_b = hb * zl
        # mirror: under the chamber the bottom wall is the top wall's mirror (a membrane,
        # counted with the top wall); only its strips under the side walls and its share of
        # the end blocks stay uniaxial
        w_b = ((2.0 * ws * dc + 2.0 * g["df"] * w) if o.mirror else w) * hb * wl
        z_w = jnp.concatenate([hb + (hc + ht) * zl2, hb + hc + ht * zl])
        w_w = jnp.concatenate([2.0 * g["df"] * w * (hc + ht) * wl2, dc * 2.0 * ws * ht * wl])
        lb_ = 1.0 + e + k * (z_b - zb)
        lw_ = 1.0 + e + k * (z_w - zb)
        return {"bottom": (lb_ * lb_ + 2.0 / lb_, 2.0 * lb_ + 1.0 / (lb_ * lb_), w_b, lb_),
                "solid": (lw_ * lw_ + 2.0 / lw_, 2.0 * lw_ + 1.0 / (lw_ * lw_), w_w, lw_)}

    def top_fields(k: Any, e: Any, phi_t: Any, th: Any, psi: Any = 0.0,
                   ) -> tuple[Any, Any, Any, Any]:
        """Top wall over the chamber: chord at z = hb + hc cos ψ (half-chord wc/2 + hc sin ψ
        when the side walls lean), bulging up (half span)."""
        g = geometry(th)
        hb, hc = g["hb"], g["hc"]
        zb = 0.5 * hb
        a = 0.5 * g["wc"]
        if o.side_lean:
            cs = 1.0 + hc * jnp.sin(psi) / a
            zt = hb + hc * jnp.cos(psi)
        else:
            cs, zt = 1.0, hb + hc
        return membrane(phi_t, a, g["ht"], s_top, w_top, g["dc"],
                        lambda z: 1.0 + e + k * (z - zb),
                        lambda x, zz: zt + zz,
                        lambda c, sn: c, cs)

    def side_fields(k: Any, e: Any, phi_s: Any, th: Any, psi: Any = 0.0,
                    ) -> tuple[Any, Any, Any, Any]:
        """The two side walls: chord from z = hb up to hb + hc (rotated outward by the lean
        ψ about its base corner), bulging outward."""
        g = geometry(th)
        hb, hc = g["hb"], g["hc"]
        zb = 0.5 * hb
        a_s = 0.5 * hc
        if o.side_lean:
            c_l, s_l = jnp.cos(psi), jnp.sin(psi)
            I1, I2, ww, lm = membrane(phi_s, a_s, g["ws"], s_side, w_side, g["dc"],
                                      lambda z: 1.0 + e + k * (z - zb),
                                      lambda x, zz: hb + (a_s + x) * c_l - zz * s_l,
                                      lambda c, sn: sn * c_l - c * s_l)
        else:
            I1, I2, ww, lm = membrane(phi_s, a_s, g["ws"], s_side, w_side, g["dc"],
                                      lambda z: 1.0 + e + k * (z - zb),
                                      lambda x, zz: hb + a_s + x,
                                      lambda c, sn: sn)
        return I1, I2, 2.0 * ww, lm

    def u_hinge(psi: Any, th: Any) -> Any:
        """Bending the two side walls' roots into the floor (clamped plates, initial μ = 1):
        2 walls × dc × (3/2) D δ² / hc³ with D = ws³/3 and δ = hc sin ψ."""
        g = geometry(th)
        return g["dc"] * g["ws"] ** 3 * jnp.sin(psi) ** 2 / g["hc"]

    def fields(qf: Any, th: Any) -> dict[str, Any]:
        """Invariants (I1, I2), weights and largest stretches at all quadrature points."""
        k, phi_t, phi_s, e, psi = full(qf)
        out = solid_fields(k, e, th)
        out["top"] = top_fields(k, e, phi_t, th, psi)
        out["side"] = side_fields(k, e, phi_s, th, psi)
        return out

    def w_wall(I1: Any, I2: Any, th: Any) -> Any:
        return lw.energy(I1, I2, xp=JAX_MATH, **th["mw"])

    def w_bot(I1: Any, I2: Any, th: Any) -> Any:
        return lb.energy(I1, I2, xp=JAX_MATH, **th["mb"])

    def volume(qf: Any, th: Any) -> Any:
        """ΔV/d³: the exact volume change of the chamber for the assumed kinematics."""
        return volume4(full(qf), th)

    def volume4(q: Any, th: Any) -> Any:
        """ΔV/d³ from all coordinates (k, φt, φs, e, ψ)."""
        k, phi_t, phi_s, e = q[0], q[1], q[2], q[3]
        g = geometry(th)
        hb, hc, wc, dc = g["hb"], g["hc"], g["wc"], g["dc"]
        zb = 0.5 * hb
        a_t, a_s = 0.5 * wc, 0.5 * hc
        if o.side_lean:
            psi = q[4]
            c_l, s_l = jnp.cos(psi), jnp.sin(psi)
            # trapezoid: base wc at hb, top wc + 2 hc sin ψ at hb + hc cos ψ
            hh, top = hc * c_l, wc + 2.0 * hc * s_l
            area = 0.5 * (wc + top) * hh
            zc = hb + hh * (wc + 2.0 * top) / (3.0 * (wc + top))
            dv = dc * (area * (1.0 + e + k * (zc - zb)) - wc * hc)
            a_top, z_top, z_side = a_t + hc * s_l, hb + hh, hb + a_s * c_l
        else:
            dv = dc * wc * hc * (e + k * (hb + 0.5 * hc - zb))
            a_top, z_top, z_side = a_t, hb + hc, hb + 0.5 * hc
        wy, gy, _ = _taper_nodes(o, dc, 2.0 * a_t)
        phi = phi_t * gy
        seg = _segment_pack(phi)
        A = a_top**2 * jnp.sum(wy * seg[0])
        M = a_top**3 * jnp.sum(wy * seg[1])
        dv += A * (1.0 + e + k * (z_top - zb)) + k * M
        if o.mirror:
            # the bottom wall's mirrored segment hangs below the chamber floor
            dv += A * (1.0 + e + k * (hb - zb)) - k * M
        wy, gy, _ = _taper_nodes(o, dc, 2.0 * a_s)
        segs = _segment_pack(phi_s * gy)
        As = a_s**2 * jnp.sum(wy * segs[0])
        dv += 2.0 * As * (1.0 + e + k * (z_side - zb))
        if o.side_lean:
            # the leaning segment's centroid sits lower by its offset from the chord × sin ψ
            dv -= 2.0 * k * s_l * a_s**3 * jnp.sum(wy * segs[1])
        return dv

    def strain_energy(qf: Any, th: Any) -> Any:
        f = fields(qf, th)
        I1, I2, w, _ = f["bottom"]
        u = jnp.sum(w * w_bot(I1, I2, th))
        for key in ("solid", "top", "side"):
            I1, I2, w, _ = f[key]
            u += (2.0 if o.mirror and key == "top" else 1.0) * jnp.sum(w * w_wall(I1, I2, th))
        if o.side_lean:
            u += u_hinge(full(qf)[4], th)
        return u

    def energy(qf: Any, p: Any, th: Any) -> Any:
        return strain_energy(qf, th) - p * volume(qf, th)

    def _fof(fn: Any, x: Any) -> tuple[Any, Any, Any]:
        """Value, gradient and Hessian of a scalar function of a short vector, in one forward
        over forward pass (fewest operations for a handful of variables)."""
        def grad_and_value(v: Any) -> tuple[Any, Any]:
            return jax.jacfwd(lambda w: (fn(w), fn(w)), has_aux=True)(v)

        H, (gr, val) = jax.jacfwd(lambda v: (grad_and_value(v)[0], grad_and_value(v)),
                                  has_aux=True)(x)
        return val, gr, H

    def u_solid(x: Any, th: Any) -> Any:
        f = solid_fields(x[0], x[1], th)
        I1, I2, w, _ = f["bottom"]
        u = jnp.sum(w * w_bot(I1, I2, th))
        I1, I2, w, _ = f["solid"]
        return u + jnp.sum(w * w_wall(I1, I2, th))

    def u_top(x: Any, th: Any) -> Any:
        psi = x[3] if o.side_lean else 0.0
        I1, I2, w, _ = top_fields(x[0], x[1], x[2], th, psi)
        return (2.0 if o.mirror else 1.0) * jnp.sum(w * w_wall(I1, I2, th))

    def u_side(x: Any, th: Any) -> Any:
        psi = x[3] if o.side_lean else 0.0
        I1, I2, w, _ = side_fields(x[0], x[1], x[2], th, psi)
        u = jnp.sum(w * w_wall(I1, I2, th))
        return u + u_hinge(psi, th) if o.side_lean else u

    lean_ix = [4] if o.side_lean else []
    i_solid = np.array([0, 3])
    i_top, i_side = np.array([0, 3, 1, *lean_ix]), np.array([0, 3, 2, *lean_ix])
    nq = len(COORDINATES)
    P_solid, P_top, P_side, P_free = (jnp.asarray(np.eye(nq)[ix]) for ix in (
        i_solid, i_top, i_side, np.array(free)))

    def derivatives(qf: Any, p: Any, th: Any) -> tuple[Any, Any]:
        """Gradient and Hessian of Π over (free q, p), exploiting the energy's structure.

        Every region depends on two or three of the four coordinates (the solids on k and
        e, the top wall also on φt, the side walls also on φs), so each region's Hessian
        is taken over its own variables only; the pressure enters linearly
        (∂Π/∂p = −ΔV, ∂²Π/∂q∂p = −∂ΔV/∂q, ∂²Π/∂p² = 0). Equal to the full AD Hessian of
        :func:`energy` (tested) at about a third of its cost.
        """
        q = jnp.stack(full(qf))
        _, gs, Hs = _fof(lambda x: u_solid(x, th), P_solid @ q)
        _, gt, Ht = _fof(lambda x: u_top(x, th), P_top @ q)
        _, gd, Hd = _fof(lambda x: u_side(x, th), P_side @ q)
        dV, gv, Hv = _fof(lambda x: volume4(x, th), q)
        # embed the blocks with constant selection matrices (no scatter: vmap-friendly)
        gu = gs @ P_solid + gt @ P_top + gd @ P_side
        Hu = P_solid.T @ Hs @ P_solid + P_top.T @ Ht @ P_top + P_side.T @ Hd @ P_side
        gq = (gu - p * gv) @ P_free.T
        Hq = P_free @ (Hu - p * Hv) @ P_free.T
        dv = gv @ P_free.T
        g = jnp.concatenate([gq, jnp.reshape(-dV, (1,))])
        H = jnp.concatenate([jnp.concatenate([Hq, -dv[:, None]], axis=1),
                             jnp.concatenate([-dv, jnp.zeros(1)])[None, :]], axis=0)
        return g, H

    def lockup(qf: Any, th: Any) -> Any:
        f = fields(qf, th)
        frac = jnp.asarray(0.0)
        if lb.lockup_jm:
            frac = jnp.maximum(frac, jnp.max(f["bottom"][0] - 3.0) / th["mb"][lb.lockup_jm])
        if lw.lockup_jm:
            for key in ("solid", "top", "side"):
                frac = jnp.maximum(frac, jnp.max(f[key][0] - 3.0) / th["mw"][lw.lockup_jm])
        return frac

    def measures(qf: Any, p: Any, th: Any) -> dict[str, Any]:
        f = fields(qf, th)
        peak = jnp.asarray(1.0)
        for key in ("bottom", "solid"):
            lam = f[key][3]
            peak = jnp.maximum(peak, jnp.max(jnp.maximum(lam, lam**-0.5)))
        for key in ("top", "side"):
            peak = jnp.maximum(peak, jnp.max(f[key][3]))
        return {"volume": volume(qf, th), "peak_stretch": peak, "lockup": lockup(qf, th)}

    return CellKernel(energy=energy, derivatives=derivatives, measures=measures,
                      admissible=lockup, n_free=len(free), options=o, wall_law=lw.name,
                      bottom_law=lb.name)
