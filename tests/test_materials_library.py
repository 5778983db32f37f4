"""The built-in library: names, provenance, literature sets, and reproducibility."""

from __future__ import annotations

import json

import pytest

from multimorph.errors import UnknownMaterialError
from multimorph.materials import get_material, list_materials, material_from_spec
from multimorph.materials.build_library import MARECHAL, data_dir, fit_marechal
from multimorph.materials.library import library_entry

REQUIRED = ("ecoflex-00-10", "ecoflex-00-30", "ecoflex-00-50", "dragon-skin-10",
            "dragon-skin-20", "dragon-skin-30", "mold-star-16", "mold-star-20t",
            "sortaclear-40", "rebound-25", "rtv615", "elastosil-m4601", "treloar-1944")


def test_every_required_and_every_marechal_material_is_listed() -> None:
    names = list_materials()
    for n in REQUIRED:
        assert n in names
    for stem, (name, _, _) in MARECHAL.items():
        assert name in names
        assert (data_dir() / "marechal2021" / f"{stem}.csv").is_file()
    assert names == sorted(names)
    assert (data_dir() / "marechal2021" / "README.md").read_text().count("ODbL") >= 1


@pytest.mark.parametrize("name", [MARECHAL[s][0] for s in sorted(MARECHAL)])
def test_marechal_entries_fitted_over_design_range(name: str) -> None:
    entry = library_entry(name)
    assert {"gent", "yeoh", "reduced-polynomial-6"} <= set(entry["models"])
    assert entry["break_stretch"] > 1.5
    for model in ("gent", "yeoh", "reduced-polynomial-6"):
        m = get_material(name, model)
        p = m.provenance
        assert p is not None and p.doi == "10.1089/soro.2019.0115"
        assert "ODbL" in p.licence and p.data_file.endswith(".csv")
        assert p.fit_range[1] <= 4.0 and 0 < p.fit_error < 0.5
        assert "relative" in p.residual
        assert m.break_stretch == entry["break_stretch"]
        assert entry["models"][model]["stats"]["status"] in ("converged", "at_bound")
    gent = get_material(name)
    assert gent.model == "gent"
    # Gent: every fitted point below lock-up, i.e. Jm > I1 - 3 at lambda = fit_range[1]
    lam = gent.provenance.fit_range[1]
    assert gent.jm > lam**2 + 2 / lam - 3


def test_default_model_and_suffix() -> None:
    ds30 = get_material("dragon-skin-30")
    assert ds30.model == "gent" and ds30.name == "dragon-skin-30"
    assert get_material("Dragon Skin 30:yeoh").model == "yeoh"
    assert get_material("dragon_skin_30", model="reduced-polynomial").model == \
        "reduced-polynomial-6"
    assert get_material("dragon-skin-10-medium").name == "dragon-skin-10"  # alias
    assert material_from_spec("ecoflex-00-30").name == "ecoflex-00-30"


def test_unknown_names_suggest_close_matches() -> None:
    with pytest.raises(UnknownMaterialError, match="did you mean dragon-skin-30"):
        get_material("dragonskin-30")
    with pytest.raises(UnknownMaterialError, match="no arruda-boyce parameters"):
        get_material("dragon-skin-30", "arruda-boyce")
    with pytest.raises(UnknownMaterialError, match="unknown material model"):
        get_material("dragon-skin-30:hooke")


def test_literature_sets() -> None:
    el = get_material("elastosil-m4601")
    assert el.model == "yeoh"
    assert el.params["c10"] == 0.11e6 and el.params["c20"] == 0.02e6
    assert el.provenance.doi == "10.1109/TRO.2015.2428504"
    og = get_material("treloar-1944", "ogden")
    assert og.convention == "ogden1972"
    assert og.shear_modulus == pytest.approx(0.4225e6)
    assert og.provenance.doi == "10.1098/rspa.1972.0026"


def test_library_is_reproducible_from_shipped_data() -> None:
    # refit one material with the library's settings: same parameters (the full rebuild
    # is 'python -m multimorph.materials.build_library --check')
    _, fits = fit_marechal("dragon_skin_30", ("gent",))
    lib = json.loads((data_dir() / "library.json").read_text())
    stored = lib["materials"]["dragon-skin-30"]["models"]["gent"]["params"]
    for k, v in fits["gent"].params.items():
        assert stored[k] == pytest.approx(v, rel=1e-7)
    assert lib["fit_settings"]["stretch_max"] == 4.0
