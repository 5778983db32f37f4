"""FE of a twisting module: tilted-chamber strips around a polygonal shaft.

Small cells (10 × 10 × 8 mm; 2 cells for the meshes, 1 for the runs), one element through
each wall, edges d/3, a shaft whose faces are only slightly wider than the strips and low
pressures keep each run to ~5 s (2.5k free DOF).
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("felupe")
pytest.importorskip("contique")

from multimorph.device import Module
from multimorph.errors import SpecError
from multimorph.fe import (
    MESH_PRESETS,
    FESettings,
    FETwistResult,
    MeshDensity,
    cell_mesh,
    chamber_volume,
    compare_twisting,
    simulate_twisting_module,
    twisting_module_mesh,
)
from multimorph.fe.mesh import BOTTOM, HEX_FACES, SHAFT, WALL
from multimorph.geometry import CellGeometry
from multimorph.materials import Material

pytestmark = pytest.mark.slow

MU = 1.0e5
SOFT = Material("gent", {"mu": MU, "jm": 30.0})
DENS = MeshDensity(wall_elements=1, length_fraction=1 / 3)
BETA = math.radians(30.0)
P_MAX = 0.3 * MU


def _cell() -> CellGeometry:
    return CellGeometry(10e-3, 10e-3, 8e-3, 1e-3, 2.5e-3, 1.5e-3, 1e-3, material=SOFT)


def _module(tilt: float = BETA, **kw: object) -> Module:
    base: dict[str, object] = dict(n_cells=2, tilt=tilt, shaft_radius=3.2e-3, strips=3)
    base.update(kw)
    return Module("tw", "twisting", _cell(), **base)  # type: ignore[arg-type]


def _gauss_jacobians(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """det J of the trilinear map at the 2×2×2 Gauss points, shape (cells, 8)."""
    g = np.array([-1.0, 1.0]) / math.sqrt(3.0)
    corner = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                       [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=float)
    X = points[cells]  # (c, 8, 3)
    out = []
    for xi in g:
        for eta in g:
            for zeta in g:
                q = np.array([xi, eta, zeta])
                dN = np.empty((8, 3))
                for a in range(8):
                    f = 1.0 + corner[a] * q
                    dN[a] = corner[a] * np.array([f[1] * f[2], f[0] * f[2], f[0] * f[1]]) / 8
                J = np.einsum("cai,aj->cij", X, dN)
                out.append(np.linalg.det(J))
    return np.column_stack(out)


@pytest.mark.parametrize("tilt", [BETA, -BETA, 0.0])
@pytest.mark.parametrize(("strips", "radius"), [(3, 3.2e-3), (4, 5.5e-3)])
def test_mesh_is_valid_conforming_and_keeps_volume(tilt: float, strips: int, radius: float,
                                                   ) -> None:
    """Every Jacobian positive at every Gauss point; no duplicate nodes; every face of the
    hexahedra shared by at most two cells and none left open on the strip–shaft interface;
    total volume = polygon prism + strips' solid (the shear keeps volume) to 1e-10; chamber
    volume = strips × the straight strip's; the tags and the clamp as documented."""
    from scipy.spatial import cKDTree

    m = twisting_module_mesh(_module(strips=strips, shaft_radius=radius), DENS, tilt=tilt)
    g, L, r, n = m.module.cell, m.length, m.radius, strips
    det = _gauss_jacobians(m.points, m.cells)
    assert det.min() > 0
    assert len(cKDTree(m.points).query_pairs(1e-7 * g.length)) == 0
    faces = np.sort(m.cells[:, HEX_FACES].reshape(-1, 4), axis=1)
    uniq, counts = np.unique(faces, axis=0, return_counts=True)
    assert counts.max() == 2
    # no open face on the glued interface: an open face with all nodes on a polygon face
    # plane, centred within a strip's footprint
    open_ = uniq[counts == 1]
    X = m.unsheared()[open_]  # (k, 4, 3)
    for k in range(n):
        phi = 2 * math.pi * k / n
        er = np.array([math.sin(phi), 0.0, math.cos(phi)])
        et = np.array([math.cos(phi), 0.0, -math.sin(phi)])
        on = np.all(np.abs(X @ er - r) < 1e-9 * L, axis=1)
        inside = np.abs(X.mean(axis=1) @ et) < 0.5 * g.width - 1e-9 * L
        assert not np.any(on & inside)
    vol = det.sum(axis=1)  # Gauss weights 1, reference cube volume 8 = Σ w det J / 1
    prism = n * r**2 * math.tan(math.pi / n) * L
    chambers = m.module.n_cells * g.wc * g.hc * g.dc
    strip = g.width * g.height * L - chambers
    assert vol.sum() == pytest.approx(prism + n * strip, rel=1e-10)
    assert vol[m.region == SHAFT].sum() == pytest.approx(prism, rel=1e-10)
    straight = cell_mesh(g, DENS, n_cells=m.module.n_cells, half=False)
    v_straight = chamber_volume(straight.points, straight.chamber_faces)
    assert v_straight == pytest.approx(chambers, rel=1e-12)
    assert chamber_volume(m.points, m.chamber_faces) == pytest.approx(n * v_straight,
                                                                      rel=1e-10)
    assert set(np.unique(m.region)) == {WALL, BOTTOM, SHAFT}
    assert np.all(m.strip[m.region == SHAFT] == -1)
    y0 = m.unsheared()[:, 1]
    assert np.all(np.abs(y0[m.clamped]) < 1e-12) and np.all(np.abs(y0[m.end_section] - L) < 1e-12)
    # every node of the reference end is clamped: strips and shaft
    used = np.unique(m.cells[m.region == SHAFT])
    assert np.any(m.clamped[used]) and np.any(m.clamped[np.unique(m.cells[m.region == WALL])])


