"""Strain-energy laws, one module each, each a pure function of invariants or stretches.

Every function takes the math namespace ``xp`` (see :mod:`multimorph.materials._math`) so the
same law serves fitting and the reduced model (JAX) and FE (tensortrax).
"""

from multimorph.materials.laws._arruda_boyce import arruda_boyce
from multimorph.materials.laws._gent import gent
from multimorph.materials.laws._mooney_rivlin import mooney_rivlin
from multimorph.materials.laws._neo_hooke import neo_hooke
from multimorph.materials.laws._ogden import ogden
from multimorph.materials.laws._reduced_polynomial import reduced_polynomial

__all__ = [
    "arruda_boyce",
    "gent",
    "mooney_rivlin",
    "neo_hooke",
    "ogden",
    "reduced_polynomial",
]
