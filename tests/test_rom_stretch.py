"""The mirror-symmetric (stretching) cell of the reduced model.

A cell whose bottom wall is the top wall's mirror image (same thickness, same elastomer)
cannot bend; pressurised, its top and bottom walls balloon alike and the pressure on the end
walls stretches it axially, as the 3D FE of a symmetric module shows (docs/fe.md). The model
is the default energy with the bottom wall bulging like the top (``RomOptions(mirror=True)``),
k held at 0, and Pc/Ph read on the axial stretch.
"""

from __future__ import annotations

import numpy as np
import pytest
from tests._cells import MU, WALL, ref_cell

from multimorph.errors import SpecError
from multimorph.geometry import CellGeometry


def sym_cell(**kw):
    base = dict(top_wall=0.8e-3, bottom_wall=0.8e-3, bottom_material=WALL, symmetric=True)
    base.update(kw)
    return ref_cell(**base)


@pytest.fixture(scope="module")
def stretching():
    from multimorph.rom import solve_cell

    return solve_cell(sym_cell(), 1.2 * MU)


def segment(phi):
    """Circular-segment area over a unit half-chord (A / a²)."""
    return (2 * phi - np.sin(2 * phi)) / (2 * np.sin(phi) ** 2)


def test_symmetric_cell_stretches_and_does_not_bend(stretching):
    path = stretching.path
    q = path.extra["q"]
    assert np.all(path.curvature == 0.0) and np.all(q[:, 0] == 0.0)
    lam = stretching.loading.axial_stretch
    assert np.all(np.diff(lam) > -1e-12)
    ch = stretching.characteristic
    assert ch.signal == "axial_stretch"
    assert ch.critical is not None and ch.hardening is not None
    assert 0.2 * MU < ch.critical < ch.hardening < 1.2 * MU
    # ballooning: the stretch rises slowly below Pc, fast between Pc and Ph, then hardens
    P = stretching.loading.pressure
    x = np.array([0.5 * ch.critical, ch.critical, ch.hardening, P[-1]])
    at = np.interp(x, P, lam)
    slope = np.diff(at) / np.diff(x)
    assert at[0] < 1.15 and at[2] > 1.5
    assert slope[1] > 1.2 * slope[0] and slope[1] > 1.2 * slope[2]
    assert ch.curvature_at["critical"] == 0.0


def test_end_wall_force_and_mirrored_bulge_work():
    """Exact identities of the mirror model's pressure work (plane bulges, no taper): the
    pressure on the end walls, dΔV/de, is the chamber section wc hc + 2 (wc/2)² S(φt) +
    2 (hc/2)² S(φs) (top and bottom segments, two side segments; S the segment area per
    squared half-chord) times the chamber length, so at equilibrium the walls' axial force
    carries p times that section; and the work per unit φt is twice the one-sided wall's (two
    bulging walls) on the stretched length. Checked on states across the traced range."""
    import jax
    import jax.numpy as jnp

    from multimorph.rom import RomOptions, cell_kernel
    from multimorph.rom._model import cell_theta

    opts = RomOptions(mirror=True, end_taper=False)
    cell = sym_cell()
    ck = cell_kernel("gent", "gent", opts)
    th = jax.tree_util.tree_map(jnp.asarray, cell_theta(cell))
    dV = jax.jit(jax.grad(lambda qf: ck.measures(qf, 0.0, th)["volume"]))
    d = cell.length
    wc, hc, dc = cell.chamber_width / d, cell.chamber_height / d, cell.chamber_length / d
    rng = np.random.default_rng(7)
    for phi_t, phi_s, e in rng.uniform([0.1, 0.05, 0.0], [2.4, 2.0, 1.2], (6, 3)):
        g = np.asarray(dV(jnp.asarray([phi_t, phi_s, e])))
        section = wc * hc + 2 * (wc / 2) ** 2 * segment(phi_t) + 2 * (hc / 2) ** 2 * segment(phi_s)
        assert g[2] == pytest.approx(dc * section, rel=1e-9)
        h = 1e-6
        ds = (segment(phi_t + h) - segment(phi_t - h)) / (2 * h)
        assert g[0] == pytest.approx(2 * (1 + e) * dc * (wc / 2) ** 2 * ds, rel=1e-6)


def test_thinner_walls_stretch_earlier():
    from multimorph.rom import solve_cell

    pcs = [solve_cell(sym_cell(top_wall=t, bottom_wall=t), 1.5 * MU).characteristic.critical
           for t in (0.6e-3, 0.8e-3, 1.0e-3)]
    assert pcs[0] < pcs[1] < pcs[2]