@pytest.mark.parametrize("strips", [3, 5])
def test_mesh_has_the_rotational_symmetry(strips: int) -> None:
    """Rotating the node set by 2π/strips about the axis maps it onto itself (1e-9 of d)."""
    from scipy.spatial import cKDTree

    m = twisting_module_mesh(_module(strips=strips, shaft_radius=7.5e-3), DENS)
    c, s = math.cos(2 * math.pi / strips), math.sin(2 * math.pi / strips)
    R = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    dist, _ = cKDTree(m.points).query(m.points @ R.T)
    assert dist.max() < 1e-9 * m.module.cell.length


def test_mesh_refuses_strips_wider_than_the_shaft_faces() -> None:
    """3 strips 10 mm wide need faces ≥ 10 mm: inradius ≥ 5 / tan 60° = 2.89 mm."""
    with pytest.raises(SpecError, match=r"module 'tw'\.shaft_radius.*width"):
        twisting_module_mesh(_module(shaft_radius=2.5e-3), DENS)
    with pytest.raises(SpecError, match=r"module 'tw'\.strips"):
        twisting_module_mesh(_module(strips=2, shaft_radius=10e-3), DENS)
    twisting_module_mesh(_module(shaft_radius=5e-3 / math.tan(math.pi / 3)), DENS)  # flush


@pytest.fixture(scope="module")
def runs() -> dict[float, FETwistResult]:
    s = FESettings(mesh=DENS, method="pressure")  # below any limit point: steps only
    return {b: simulate_twisting_module(_module(n_cells=1), s, p_max=P_MAX, tilt=b)
            for b in (BETA, -BETA, 0.0)}


def test_twist_follows_the_tilt(runs: dict[float, FETwistResult]) -> None:
    """β and −β are mirror images: equal paths, opposite twist of equal magnitude (1e-6;
    the meshes are node-for-node mirrors, only the rounding differs). β > 0 twists
    left-handed about the axis (the strips' chambers lengthen along (−sin β, cos β) in the
    strip frame: a negative in-surface shear). The straight module does not twist (exact
    by its mirror symmetry, to the solver's accuracy) and the tilted one twists more with
    every pressure step below the ballooning (no limit point here)."""
    a, b, z = runs[BETA], runs[-BETA], runs[0.0]
    assert np.allclose(a.pressure, b.pressure, rtol=1e-12)
    assert np.allclose(a.twist_angle, -b.twist_angle, rtol=1e-6, atol=1e-12)
    assert np.allclose(a.axial_stretch, b.axial_stretch, rtol=1e-6)
    assert a.twist_angle[-1] < -math.radians(1.0)
    assert np.max(np.abs(z.twist_angle)) < 1e-8
    assert z.axial_stretch[-1] > 1.0
    lo = a.response.loading
    assert np.all(np.diff(lo.pressure) > 0)
    assert np.all(np.diff(lo.twist_rate) > 0)  # in the sense of the tilt: growing
    assert np.allclose(lo.twist_rate, b.response.loading.twist_rate, rtol=1e-6, atol=1e-12)
    assert np.max(np.abs(a.response.path.extra["bend_angle"])) < 1e-8  # bending cancels
    assert a.stats["nfree"] == a.mesh.ndof - 3 * int(a.mesh.clamped.sum())


