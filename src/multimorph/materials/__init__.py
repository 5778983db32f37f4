"""Materials room: strain-energy laws, the Material value object, load cases, stability,
fitting, test-data readers and the built-in library.
"""

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
from multimorph.materials._material import OGDEN_CONVENTIONS, Material, Provenance
from multimorph.materials._math import JAX_MATH, JaxMath
from multimorph.materials._readers import LoadCurve, Specimen, TestData, read_test_data
from multimorph.materials._registry import MODEL_NAMES, Law, get_law
from multimorph.materials._spec import material_from_spec
from multimorph.materials.library import get_material, list_materials

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

