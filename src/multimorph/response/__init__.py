"""The shared result type of every backend (reduced model and FE alike).

A :class:`Response` holds the whole equilibrium path of one cell/module (pressure and the
kinematic outputs along it, with a stability flag), the curves a pressure-controlled user
observes on loading and unloading (derived from the path by :func:`observed_curves`), and the
characteristic pressures (:func:`characteristic_pressures`). Every analysis and plot takes a
:class:`Response`, so ROM-vs-FE comparison is one function. The derivations are pure NumPy on
an :class:`EquilibriumPath`, so every backend shares them; :func:`build_response` does all of
it in one call.
"""

from multimorph.response._build import build_response
from multimorph.response._characteristic import (
    BALLOONING_VOLUME_RATIO,
    DEFINITIONS_VERSION,
    characteristic_pressures,
    critical_pressure,
    hardening_pressure,
)
from multimorph.response._observed import observed_curves, observed_positions
from multimorph.response._types import CharacteristicPressures, EquilibriumPath, Response

__all__ = [
    "BALLOONING_VOLUME_RATIO",
    "DEFINITIONS_VERSION",
    "CharacteristicPressures",
    "EquilibriumPath",
    "Response",
    "build_response",
    "characteristic_pressures",
    "critical_pressure",
    "hardening_pressure",
    "observed_curves",
    "observed_positions",
]
