"""The shared result type of every backend (reduced model and FE alike).

A :class:`Response` holds the whole equilibrium path of one cell/module (pressure and the
kinematic outputs along it, with a stability flag), the curves a pressure-controlled user
observes on loading and unloading (derived from the path), and the characteristic pressures.
Every analysis and plot takes a :class:`Response`, so ROM-vs-FE comparison is one function.
"""

from multimorph.response._types import CharacteristicPressures, EquilibriumPath, Response

__all__ = ["CharacteristicPressures", "EquilibriumPath", "Response"]
