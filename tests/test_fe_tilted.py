"""FE of tilted (twisting) cells: the sheared mesh, the strip's shear, and the ROM's shear.

The cell is the gripper's twisting cell (``examples/gripper.toml``, ``[cells.twist]``: d 10,
w 12, h 10 mm, top wall 0.5, bottom 4, side 2.5, end 0.75 mm, Dragon Skin 10). The FE runs
use a very coarse mesh (3 mm elements, one through each wall) and a strip of two cells, so
that the file stays small; ``docs/fe.md`` ("Tilted (twisting) cells") has the measured numbers
on finer meshes.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("felupe")

from multimorph.errors import SpecError
from multimorph.fe import CellMesh, MeshDensity, cell_mesh, chamber_volume, strip_strain
from multimorph.geometry import CellGeometry
from multimorph.materials.library import get_material

BETA = math.radians(30.0)
TINY = MeshDensity(wall_elements=1, size=3e-3)


def _twist_cell() -> CellGeometry:
    return CellGeometry(10e-3, 12e-3, 10e-3, 0.5e-3, 4e-3, 2.5e-3, 0.75e-3,
                        material=get_material("dragon-skin-10"))


def _corner_jacobians(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """det ∂x/∂ξ of every trilinear hexahedron at its 8 corners (VTK order)."""
    xi = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                   [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], float)
    X = points[cells]  # (m, 8, 3)
    dets = []
    for p in xi:
        # dN_a/dξ_j = ξ_aj/8 · Π_{k≠j} (1 + ξ_ak p_k)
        dN = np.empty((8, 3))
        for j in range(3):
            other = [k for k in range(3) if k != j]
            dN[:, j] = xi[:, j] / 8 * np.prod(1 + xi[:, other] * p[other], axis=1)
        J = np.einsum("mai,aj->mij", X, dN)
        dets.append(np.linalg.det(J))
    return np.array(dets)


@pytest.mark.parametrize(("tilt_deg", "n_cells"), [(30.0, 2), (-55.0, 3), (79.0, 1)])
def test_sheared_mesh_keeps_volume_tags_and_orientation(tilt_deg: float, n_cells: int) -> None:
    g = _twist_cell()
    beta = math.radians(tilt_deg)
    straight = cell_mesh(g, "coarse", half=False, n_cells=n_cells)
    tilted = cell_mesh(g, "coarse", half=False, n_cells=n_cells, tilt=beta)
    assert tilted.tilt == beta and straight.tilt == 0.0
    # a shear has determinant 1: same chamber volume (exact divergence theorem)
    v0 = chamber_volume(straight.points, straight.chamber_faces)
    assert v0 == pytest.approx(n_cells * g.wc * g.hc * g.dc, rel=1e-12)
    assert chamber_volume(tilted.points, tilted.chamber_faces) == pytest.approx(v0, rel=1e-12)
    # ... and keeps every element right-handed
    assert np.all(_corner_jacobians(tilted.points, tilted.cells) > 0)
    # same topology and tags; only the points moved, along y only
    for name in ("cells", "region", "chamber_points", "chamber_faces", "clamped", "bend_line",
                 "end_face"):
        assert np.array_equal(getattr(tilted, name), getattr(straight, name)), name
    assert np.array_equal(tilted.points[:, [0, 2]], straight.points[:, [0, 2]])
    assert np.allclose(tilted.unsheared(), straight.points, atol=1e-15)
    # clamp and free end are the sheared planes y = k d + (x − w/2) tan β
    P = tilted.points
    shift = (P[:, 0] - g.width / 2) * math.tan(beta)
    assert np.allclose(P[tilted.clamped, 1], shift[tilted.clamped], atol=1e-15)
    assert np.allclose(P[tilted.end_face, 1], tilted.length + shift[tilted.end_face],
                       atol=1e-15)
    # the partitions keep their thickness df along y; the chamber axis is n = (−sin β, cos β)
    assert np.all(np.diff(P[tilted.bend_line, 1]) > 0)
    # every section is the whole sheared plane: area w h / cos β
    for k, (nodes, w) in enumerate(tilted.sections()):
        assert w.sum() == pytest.approx(g.width * g.height / math.cos(beta), rel=1e-12)
        assert np.allclose(tilted.unsheared()[nodes, 1], k * g.length, atol=1e-12)


def test_zero_tilt_is_the_straight_mesh() -> None:
    g = _twist_cell()
    for half in (True, False):
        a = cell_mesh(g, "coarse", half=half, n_cells=2)
        b = cell_mesh(g, "coarse", half=half, n_cells=2, tilt=0.0)
        for name in CellMesh.__dataclass_fields__:
            va, vb = getattr(a, name), getattr(b, name)
            if isinstance(va, np.ndarray):
                assert np.array_equal(va, vb), name
            else:
                assert va == vb, name


@pytest.mark.parametrize("tilt", [math.radians(80.0), math.radians(-85.0), math.nan, math.inf])
def test_tilt_out_of_range_is_refused(tilt: float) -> None:
    with pytest.raises(SpecError, match="tilt"):
        cell_mesh(_twist_cell(), "coarse", half=False, tilt=tilt)


def test_tilted_half_model_is_refused() -> None:
    """A tilted cell has no mirror plane x = w/2."""
    with pytest.raises(SpecError, match=r"tilt.*half=False"):
        cell_mesh(_twist_cell(), "coarse", tilt=BETA)


def test_strip_strain_recovers_an_affine_field() -> None:
    """Analytic oracle: any affine displacement is recovered exactly, and a uniaxial natural
    strain ε along the chamber axis n = (−sin β, cos β) gives the ROM's twisting kinematics,
    γ_xy = −ε sin 2β and axial strain ε cos² β (in the mesh's frame)."""
    g = _twist_cell()
    m = cell_mesh(g, TINY, half=False, n_cells=3, tilt=BETA)
    nodes, w = m.strip_nodes()
    X = m.points[nodes]
    H = np.array([[0.01, -0.02, 0.003], [0.015, 0.02, -0.004], [0.001, 0.002, -0.01]])
    s = strip_strain(X, X + X @ H.T + [1e-3, -2e-3, 5e-4], w)
    assert np.allclose(s.gradient, H, atol=1e-13)
    assert s.shear == pytest.approx(H[0, 1] + H[1, 0], abs=1e-13)
    eps = 0.02
    n = np.array([-math.sin(BETA), math.cos(BETA), 0.0])
    s = strip_strain(X, X + eps * np.outer(X @ n, n), w)
    assert s.shear == pytest.approx(-eps * math.sin(2 * BETA), abs=1e-14)
    assert s.axial == pytest.approx(eps * math.cos(BETA) ** 2, abs=1e-14)
    assert s.rotation == pytest.approx(0.0, abs=1e-14)


def _strip_at(beta: float, pressure: float) -> tuple[float, float, float]:
    """(γ, axial strain, twist angle) of a 2-cell strip at one pressure (one Newton solve
    from the undeformed state: the pressure is small enough)."""
    from multimorph.fe import bend_and_twist, build_cell_problem, make_solver, newton

    m = cell_mesh(_twist_cell(), TINY, half=False, n_cells=2, tilt=beta)
    problem, L, mu = build_cell_problem(m)
    solver = make_solver("auto")
    try:
        x, info = newton(problem, problem.get_x(), pressure / mu, solver, tol=1e-10,
                         maxiter=12)
    finally:
        solver.release()
    assert info.converged, info.message
    problem.set_x(x)
    xd = m.points + problem.values * L
    nodes, w = m.strip_nodes()
    s = strip_strain(m.points[nodes], xd[nodes], w)
    _, twist = bend_and_twist(m.points[m.end_face], xd[m.end_face])
    return s.shear, s.axial, twist


@pytest.mark.slow
def test_strip_shear_follows_the_tilt() -> None:
    """Inflated, a strip of tilted chambers shears in its plane; the mirror image (−β) shears
    the other way by as much, and a straight strip not at all (both exact by symmetry)."""
    P = 0.05 * _twist_cell().mu
    g_pos, a_pos, t_pos = _strip_at(BETA, P)
    g_neg, a_neg, t_neg = _strip_at(-BETA, P)
    g_0, a_0, t_0 = _strip_at(0.0, P)
    # chamber axis n = (−sin β, cos β): it expands along n, so γ_xy has the sign of −β
    assert g_pos < 0 < g_neg
    assert a_pos > 0 and a_0 > 0
    # mirror x → w − x: γ and the twist change sign, the axial strain does not (solver
    # tolerance 1e-10 relative on the residual)
    assert g_neg == pytest.approx(-g_pos, rel=1e-6)
    assert t_neg == pytest.approx(-t_pos, rel=1e-5)
    assert a_neg == pytest.approx(a_pos, rel=1e-6)
    assert abs(g_0) < 1e-8 * abs(g_pos) and abs(t_0) < 1e-6 * abs(t_pos)
    # the shear is a sizeable part of the chamber's expansion, not a numerical residue
    assert abs(g_pos) > 0.5 * a_pos


@pytest.mark.slow
def test_fe_shear_against_the_rom_twisting_kinematics() -> None:
    """``simulate_cell(..., tilt=β)`` records the shear; against the ROM's γ = (λ_mid − 1)
    sin 2β of the straight cell it has the same sign and is larger (measured on this mesh:
    FE/ROM 3.1 at 0.05 μ, 2.4 at 0.1 μ; docs/fe.md): the FE cell is softer than the ROM's
    (its side walls lean out, Pc about half the ROM's, see "ROM vs FE") and the tilted
    chamber's side walls, pushed apart, add shear that the ROM's uniaxial kinematics lacks."""
    from multimorph.fe import FESettings, compare_shear

    g = _twist_cell()
    c = compare_shear(g, BETA, 0.1 * g.mu, FESettings(mesh=TINY), n_cells=2)
    assert c.meta["fe_status"] == "completed"
    assert np.all(np.diff(c.pressure) > 0) and c.pressure[-1] == pytest.approx(0.1 * g.mu)
    late = c.pressure >= 0.05 * g.mu  # the ROM's small-pressure response is not linear
    assert np.all(c.shear_fe[late] < 0) and np.all(c.shear_rom[late] < 0)
    assert np.all((c.ratio[late] > 1.0) & (c.ratio[late] < 5.0))
    assert np.all(c.axial_fe[late] > 0) and np.all(c.axial_rom[late] > 0)


@pytest.mark.slow
def test_cli_fem_tilt(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """``multimorph fem --tilt`` meshes the full tilted strip, reports its shear and writes a
    sheared STEP/STL; a bad angle, or a tilt with a device spec, exits 2 and writes nothing."""
    import json

    from typer.testing import CliRunner

    from multimorph.cli._app import _register, app

    _register()
    spec = tmp_path / "twist.toml"
    spec.write_text(
        '[cell]\nlength = "10 mm"\nwidth = "12 mm"\nheight = "10 mm"\ntop_wall = "0.5 mm"\n'
        'bottom_wall = "4 mm"\nside_wall = "2.5 mm"\nend_wall = "0.75 mm"\n'
        'material = "dragon-skin-10"\n')
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["fem", str(spec), "--tilt", "30 deg", "--cells", "2",
                                   "--element-size", "3 mm", "--pmax", "2.5 kPa",
                                   "--no-vtu", "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    info = json.loads(res.output)
    assert info["stats"]["tilt"] == pytest.approx(BETA)
    assert info["stats"]["settings"]["half"] is False
    assert info["final"]["strip_shear"] < 0  # chamber axis (−sin β, cos β): γ_xy < 0
    header = (out / "path.csv").read_text().splitlines()[0].split(",")
    assert "shear" in header and "strip_axial_strain" in header
    for name in ("cell.step", "cell.stl"):
        assert (out / name).is_file(), name
    # the STL (ASCII, gmsh) is the sheared solid: its vertices reach y < 0 on the x = 0 side
    pts = np.array([[float(v) for v in line.split()[1:4]]
                    for line in (out / "cell.stl").read_text().splitlines()
                    if line.strip().startswith("vertex")])
    assert pts[:, 1].min() < -1.0 and pts[:, 1].max() > 20.0 + 1.0  # mm, tan 30° · 6 mm
    for bad in (["--tilt", "85 deg"], ["--tilt", "ten"]):
        r = CliRunner().invoke(app, ["fem", str(spec), *bad, "--out", str(tmp_path / "bad")])
        assert r.exit_code == 2, r.output
        assert "--tilt" in r.output
        assert not (tmp_path / "bad").exists()
