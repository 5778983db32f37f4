"""Materials room: strain-energy laws, the Material value object, load cases, stability,
fitting, test-data readers and the built-in library.
"""

from typing import TYPE_CHECKING, Any

from multimorph.materials._material import OGDEN_CONVENTIONS, Material, Provenance
from multimorph.materials._math import JAX_MATH, JaxMath
from multimorph.materials._registry import MODEL_NAMES, Law, get_law
from multimorph.materials._spec import material_from_spec
from multimorph.materials.library import get_material, list_materials

if TYPE_CHECKING:  # the names __getattr__ below loads when first used
    from multimorph.materials._fit import CaseStats, FitResult, fit_material
    from multimorph.materials._loadcases import (
        LOAD_CASES,
        StabilityReport,
        canonical_case,
        drucker_stability,
        nominal_stress,
        stress_function,
        stretches,
    )
    from multimorph.materials._readers import LoadCurve, Specimen, TestData, read_test_data

#: Names of the modules that import JAX (fits, load cases, test-data readers), loaded when
#: first used: a Material, a spec or the library does not pay for importing JAX (about a
#: second of every CLI call; the calibrated model's default path runs no JAX).
_LAZY = {
    "CaseStats": "_fit", "FitResult": "_fit", "fit_material": "_fit",
    "LOAD_CASES": "_loadcases", "StabilityReport": "_loadcases",
    "canonical_case": "_loadcases", "drucker_stability": "_loadcases",
    "nominal_stress": "_loadcases", "stress_function": "_loadcases",
    "stretches": "_loadcases",
    "LoadCurve": "_readers", "Specimen": "_readers", "TestData": "_readers",
    "read_test_data": "_readers",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        from importlib import import_module

        value = getattr(import_module(f"multimorph.materials.{_LAZY[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'multimorph.materials' has no attribute {name!r}")


__all__ = [
    "JAX_MATH",
    "LOAD_CASES",
    "MODEL_NAMES",
    "OGDEN_CONVENTIONS",
    "CaseStats",
    "FitResult",
    "JaxMath",
    "Law",
    "LoadCurve",
    "Material",
    "Provenance",
    "Specimen",
    "StabilityReport",
    "TestData",
    "canonical_case",
    "drucker_stability",
    "fit_material",
    "get_law",
    "get_material",
    "list_materials",
    "material_from_spec",
    "nominal_stress",
    "read_test_data",
    "stress_function",
    "stretches",
]