def test_compare_with_the_reduced_model(runs: dict[float, FETwistResult]) -> None:
    """Known answer for the reduced-model side (a synthetic cell response, no JAX): a
    mid-height strain ε = c P gives the twist angle ε sin 2β / R · L and the axial stretch
    1 + ε cos²β, with R = shaft radius + h/2; the FE side is its loading curve at the same
    pressures. Both twist in the sense of the tilt (positive), for β and for −β."""
    from multimorph.response import EquilibriumPath, build_response

    P = np.linspace(0.0, 2 * P_MAX, 41)
    c = 0.2 / MU
    zero = np.zeros_like(P)
    path = EquilibriumPath(pressure=P, curvature=zero, twist_rate=zero,
                           axial_stretch=1.0 + c * P, volume=1.0 + P, peak_stretch=1.0 + c * P,
                           stable=np.ones(len(P), dtype=bool), extra={})
    rom = build_response(path, length=10e-3, shear_modulus=MU, backend="rom")
    for beta in (BETA, -BETA):
        fe = runs[beta]
        mod = _module(n_cells=1, tilt=beta)
        out = compare_twisting(fe, mod, rom=rom)
        Pc = np.array(out["pressure_pa"])
        R = mod.shaft_radius + 0.5 * mod.cell.height
        eps = c * Pc
        want = np.degrees(eps * math.sin(2 * abs(beta)) / R * mod.length)
        assert np.allclose(out["twist_deg_rom"], want, rtol=1e-12)
        assert np.allclose(out["stretch_rom"], 1 + eps * math.cos(beta) ** 2, rtol=1e-12)
        lo = fe.response.loading
        assert np.allclose(out["twist_deg_fe"],
                           -np.sign(beta) * np.degrees(np.interp(Pc, fe.pressure,
                                                                 fe.twist_angle)), rtol=1e-12)
        assert np.all(np.array(out["twist_deg_fe"]) > 0)
        assert np.allclose(out["stretch_fe"], np.interp(Pc, lo.pressure, lo.axial_stretch))
        rel = (np.array(out["twist_deg_rom"]) - out["twist_deg_fe"]) / out["twist_deg_fe"]
        assert np.allclose(out["twist_rel"], rel)
        for k in ("pc_fe", "pc_rom", "pc_rel", "ph_fe", "ph_rom", "ph_rel"):
            assert k in out
        json.dumps(out)


_SPEC = """
[device]
name = "twister test"
pmax = "30 kPa"

[cells.tw]
length = "10 mm"
width = "10 mm"
height = "8 mm"
top_wall = "1 mm"
bottom_wall = "2.5 mm"
side_wall = "1.5 mm"
end_wall = "1 mm"
material = {model = "gent", mu = "100 kPa", jm = 30}

[[module]]
name = "tw"
kind = "twisting"
cell = "tw"
cells = 1
tilt = "30 deg"
shaft_radius = "3.2 mm"
strips = 3
"""


def test_cli_fem_module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``multimorph fem DEVICE.toml --module tw --json``: exit 0, the summary's keys and the
    files; a module name that is not in the spec: exit 2, the message names the option,
    nothing written; a bending module (here at 90°) goes the device route."""
    from typer.testing import CliRunner

    from multimorph.cli._app import _register, app

    _register()
    monkeypatch.setitem(MESH_PRESETS, "coarse", DENS)  # the tiny test mesh
    spec = tmp_path / "tw.toml"
    spec.write_text(_SPEC)
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["fem", str(spec), "--module", "tw", "--mesh", "coarse",
                                   "--method", "pressure", "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    info = json.loads(res.output)
    assert info["backend"] == "fe"
    mod = info["module"]
    for k in ("critical_pressure", "hardening_pressure", "final", "stats", "tilt_deg"):
        assert k in mod
    assert mod["final"]["twist_angle_deg"] < 0
    # the peak stretch sits in a strip's wall (the chambers balloon), not in the shaft
    assert mod["final"]["peak_region"] == "wall" and len(mod["final"]["peak_location_m"]) == 3
    for f in ("summary.json", "path.csv", "module.pvd", "curves.png", "snapshots.png",
              "report.html"):
        assert (out / f).exists() and f in info["files"]
    for f in ("curves.png", "snapshots.png"):
        assert (out / f).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = CliRunner().invoke(app, ["fem", str(spec), "--module", "tw", "--wall-elements", "0",
                                   "--out", str(tmp_path / "bad"), "--json"])
    assert bad.exit_code == 2 and "--wall-elements" in bad.output
    assert not (tmp_path / "bad").exists()
    bad = CliRunner().invoke(app, ["fem", str(spec), "--module", "nope", "--out",
                                   str(tmp_path / "bad"), "--json"])
    assert bad.exit_code == 2 and "--module" in bad.output and "nope" in bad.output
    assert not (tmp_path / "bad").exists()
    # a bending module goes the device route (a 90° bending plane: a turned piece)
    bend = tmp_path / "bend.toml"
    bend.write_text(_SPEC.replace('kind = "twisting"', 'kind = "bending"').replace(
        'tilt = "30 deg"', 'orientation = "90 deg"'))
    ok = CliRunner().invoke(app, ["fem", str(bend), "--module", "tw", "--method", "pressure",
                                  "--pmax", "5 kPa", "--out", str(tmp_path / "b"), "--json"])
    assert ok.exit_code == 0, ok.output
    dev = json.loads(ok.output)["device"]["modules"]["tw"]
    assert dev["kind"] == "bending" and dev["orientation_deg"] == pytest.approx(90.0)


def test_module_spec_validation_reaches_fe() -> None:
    """A twisting module whose tilt Module refuses never reaches the mesher."""
    with pytest.raises(SpecError, match="tilt"):
        replace(_module(), tilt=0.0)
