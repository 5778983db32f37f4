"""The package's shape: no module imports another's private names, no import cycles, and
``multimorph.fe`` keeps its public names.

ruff's PLC2701 checks private imports from other packages only; inside ``multimorph`` this
test reads every module's imports (also those inside functions) with :mod:`ast`.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = SRC / "multimorph"


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(SRC).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _imports(name: str, path: Path) -> list[tuple[str, str | None]]:
    """(module, imported name or None) of every import in a module."""
    out: list[tuple[str, str | None]] = []
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out += [(alias.name, None) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")
            base = base[:len(base) - node.level + 1] if node.level else []
            module = ".".join([*base, *([node.module] if node.module else [])])
            out += [(module, alias.name) for alias in node.names]
    return out


def test_no_private_names_are_imported_across_modules() -> None:
    """A private helper another module needs is public in its room (or moves)."""
    found = [f"{name}: from {module} import {item}"
             for name, path in MODULES.items() for module, item in _imports(name, path)
             if item is not None and item.startswith("_") and not item.startswith("__")
             and module != name and module.startswith("multimorph")]
    assert found == []


def test_no_import_cycles() -> None:
    """Imports run one way between modules (also those inside functions): no cycle, except
    through a package's own ``__init__`` re-exporting its modules."""
    edges: dict[str, set[str]] = {}
    for name, path in MODULES.items():
        targets = set()
        for module, item in _imports(name, path):
            target = f"{module}.{item}" if f"{module}.{item}" in MODULES else module
            if target in MODULES and target != name and not name.startswith(target + "."):
                targets.add(target)
        edges[name] = targets
    state: dict[str, int] = {}
    cycle: list[str] = []

    def visit(node: str, trail: list[str]) -> bool:
        state[node] = 1
        for nxt in sorted(edges[node]):
            if state.get(nxt) == 1:
                cycle.extend([*trail[trail.index(nxt):], node, nxt] if nxt in trail
                             else [node, nxt])
                return True
            if nxt not in state and visit(nxt, [*trail, node]):
                return True
        state[node] = 2
        return False

    for node in edges:
        if node not in state and visit(node, []):
            break
    assert cycle == []


def test_the_fe_room_keeps_its_public_names() -> None:
    pytest.importorskip("felupe")
    import multimorph.fe as fe

    assert sorted(fe.__all__) == sorted([
        "CELL_ENDS", "FE_MODULE_KINDS", "MESH_PRESETS", "CellMesh", "Comparison", "DeviceMesh",
        "FEDeviceResult", "FEResult", "FESettings", "FETwistResult", "LinearSolver",
        "MeshDensity", "MissingExtraError", "NonFiniteSystemError", "PathCheckpoint",
        "PathPoint", "PathRun", "PressureProblem", "ShearComparison", "TwistMesh",
        "bend_and_twist", "build_cell_problem", "cell_mesh", "chamber_volume",
        "circle_fit_curvature", "compare_cell", "compare_device", "compare_responses",
        "compare_shear", "compare_shear_responses", "compare_twisting", "continuation",
        "device_mesh", "fe_device_branches", "fe_device_modules", "line_stretch",
        "make_solver", "newton", "peak_stretch", "pressure_control", "resolve_density",
        "simulate_cell", "simulate_device", "simulate_twisting_module", "strip_strain",
        "twisting_module_mesh"])
    assert all(hasattr(fe, name) for name in fe.__all__)
