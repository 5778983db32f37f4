"""Registry of strain-energy laws: names, parameters, units, bounds and modulus formulas.

Model names (case-insensitive, ``_`` or ``-``): ``neo-hooke``, ``mooney-rivlin``, ``yeoh``
(reduced polynomial N = 3), ``reduced-polynomial`` (N = 1..6, default 6; also
``reduced-polynomial-4``), ``gent``, ``ogden`` (N terms, default 3; also ``ogden-2``),
``arruda-boyce``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from multimorph.errors import SpecError
from multimorph.materials import laws

__all__ = ["MODEL_NAMES", "Law", "get_law"]

INF = math.inf

#: Canonical model families a user can name.
MODEL_NAMES = (
    "neo-hooke",
    "mooney-rivlin",
    "yeoh",
    "reduced-polynomial",
    "gent",
    "ogden",
    "arruda-boyce",
)


@dataclass(frozen=True)
class Law:
    """A strain-energy law and what the rest of the package needs to know about it.

    Attributes
    ----------
    name : str
        Canonical model name including its order, e.g. ``"gent"``, ``"reduced-polynomial-6"``.
    variables : {"invariants", "stretches"}
        Whether :attr:`energy` takes ``(I1, I2)`` or principal stretches ``(l1, l2, l3)``.
    energy : callable
        The pure energy function (Pa) with keyword parameters and math namespace ``xp``.
    param_names : tuple of str
        Parameter names in canonical order.
    param_units : tuple of str
        ``"Pa"`` for moduli, ``"-"`` for dimensionless shape parameters.
    lower, upper : tuple of float
        Bounds that keep the parameters physical (used by fits and validation).
    shear_modulus : callable
        ``shear_modulus(params) -> float``, the small-strain shear modulus (Pa).
    lockup_jm : str or None
        Name of the parameter bounding ``I1 - 3`` (Gent), else ``None``.
    """

    name: str
    title: str
    variables: str
    energy: Callable[..., Any]
    param_names: tuple[str, ...]
    param_units: tuple[str, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    shear_modulus: Callable[[Mapping[str, float]], float]
    guess: Callable[[float], dict[str, float]] = field(repr=False)
    lockup_jm: str | None = None

    @property
    def family(self) -> str:
        return re.sub(r"-\d+$", "", self.name)


def _ab_mu0(p: Mapping[str, float]) -> float:
    lm2 = p["lambda_m"] ** 2
    return p["mu"] * (
        1 + 3 / (5 * lm2) + 99 / (175 * lm2**2) + 513 / (875 * lm2**3) + 42039 / (67375 * lm2**4)
    )


def _rp(n: int, name: str, title: str) -> Law:
    names = tuple(f"c{i}0" for i in range(1, n + 1))
    # c10 > 0 (positive modulus); the highest-order term >= 0 (no softening at large strain);
    # intermediate terms are free: silicones soften before they harden.
    lower = tuple(0.0 if i in (0, n - 1) else -INF for i in range(n))
    return Law(
        name=name,
        title=title,
        variables="invariants",
        energy=laws.reduced_polynomial,
        param_names=names,
        param_units=("Pa",) * n,
        lower=lower,
        upper=(INF,) * n,
        shear_modulus=lambda p: 2.0 * p["c10"],
        guess=lambda mu: {k: (mu / 2 if k == "c10" else mu * 1e-3 / 10**i)
                          for i, k in enumerate(names)},
    )


def _ogden(n: int) -> Law:
    # Each term keeps mu_p * alpha_p > 0 (sufficient for stability): the sign pattern of the
    # alphas is fixed by the start values (Ogden 1972: +, +, -), mu_p follows its alpha's sign.
    signs = [1.0, 1.0, -1.0, 1.0, -1.0, 1.0][:n] if n > 1 else [1.0]
    start_alpha = [1.3, 5.0, -2.0, 3.0, -4.0, 8.0][:n] if n > 1 else [2.0]
    names = tuple(f"mu{i}" for i in range(1, n + 1)) + tuple(f"alpha{i}" for i in range(1, n + 1))
    lower = tuple(0.0 if sign > 0 else -INF for sign in signs) + tuple(
        0.05 if sign > 0 else -30.0 for sign in signs)
    upper = tuple(INF if sign > 0 else 0.0 for sign in signs) + tuple(
        30.0 if sign > 0 else -0.05 for sign in signs)

    def guess(mu: float) -> dict[str, float]:
        weights = [1.0, 0.002, 0.016, 0.001, 0.001, 1e-4][:n] if n > 1 else [1.0]
        first: dict[str, float] = {}
        for i, (w, a) in enumerate(zip(weights, start_alpha, strict=True), start=1):
            first[f"mu{i}"] = 2 * mu * w / abs(a) * (1 if a > 0 else -1) * (1.5 if i == 1 else 1)
        for i, a in enumerate(start_alpha, start=1):
            first[f"alpha{i}"] = a
        return first

    return Law(
        name=f"ogden-{n}",
        title=f"Ogden, {n} term{'s' if n > 1 else ''} (1972 convention)",
        variables="stretches",
        energy=laws.ogden,
        param_names=names,
        param_units=("Pa",) * n + ("-",) * n,
        lower=lower,
        upper=upper,
        shear_modulus=lambda p: 0.5 * sum(p[f"mu{i}"] * p[f"alpha{i}"] for i in range(1, n + 1)),
        guess=guess,
    )


_FIXED: dict[str, Law] = {
    "neo-hooke": Law(
        name="neo-hooke", title="neo-Hookean", variables="invariants", energy=laws.neo_hooke,
        param_names=("mu",), param_units=("Pa",), lower=(0.0,), upper=(INF,),
        shear_modulus=lambda p: p["mu"], guess=lambda mu: {"mu": mu},
    ),
    "mooney-rivlin": Law(
        name="mooney-rivlin", title="Mooney–Rivlin", variables="invariants",
        energy=laws.mooney_rivlin, param_names=("c10", "c01"), param_units=("Pa", "Pa"),
        lower=(0.0, -INF), upper=(INF, INF),
        shear_modulus=lambda p: 2.0 * (p["c10"] + p["c01"]),
        guess=lambda mu: {"c10": 0.4 * mu, "c01": 0.1 * mu},
    ),
    "gent": Law(
        name="gent", title="Gent", variables="invariants", energy=laws.gent,
        param_names=("mu", "jm"), param_units=("Pa", "-"), lower=(0.0, 0.1), upper=(INF, 1e6),
        shear_modulus=lambda p: p["mu"], guess=lambda mu: {"mu": mu, "jm": 50.0},
        lockup_jm="jm",
    ),
    "arruda-boyce": Law(
        name="arruda-boyce", title="Arruda–Boyce (5-term)", variables="invariants",
        energy=laws.arruda_boyce, param_names=("mu", "lambda_m"), param_units=("Pa", "-"),
        lower=(0.0, 1.05), upper=(INF, 200.0), shear_modulus=_ab_mu0,
        guess=lambda mu: {"mu": 0.9 * mu, "lambda_m": 5.0},
    ),
    "yeoh": _rp(3, "yeoh", "Yeoh (reduced polynomial N = 3)"),
}


def get_law(model: str, order: int | None = None) -> Law:
    """Look up a law by name (and order for ``reduced-polynomial`` / ``ogden``).

    Examples
    --------
    >>> get_law("gent").param_names
    ('mu', 'jm')
    >>> get_law("reduced-polynomial", 6).name
    'reduced-polynomial-6'
    >>> get_law("ogden-2").param_names
    ('mu1', 'mu2', 'alpha1', 'alpha2')
    """
    key = str(model).strip().lower().replace("_", "-").replace(" ", "-")
    key = {"neohooke": "neo-hooke", "neo-hookean": "neo-hooke", "mooneyrivlin": "mooney-rivlin",
           "arrudaboyce": "arruda-boyce", "reduced-polynomial": "reduced-polynomial"}.get(key, key)
    match = re.fullmatch(r"(reduced-polynomial|ogden)(?:-(\d+))?", key)
    if match:
        family, suffix = match.group(1), match.group(2)
        n = int(suffix) if suffix else order if order is not None else (6 if
                                                                      family.startswith("red")
                                                                      else 3)
        if suffix and order is not None and int(suffix) != order:
            raise SpecError(f"model {model!r} contradicts order={order}")
        if not 1 <= n <= 6:
            raise SpecError(f"model {model!r}: order must be 1..6, got {n}")
        if family == "ogden":
            return _ogden(n)
        return _rp(n, f"reduced-polynomial-{n}", f"reduced polynomial N = {n}")
    if key in _FIXED:
        if order is not None and key != "yeoh":
            raise SpecError(f"model {model!r} takes no order (got {order})")
        return _FIXED[key]
    raise SpecError(
        f"unknown material model {model!r}; expected one of {', '.join(MODEL_NAMES)}"
    )
