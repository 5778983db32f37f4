"""ROM-vs-FE comparison of two responses (synthetic paths, no FE run)."""

from __future__ import annotations

import numpy as np
import pytest

from multimorph.fe import compare_responses
from multimorph.response import EquilibriumPath, build_response


def _response(scale: float, backend: str):
    P = np.linspace(0.0, 1.0, 201)
    k = scale * (np.tanh((P - 0.5) / 0.08) + np.tanh(0.5 / 0.08))  # steepest at P = 0.5
    z = np.zeros_like(P)
    path = EquilibriumPath(pressure=P, curvature=k, twist_rate=z, axial_stretch=z + 1,
                           volume=1 + P, peak_stretch=1 + P, stable=np.ones_like(P, bool))
    return build_response(path, length=0.02, shear_modulus=1.0, backend=backend)


def test_identical_responses_agree() -> None:
    c = compare_responses(_response(1.0, "rom"), _response(1.0, "fe"))
    assert c.pc_rom == pytest.approx(0.5, abs=0.01)
    assert c.pc_rel == pytest.approx(0.0, abs=1e-12)
    assert c.kappa_rel_max == pytest.approx(0.0, abs=1e-12)


def test_relative_differences_are_rom_minus_fe_over_fe() -> None:
    c = compare_responses(_response(1.2, "rom"), _response(1.0, "fe"))
    assert c.pc_rel == pytest.approx(0.0, abs=1e-9)  # same Pc, different amplitude
    assert c.kappa_rel_max == pytest.approx(0.2, rel=1e-6)
    d = c.to_dict()
    assert set(d) >= {"critical_pressure", "hardening_pressure", "kappa"}


def _stretching(scale: float, center: float, backend: str):
    """A symmetric cell: no curvature, a ballooning axial stretch steepest at ``center``."""
    P = np.linspace(0.0, 1.0, 201)
    lam = 1 + scale * (np.tanh((P - center) / 0.08) + np.tanh(center / 0.08))
    z = np.zeros_like(P)
    path = EquilibriumPath(pressure=P, curvature=z, twist_rate=z, axial_stretch=lam,
                           volume=1 + P, peak_stretch=1 + P, stable=np.ones_like(P, bool))
    return build_response(path, length=0.02, shear_modulus=1.0, backend=backend,
                          signal="axial_stretch")


def test_symmetric_cells_compare_on_the_axial_stretch() -> None:
    c = compare_responses(_stretching(0.5, 0.6, "rom"), _stretching(0.5, 0.3, "fe"))
    assert c.signal == "axial_stretch"
    assert c.pc_rom == pytest.approx(0.6, abs=0.01) and c.pc_fe == pytest.approx(0.3, abs=0.01)
    assert c.pc_rel == pytest.approx(1.0, rel=0.05)            # the ROM balloons twice as late
    assert c.kappa_rel_max is None                              # nothing bends
    assert 0.5 < c.stretch_rel_max <= 1.0
    d = c.to_dict()
    assert d["signal"] == "axial_stretch" and len(d["axial_stretch"]["rom"]) == len(c.pressure)


def test_an_fe_cell_is_compared_on_its_end_rotation_as_the_cell_models_define_kappa() -> None:
    """An FE cell records its end face's rotation and the circle fit of its bottom edge,
    which bends about half as much (0.44-0.48 on the examples' cells); the cell models'
    κd is the end rotation per cell, so κ(P) is compared on it (Pc, Ph stay each side's)."""
    from multimorph.fe.analyses._compare import bend_curvature

    model = _response(1.0, "calibrated")
    P = np.linspace(0.0, 1.0, 201)
    k = np.tanh((P - 0.5) / 0.08) + np.tanh(0.5 / 0.08)
    z = np.zeros_like(P)
    path = EquilibriumPath(pressure=P, curvature=0.46 * k, twist_rate=z, axial_stretch=z + 1,
                           volume=1 + P, peak_stretch=1 + P, stable=np.ones_like(P, bool),
                           extra={"bend_angle": k * 0.02})
    fe = build_response(path, length=0.02, shear_modulus=1.0, backend="fe")
    assert bend_curvature(fe)[1] == "end rotation / length"
    assert bend_curvature(model)[1] == "curvature"
    c = compare_responses(model, fe)
    assert c.kappa_rel_max == pytest.approx(0.0, abs=1e-9)     # the same end rotation
    assert c.pc_rel == pytest.approx(0.0, abs=1e-9)
    assert c.to_dict()["kappa"]["measure"] == {"rom": "curvature",
                                               "fe": "end rotation / length"}
