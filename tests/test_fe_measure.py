"""Measurements from node coordinates (chamber volume, circle fit, section rotation)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("felupe")

from multimorph.fe import (
    bend_and_twist,
    cell_mesh,
    chamber_volume,
    circle_fit_curvature,
)
from multimorph.geometry import CellGeometry
from multimorph.materials import Material

GEOM = CellGeometry(20e-3, 10e-3, 8e-3, 1e-3, 2e-3, 2e-3, 2e-3,
                    material=Material("neo-hooke", {"mu": 1e5}))


@pytest.mark.parametrize("half", [True, False])
@pytest.mark.parametrize("preset", ["coarse", "medium"])
def test_reference_chamber_volume_and_tags(half: bool, preset: str) -> None:
    m = cell_mesh(GEOM, preset, half=half)
    V = chamber_volume(m.points, m.chamber_faces, mirror_x=GEOM.width / 2 if half else None)
    assert V == pytest.approx(GEOM.wc * GEOM.hc * GEOM.dc, rel=1e-12)
    # walls fall on grid lines: every bottom-layer cell lies below z = hb
    cen = m.points[m.cells].mean(axis=1)
    assert np.all((cen[:, 2] < GEOM.hb) == (m.region == 1))
    assert np.all(m.points[m.clamped, 1] == 0.0)
    assert np.all(np.diff(m.points[m.bend_line, 1]) > 0)


def test_volume_of_moved_mesh_is_exact_for_affine_maps() -> None:
    m = cell_mesh(GEOM, "coarse", half=False)
    F = np.array([[1.2, 0.1, 0.0], [0.0, 0.9, 0.2], [0.05, 0.0, 1.1]])
    x = m.points @ F.T
    V = chamber_volume(x, m.chamber_faces)
    assert V == pytest.approx(np.linalg.det(F) * GEOM.wc * GEOM.hc * GEOM.dc, rel=1e-12)


def test_circle_fit_recovers_radius_and_sign() -> None:
    R = 0.05
    t = np.linspace(0.0, 0.8, 17)
    y, z = R * np.sin(t), -(R - R * np.cos(t))  # turns towards -z: top outward, κ > 0
    assert circle_fit_curvature(y, z) == pytest.approx(1 / R, rel=1e-10)
    assert circle_fit_curvature(y, -z) == pytest.approx(-1 / R, rel=1e-10)
    assert circle_fit_curvature(t, 0 * t) == 0.0


def test_bend_and_twist_of_a_rigid_rotation() -> None:
    rng = np.random.default_rng(1)
    X = rng.random((20, 3))
    th, ps = 0.4, 0.25

    def rot(axis: int, a: float) -> np.ndarray:
        c, s = np.cos(a), np.sin(a)
        i, j = [k for k in range(3) if k != axis]
        R = np.eye(3)
        R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
        return R

    # twist about y first, then bend about x (towards -z for a positive angle)
    R = rot(0, -th) @ rot(1, ps)
    bend, twist = bend_and_twist(X, X @ R.T + 0.3)
    assert bend == pytest.approx(th, abs=1e-12)
    assert abs(twist) == pytest.approx(ps, abs=1e-12)


def test_largest_stretch_matches_an_eigen_solver_including_repeated_eigenvalues() -> None:
    """The closed-form largest principal stretch equals sqrt(max eig(FᵀF)) for random F, the
    identity, uniaxial stretch (two equal smallest eigenvalues) and equibiaxial stretch
    (two equal largest: the numerically worst case of the trigonometric formula)."""
    from multimorph.fe.analyses import largest_stretch

    rng = np.random.default_rng(3)
    F = np.eye(3)[:, :, None, None] + 0.4 * rng.standard_normal((3, 3, 4, 500))
    F[:, :, 0, 0] = np.eye(3)
    F[:, :, 0, 1] = np.diag([2.0, 2.0 ** -0.5, 2.0 ** -0.5])
    F[:, :, 0, 2] = np.diag([1.5, 1.5, 1.5 ** -2])
    R = np.linalg.qr(rng.standard_normal((3, 3)))[0]
    F[:, :, 0, 3] = R @ np.diag([1.3, 1.3, 0.7]) @ R.T
    lam = largest_stretch(F)
    C = np.einsum("kiqc,kjqc->qcij", F, F)
    ref = np.sqrt(np.linalg.eigvalsh(C)[..., -1])
    np.testing.assert_allclose(lam, ref, rtol=1e-8)
    assert lam[0, :4] == pytest.approx([1.0, 2.0, 1.5, 1.3], rel=1e-8)


def test_peak_element_over_all_and_over_a_subset() -> None:
    """The element of the largest stretch, over all elements and over a subset (a device
    module's), is the brute-force one."""
    from multimorph.fe.analyses import peak_element

    ev = np.random.default_rng(3).uniform(1.0, 2.0, size=(8, 50))
    assert peak_element(ev) == int(np.argmax(ev.max(axis=0)))
    among = np.arange(0, 50, 7)
    best = max(among, key=lambda j: ev[:, j].max())
    assert peak_element(ev, among) == best


def test_a_free_tips_end_wall_is_left_out_of_the_bend_fit() -> None:
    """At a free end the bulging end wall pulls the bottom edge under it; the bend is read
    on the rest of the edge (stop 27: the double-curvature 'reverse' module, 2 cells, read
    κL = −0.80 rad at a 0.1 % stretch on the whole edge, −0.11 rad without that part)."""
    from multimorph.fe import FESettings, MeshDensity, simulate_cell

    fit = circle_fit_curvature

    mat = Material("gent", {"mu": 245e3, "jm": 25.0})
    g = CellGeometry(17.3e-3, 7.42e-3, 10.8e-3, 2.09e-3, 4.05e-3, 1.23e-3, 2.14e-3,
                     material=mat, bottom_material=mat)
    res = simulate_cell(g, FESettings(mesh=MeshDensity(wall_elements=1, length_fraction=0.1),
                                      p_max=20e3, method="pressure"), n_cells=2, end="free")
    mesh = res.mesh
    x = mesh.points + res.displacements[-1][:len(mesh.points)]
    line = np.asarray(mesh.bend_line)
    inner = line[mesh.points[line, 1] <= mesh.length - g.df * (1 - 1e-9)]
    assert 3 <= inner.size < line.size
    k_all = fit(x[line, 1], x[line, 2])
    k_inner = fit(x[inner, 1], x[inner, 2])
    assert res.response.path.curvature[-1] == pytest.approx(k_inner, rel=1e-9)
    # the end wall's pull is most of what the whole edge reads, at a 0.2 % stretch
    assert abs(k_inner) < 0.5 * abs(k_all)
    assert res.response.path.axial_stretch[-1] < 1.005