def test_symmetric_cell_validation_is_precise():
    with pytest.raises(SpecError, match=r"symmetric.*bottom_wall = top_wall"):
        ref_cell(symmetric=True)                     # 2 mm bottom under a 0.8 mm top wall
    with pytest.raises(SpecError, match=r"symmetric.*bottom_material"):
        ref_cell(bottom_wall=0.8e-3, symmetric=True)  # a stiffer bottom layer
    spec = {"length": "20 mm", "width": "10 mm", "height": "8 mm", "top_wall": "1 mm",
            "bottom_wall": "1 mm", "side_wall": "1.5 mm", "end_wall": "1.5 mm",
            "material": "ecoflex-00-30", "symmetric": "yes"}
    with pytest.raises(SpecError, match=r"cell\.symmetric: expected true or false"):
        CellGeometry.from_spec(spec)
    spec["symmetric"] = True
    c = CellGeometry.from_spec(spec)
    assert c.symmetric and c.signal == "axial_stretch" and c.to_dict()["symmetric"] is True
    m = ref_cell().mirrored()
    assert m.symmetric and m.bottom_wall == m.top_wall and m.bottom_material == m.material


def test_stretching_module_traces_a_mirror_cell():
    from multimorph.device._modules import Module

    plain = ref_cell(bottom_wall=0.8e-3, bottom_material=WALL)
    assert not plain.symmetric
    m = Module(name="seal", kind="stretching", cell=plain, n_cells=2)
    assert m.cell.symmetric and m.cell.signal == "axial_stretch"
    bend = Module(name="b", kind="bending", cell=plain)
    assert not bend.cell.symmetric


def test_mirror_options_are_exclusive():
    from multimorph.rom import RomOptions

    for bad in ({"side_lean": True}, {"rigid_bottom": True}, {"rigid_walls": True}):
        with pytest.raises(SpecError, match="mirror"):
            RomOptions(mirror=True, **bad)
    assert RomOptions(mirror=True).free == (1, 2, 3)


def test_batch_needs_one_kind_of_cell():
    from multimorph.rom import CellBatch

    with pytest.raises(SpecError, match="mirror-symmetric"):
        CellBatch.from_cells([sym_cell(), sym_cell(symmetric=False)])


def test_stretch_sensitivity_matches_retraced_cells(stretching):
    """IFT d(axial stretch)/d(wall) of the mirror model: moving the top and bottom walls
    together (the cell stays symmetric) against two re-traced cells, at fixed pressure."""
    from multimorph.rom import LENGTHS, path_sensitivity, solve_cell

    s = path_sensitivity(sym_cell(), stretching.path)
    it, ib = LENGTHS.index("top_wall"), LENGTHS.index("bottom_wall")
    P = stretching.path.pressure
    h = 2e-6
    plus = solve_cell(sym_cell(top_wall=0.8e-3 + h, bottom_wall=0.8e-3 + h), 1.2 * MU).path
    minus = solve_cell(sym_cell(top_wall=0.8e-3 - h, bottom_wall=0.8e-3 - h), 1.2 * MU).path
    for frac in (0.3, 0.6):
        p = frac * P[-1]
        i = int(np.searchsorted(P, p))
        fd = (np.interp(P[i], plus.pressure, plus.axial_stretch)
              - np.interp(P[i], minus.pressure, minus.axial_stretch)) / (2 * h)
        # at fixed pressure: the path derivative along the arc minus its pressure share
        dlam = s.axial_stretch[i] - (s.pressure[i] * np.gradient(stretching.path.axial_stretch,
                                                                   P)[i])
        ift = dlam[it] + dlam[ib]
        assert ift == pytest.approx(fd, rel=0.03)


def test_batch_traces_symmetric_cells_like_single_ones(stretching):
    """The batched entry point (the designer's) switches the mirror model on by itself."""
    from multimorph.rom import solve_batch

    rb = solve_batch([sym_cell()], 1.2 * MU, vectorise=False)
    assert rb.options.mirror
    r = rb.response(0)
    assert r.characteristic.signal == "axial_stretch"
    assert r.characteristic.critical == pytest.approx(stretching.characteristic.critical,
                                                      rel=1e-9)
    np.testing.assert_allclose(r.path.axial_stretch, stretching.path.axial_stretch, rtol=1e-9)
