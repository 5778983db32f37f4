"""The :class:`Material` value object: one law, its parameters, and where they came from."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

import numpy as np

from multimorph.errors import LockupError, SpecError
from multimorph.materials._math import JAX_MATH
from multimorph.materials._registry import Law, get_law

__all__ = ["OGDEN_CONVENTIONS", "Material", "Provenance"]

#: Ogden parameter conventions: W = sum mu_p/alpha_p (...) (1972) or 2 mu_p/alpha_p^2 (...).
OGDEN_CONVENTIONS = ("ogden1972", "abaqus")


@dataclass(frozen=True)
class Provenance:
    """Where a parameter set comes from (shown by ``multimorph material show``)."""

    source: str
    doi: str | None = None
    licence: str | None = None
    data_file: str | None = None
    fit_range: tuple[float, float] | None = None
    fit_error: float | None = None
    residual: str | None = None
    note: str | None = None

    def to_dict(self) -> dict[str, Any]:
        d = {k: getattr(self, k) for k in self.__dataclass_fields__}
        if self.fit_range is not None:
            d["fit_range"] = list(self.fit_range)
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Provenance:
        d = dict(d)
        if d.get("fit_range") is not None:
            d["fit_range"] = tuple(float(x) for x in d["fit_range"])
        return cls(**d)


@dataclass(frozen=True)
class Material:
    """An isotropic hyperelastic material: a law and its parameters (SI units).

    Parameters
    ----------
    model : str
        Law name (see :func:`multimorph.materials.get_law`), e.g. ``"gent"``, ``"yeoh"``,
        ``"reduced-polynomial-6"``, ``"ogden-3"``.
    params : mapping of str to float
        Parameters by name; moduli in Pa, shape parameters dimensionless.
    name : str
        Display name, e.g. ``"dragon-skin-30"``.
    convention : str, optional
        Ogden only: ``"ogden1972"`` (default) or ``"abaqus"``; the parameters are stored in
        the convention given and converted explicitly when evaluated.
    bulk_modulus : float, optional
        Bulk modulus K (Pa) for nearly incompressible FE; default ``1000 * shear_modulus``.
    break_stretch : float, optional
        Uniaxial stretch at break (-), for failure margins.
    provenance : Provenance, optional
        Source, DOI, licence, fit range and error.

    Examples
    --------
    >>> m = Material("gent", {"mu": 1.0, "jm": 20.0})
    >>> round(float(m.nominal_stress("uniaxial", 2.0)), 5)
    1.94444
    >>> m.shear_modulus
    1.0
    """

    model: str
    params: Mapping[str, float]
    name: str = ""
    convention: str | None = None
    bulk_modulus: float | None = None
    break_stretch: float | None = None
    density: float | None = None
    provenance: Provenance | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        law = get_law(self.model)
        object.__setattr__(self, "model", law.name)
        given = dict(self.params)
        missing = [k for k in law.param_names if k not in given]
        extra = [k for k in given if k not in law.param_names]
        label = f"material {self.name or law.name!r}"
        if missing or extra:
            raise SpecError(
                f"{label}: model {law.name} needs parameters {', '.join(law.param_names)}"
                + (f"; missing {', '.join(missing)}" if missing else "")
                + (f"; unknown {', '.join(extra)}" if extra else "")
            )
        clean: dict[str, float] = {}
        for k in law.param_names:
            v = given[k]
            try:
                v = float(v)
            except (TypeError, ValueError):
                raise SpecError(f"{label}: parameter {k} must be a number, got {v!r}") from None
            if not math.isfinite(v):
                raise SpecError(f"{label}: parameter {k} must be finite, got {v}")
            clean[k] = v
        if law.family == "ogden":
            conv = self.convention or "ogden1972"
            if conv not in OGDEN_CONVENTIONS:
                raise SpecError(
                    f"{label}: convention must be one of {OGDEN_CONVENTIONS}, got {conv!r}")
            object.__setattr__(self, "convention", conv)
            for i in range(1, len(law.param_names) // 2 + 1):
                if clean[f"alpha{i}"] == 0.0:
                    raise SpecError(f"{label}: parameter alpha{i} must be non-zero")
        elif self.convention is not None:
            raise SpecError(f"{label}: 'convention' applies to Ogden models only")
        object.__setattr__(self, "params", _FrozenParams(clean))
        mu = self.shear_modulus
        if not mu > 0:
            raise SpecError(f"{label}: small-strain shear modulus must be > 0, got {mu:.4g} Pa")
        for k, lo in zip(law.param_names, law.lower, strict=True):
            if k in ("jm", "lambda_m", "mu") and not clean[k] > lo:
                raise SpecError(f"{label}: parameter {k} must be > {lo}, got {clean[k]}")
        for attr in ("bulk_modulus", "break_stretch", "density"):
            v = getattr(self, attr)
            if v is not None and not (math.isfinite(float(v)) and float(v) > 0):
                raise SpecError(f"{label}: {attr} must be a positive number, got {v!r}")
        if self.break_stretch is not None and not self.break_stretch > 1.0:
            raise SpecError(f"{label}: break_stretch must be > 1, got {self.break_stretch}")

    # ------------------------------------------------------------------ properties
    @property
    def law(self) -> Law:
        return get_law(self.model)

    @cached_property
    def shear_modulus(self) -> float:
        """Small-strain shear modulus μ (Pa; computed once: a material does not change)."""
        return float(self.law.shear_modulus(self.params_1972))

    @property
    def jm(self) -> float:
        """Gent's lock-up limit of I1 − 3 (inf for laws without lock-up)."""
        key = self.law.lockup_jm
        return float(self.params[key]) if key else math.inf

    @property
    def params_1972(self) -> dict[str, float]:
        """Parameters for evaluation (Ogden converted to the 1972 convention)."""
        p = dict(self.params)
        if self.convention == "abaqus":
            for i in range(1, len(p) // 2 + 1):
                p[f"mu{i}"] = 2.0 * p[f"mu{i}"] / p[f"alpha{i}"]
        return p

    def to_convention(self, convention: str) -> Material:
        """The same Ogden material with parameters expressed in ``convention``."""
        if self.law.family != "ogden":
            raise SpecError("to_convention applies to Ogden models only")
        if convention not in OGDEN_CONVENTIONS:
            raise SpecError(f"convention must be one of {OGDEN_CONVENTIONS}, got {convention!r}")
        p = self.params_1972
        if convention == "abaqus":
            for i in range(1, len(p) // 2 + 1):
                p[f"mu{i}"] = p[f"mu{i}"] * p[f"alpha{i}"] / 2.0
        return replace(self, params=p, convention=convention)

    def scaled(self, factor: float) -> Material:
        """The material with every modulus (Pa parameters, bulk modulus) scaled by ``factor``."""
        law = self.law
        p = {k: (v * factor if u == "Pa" else v)
             for (k, v), u in zip(self.params.items(), law.param_units, strict=True)}
        bulk = None if self.bulk_modulus is None else self.bulk_modulus * factor
        return replace(self, params=p, bulk_modulus=bulk)

    def with_name(self, name: str) -> Material:
        return replace(self, name=name)

    # ------------------------------------------------------------------ energies
    def energy_invariants(self, I1: Any, I2: Any, xp: Any = JAX_MATH) -> Any:
        """Raw isochoric energy (Pa) from invariants; no lock-up guard (for jitted kernels)."""
        law = self.law
        p = self.params_1972
        if law.variables == "invariants":
            return law.energy(I1, I2, xp=xp, **p)
        raise SpecError(f"{law.name} is a principal-stretch law; use energy_stretches")

    def energy_stretches(self, l1: Any, l2: Any, l3: Any, xp: Any = JAX_MATH) -> Any:
        """Raw energy (Pa) of principal stretches (incompressible: l1 l2 l3 = 1); no guard."""
        law = self.law
        p = self.params_1972
        if law.variables == "stretches":
            return law.energy(l1, l2, l3, xp=xp, **p)
        a, b, c = l1 * l1, l2 * l2, l3 * l3
        return law.energy(a + b + c, a * b + b * c + c * a, xp=xp, **p)

    def energy_isochoric_C(self, C: Any, xp: Any = JAX_MATH) -> Any:
        """Isochoric energy (Pa) of the right Cauchy–Green tensor C (FE adapters).

        Uses :math:`\\bar I_1 = J^{-2/3} I_1`, :math:`\\bar I_2 = J^{-4/3} I_2`, or the
        eigenvalues of :math:`\\bar C` for principal-stretch laws.
        """
        law = self.law
        J23 = xp.det(C) ** (-1.0 / 3.0)
        if law.variables == "invariants":
            return law.energy(J23 * xp.trace(C), J23**2 * xp.second_invariant(C), xp=xp,
                              **self.params_1972)
        ev = xp.eigvalsh(J23 * C)
        return law.energy(xp.sqrt(ev[0]), xp.sqrt(ev[1]), xp.sqrt(ev[2]), xp=xp,
                          **self.params_1972)

    def energy_nearly_incompressible_C(self, C: Any, xp: Any = JAX_MATH) -> Any:
        """Nearly incompressible energy (Pa): isochoric part + K/2 (J − 1)²."""
        J = xp.sqrt(xp.det(C))
        return self.energy_isochoric_C(C, xp) + 0.5 * self.bulk * (J - 1.0) ** 2

    @property
    def bulk(self) -> float:
        """Bulk modulus K (Pa) used by FE (default 1000 μ)."""
        return float(self.bulk_modulus) if self.bulk_modulus else 1000.0 * self.shear_modulus

    def lockup_fraction(self, l1: Any, l2: Any, l3: Any) -> np.ndarray:
        """(I1 − 3)/Jm at the given stretches (0 for laws without lock-up)."""
        I1 = np.asarray(l1) ** 2 + np.asarray(l2) ** 2 + np.asarray(l3) ** 2
        return (I1 - 3.0) / self.jm

    def check_lockup(self, l1: Any, l2: Any, l3: Any, what: str = "") -> None:
        """Raise :class:`LockupError` where (I1 − 3) ≥ Jm (a clear error instead of NaN)."""
        if math.isinf(self.jm):
            return
        frac = np.atleast_1d(self.lockup_fraction(l1, l2, l3))
        bad = np.flatnonzero(~(frac < 1.0))
        if bad.size:
            i = int(bad[0])
            stretches = [float(np.ravel(np.broadcast_to(x, frac.shape))[i]) for x in (l1, l2, l3)]
            raise LockupError(
                f"{self.name or self.model}: stretches ({stretches[0]:.4g}, {stretches[1]:.4g}, "
                f"{stretches[2]:.4g}){' in ' + what if what else ''} reach Gent lock-up: "
                f"I1 - 3 = {frac.flat[i] * self.jm:.4g} >= Jm = {self.jm:.4g}"
            )

    def energy(self, l1: Any, l2: Any, l3: Any) -> np.ndarray:
        """Guarded energy density (Pa) at principal stretches (incompressible); NumPy out."""
        self.check_lockup(l1, l2, l3)
        return np.asarray(self.energy_stretches(
            np.asarray(l1, float), np.asarray(l2, float), np.asarray(l3, float)))

    def nominal_stress(self, case: str, stretch: Any) -> np.ndarray:
        """Nominal stress (Pa) in a homogeneous load case; see :mod:`.loadcases`."""
        from multimorph.materials._loadcases import nominal_stress

        return nominal_stress(self, case, stretch)

    # ------------------------------------------------------------------ (de)serialise
    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"model": self.model, "params": dict(self.params)}
        for k in ("name", "convention", "bulk_modulus", "break_stretch", "density"):
            v = getattr(self, k)
            if v:
                d[k] = v
        if self.provenance is not None:
            d["provenance"] = self.provenance.to_dict()
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], *, name: str | None = None) -> Material:
        """Build from a mapping with ``model`` and ``params`` (SI numbers)."""
        if "model" not in d:
            raise SpecError(f"material {name or ''}: missing key 'model'".replace("  ", " "))
        if "params" not in d or not isinstance(d["params"], Mapping):
            raise SpecError(f"material {name or d.get('name', '')!r}: missing table 'params'")
        prov = d.get("provenance")
        return cls(
            model=d["model"],
            params=d["params"],
            name=name if name is not None else d.get("name", ""),
            convention=d.get("convention"),
            bulk_modulus=d.get("bulk_modulus"),
            break_stretch=d.get("break_stretch"),
            density=d.get("density"),
            provenance=Provenance.from_dict(prov) if prov else None,
        )


class _FrozenParams(Mapping[str, float]):
    """Read-only, hashable parameter mapping that keeps the law's order."""

    __slots__ = ("_d",)

    def __init__(self, d: Mapping[str, float]) -> None:
        self._d = dict(d)

    def __getitem__(self, k: str) -> float:
        return self._d[k]

    def __iter__(self):  # type: ignore[no-untyped-def]
        return iter(self._d)

    def __len__(self) -> int:
        return len(self._d)

    def __hash__(self) -> int:
        return hash(tuple(self._d.items()))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Mapping) and dict(self._d) == dict(other)

    def __repr__(self) -> str:
        return repr(self._d)
