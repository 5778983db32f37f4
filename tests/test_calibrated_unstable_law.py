"""A wall law that loses Drucker stability where a chamber wall is stretched (every
Mooney–Rivlin fit of the library: c01 < 0) is said so, whatever model answers the cell:
a warning and ``calibration.unstable_law``. Before stop 61 Dragon Skin 30's Mooney–Rivlin
fit was answered silently by the Ritz model with a Pc of 8.5 kPa, where its Gent fit gives
55 kPa."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import pytest

from multimorph.calibrated import CalibrationWarning, load_model
from multimorph.calibrated._law import drucker_limit
from multimorph.geometry import CellGeometry
from multimorph.io import load_toml
from multimorph.materials import get_material
from multimorph.materials.library import list_materials

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _names() -> list[str]:
    return [m if isinstance(m, str) else m["name"] for m in list_materials()]


def test_the_library_mooney_rivlin_fits_lose_stability_and_the_others_keep_it() -> None:
    for name in _names():
        for law in ("gent", "yeoh", "reduced-polynomial-6", "neo-hooke", "mooney-rivlin"):
            try:
                m = get_material(name, model=law)
            except Exception:       # not every entry has every law
                continue
            lam = drucker_limit(m)
            if law == "mooney-rivlin":
                assert m.params["c01"] < 0 and lam is not None and 1.0 < lam < 1.8, name
            else:
                assert lam is None, (name, law, lam)


def test_a_cell_of_an_unstable_law_is_said_so_whatever_answers_it() -> None:
    base = CellGeometry.from_spec(load_toml(EXAMPLES / "cell.toml")["cell"])
    mr = get_material("dragon-skin-30", model="mooney-rivlin")
    cell = replace(base, material=mr, bottom_material=mr.scaled(5.0))
    model = load_model()
    with pytest.warns(CalibrationWarning) as caught:
        r = model.responses([cell], 1.0e5, fast=True)[0]
    said = [str(w.message) for w in caught]
    assert any(re.search(r"wall and bottom law \(mooney-rivlin.*Drucker stability .* "
                         r"λ = 1\.08", m) for m in said), said
    # the box's message says whose Jm is outside (the wall has none of its own)
    assert any("jm = 8.831 (the Jm of the Gent wall closest to its mooney-rivlin wall"
               in m for m in said), said
    assert r.meta["calibration"]["unstable_law"]["wall"]["equibiaxial_stretch"] == \
        pytest.approx(1.078, abs=0.01)
    ok = model.responses([base], 1.0e5, fast=True)[0]
    assert "unstable_law" not in ok.meta["calibration"]
