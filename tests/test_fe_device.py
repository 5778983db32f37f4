"""FE devices on one pressure line: bending and stretching modules in series in one mesh,
twisting modules and parallel branches (fingers) tied on by rigid hubs.

Small cells (10 × 8 × 6 mm), one element through each wall, edges d/3 and low pressures keep
every run to a few seconds with SuperLU.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("felupe")
pytest.importorskip("contique")

from multimorph.device import Device, Module
from multimorph.errors import SpecError
from multimorph.fe import (
    FEDeviceResult,
    FESettings,
    MeshDensity,
    cell_mesh,
    chamber_volume,
    compare_device,
    device_mesh,
    fe_device_modules,
    simulate_cell,
    simulate_device,
)
from multimorph.fe.mesh import BOTTOM
from multimorph.geometry import CellGeometry
from multimorph.materials import Material

pytestmark = pytest.mark.slow

MU = 1.0e5
SOFT = Material("gent", {"mu": MU, "jm": 30.0})
STIFF = Material("gent", {"mu": 10 * MU, "jm": 30.0})
DENS = MeshDensity(wall_elements=1, length_fraction=1 / 3)


def _bend_cell(**kw: float) -> CellGeometry:
    base = dict(length=10e-3, width=8e-3, height=6e-3, top_wall=0.8e-3, bottom_wall=1.5e-3,
                side_wall=1e-3, end_wall=1e-3)
    base.update(kw)
    return CellGeometry(**base, material=SOFT, bottom_material=STIFF)


def _seal_cell() -> CellGeometry:
    return CellGeometry(10e-3, 12e-3, 7e-3, 0.8e-3, 0.8e-3, 1e-3, 1e-3, material=SOFT)


def _series(*mods: tuple[str, str, CellGeometry, int, float]) -> Device:
    out, start = [], 0.0
    for name, kind, cell, n, orient in mods:
        m = Module(name, kind, cell, n_cells=n, start=start, orientation=orient)
        out.append(m)
        start = m.end
    return Device(tuple(out))


def test_one_module_device_is_the_module() -> None:
    """A device of one bending module is the module of ``simulate_cell(n_cells=2)``: the
    same mesh, the same nondimensional problem, so the same path; the module's bend angle
    (end section relative to the clamped start) is the cell run's end rotation. Whole
    model: a half model's device sections are completed by their mirror images before the
    rotation fit, the cell's end face is not (their angles differ by ~0.3 % here)."""
    g = _bend_cell()
    dev = _series(("m", "bending", g, 2, 0.0))
    for half in (True, False):
        dm, cm = device_mesh(dev, DENS, half=half), cell_mesh(g, DENS, n_cells=2, half=half)
        assert dm.points.shape == cm.points.shape and np.array_equal(dm.points, cm.points)
        assert np.array_equal(dm.cells, cm.cells) and np.array_equal(dm.region, cm.region)
        assert np.array_equal(dm.chamber_points, cm.chamber_points)
        assert np.array_equal(dm.end_sections[0], cm.end_face)
    s = FESettings(mesh=DENS, p_max=0.2 * MU, half=False)
    fe = simulate_device(dev, s)
    ref = simulate_cell(g, s, n_cells=2)
    assert fe.stats["nfree"] == ref.stats["nfree"]
    r = fe.responses["m"]
    assert np.allclose(r.path.pressure, ref.response.path.pressure, rtol=0, atol=1e-9 * MU)
    # identical problems: agreement to round-off (1e-9 rad on angles of ~0.2 rad)
    assert np.allclose(r.path.extra["bend_angle"], ref.response.path.extra["bend_angle"],
                       rtol=0, atol=1e-9)
    assert np.allclose(r.path.volume, ref.response.path.volume, rtol=1e-9)
    assert np.allclose(r.path.curvature, r.path.extra["bend_angle"] / (2 * g.length))
    assert r.path.extra["bend_angle"][-1] > 0.05  # it bent (towards −z, the stiff side in)
    # the free end is the tip: its rotation is the module's
    assert np.allclose(fe.tip_angle, r.path.extra["bend_angle"], atol=1e-12)


def test_half_and_whole_models_measure_the_same_bend() -> None:
    """The half model is the whole model's half, node for node, and the symmetric solution
    is the same: completing a half section by the mirror images of its nodes *off* the
    mirror plane gives the whole section, so both measure the same bend and stretch (to
    round-off). Mirroring the on-plane nodes too weighted them twice and read a 4 % larger
    bend on this coarse section (5 × 5 nodes) before stop 15."""
    dev = Device((Module("finger", "bending", _bend_cell()),))
    r = {half: simulate_device(dev, FESettings(mesh=DENS, method="pressure", p_max=0.2 * MU,
                                               half=half)).responses["finger"].path
         for half in (True, False)}
    assert r[True].pressure[-1] == r[False].pressure[-1] == pytest.approx(0.2 * MU)
    assert r[True].extra["bend_angle"][-1] == pytest.approx(r[False].extra["bend_angle"][-1],
                                                            rel=1e-9)
    assert r[True].axial_stretch[-1] == pytest.approx(r[False].axial_stretch[-1], rel=1e-9)
    assert r[True].extra["bend_angle"][-1] > 0.05


def test_mesh_tags_of_a_mixed_device() -> None:
    """Different cross-sections on one grid: chamber volume = the modules' chambers
    (divergence theorem, exact for the reference), material and region tags per module,
    sections inside each module's own box, z mirrored for a module turned by 180°."""
    bend, seal = _bend_cell(), _seal_cell()
    dev = _series(("a", "bending", bend, 2, 0.0), ("s", "stretching", seal, 2, 0.0),
                  ("b", "bending", bend, 1, math.pi))
    for half in (True, False):
        m = device_mesh(dev, DENS, half=half)
        mirror = m.width / 2 if half else None
        vols = [mod.n_cells * mod.cell.wc * mod.cell.hc * mod.cell.dc for mod in m.modules]
        assert chamber_volume(m.points, m.chamber_faces, mirror_x=mirror) == pytest.approx(
            sum(vols), rel=1e-12)
        for i, v in enumerate(vols):
            faces = m.chamber_faces[m.face_module == i]
            assert chamber_volume(m.points, faces, mirror_x=mirror) == pytest.approx(v, rel=1e-12)
        assert (m.width, m.height) == (seal.width, seal.height)
        assert m.starts == pytest.approx([0.0, 20e-3, 40e-3, 50e-3])
        # materials: soft walls everywhere, stiff only in the bending modules' bottom layers
        assert m.materials == (SOFT, STIFF)
        stiff = m.material == 1
        assert np.all(m.region[stiff] == BOTTOM) and set(m.module[stiff]) == {0, 2}
        assert not np.any(stiff & (m.module == 1))
        cz = m.points[m.cells].mean(axis=1)[:, 2]
        lo = (m.height - bend.height) / 2
        assert np.all(cz[stiff & (m.module == 0)] < lo + bend.hb)   # 0°: bottom layer below
        assert np.all(cz[stiff & (m.module == 2)] > lo + bend.height - bend.hb)  # 180°: above
        # each module's elements stay inside its box; sections lie on its end planes
        cx = np.abs(m.points[m.cells].mean(axis=1)[:, 0] - m.width / 2)
        for i, mod in enumerate(m.modules):
            assert cx[m.module == i].max() < mod.cell.width / 2
            for sec, y in ((m.start_sections[i], m.starts[i]), (m.end_sections[i],
                                                                 m.starts[i + 1])):
                assert np.allclose(m.points[sec, 1], y)
                assert np.abs(m.points[sec, 0] - m.width / 2).max() == pytest.approx(
                    mod.cell.width / 2)
    # the device turned over (every orientation + 180°) is the z-mirror of the mesh
    flip = _series(("a", "bending", bend, 2, math.pi), ("s", "stretching", seal, 2, math.pi),
                   ("b", "bending", bend, 1, 0.0))
    m0, m1 = device_mesh(dev, DENS), device_mesh(flip, DENS)
    mirrored = m0.points * [1, 1, -1] + [0, 0, m0.height]
    key = np.lexsort(np.round(mirrored / 1e-9).T)
    key1 = np.lexsort(np.round(m1.points / 1e-9).T)
    assert np.allclose(mirrored[key], m1.points[key1], atol=1e-12)
    assert np.bincount(m0.material).tolist() == np.bincount(m1.material).tolist()


def test_flipped_modules_bend_in_opposite_senses() -> None:
    """Two equal bending modules, the second turned by 180°: in its own frame each bends
    towards its stiff layer (positive); in the device frame they cancel, so the tip turns
    back towards the axis. The magnitudes differ only by the clamp, which stiffens the first
    module (a clamped module is 4–6 % stiffer on the reference cell, docs/fe.md; measured
    here 3–5 % on this one-element-through-the-wall mesh)."""
    g = _bend_cell()
    dev = _series(("a", "bending", g, 2, 0.0), ("b", "bending", g, 2, math.pi))
    fe = simulate_device(dev, FESettings(mesh=DENS, p_max=0.2 * MU))
    pa, pb = (fe.responses[k].path for k in ("a", "b"))
    a, b = pa.extra["bend_angle"][1:], pb.extra["bend_angle"][1:]
    assert np.all(a > 0) and np.all(b > 0) and a[-1] > 0.05
    assert np.all(pb.extra["bend_angle_device"][1:] < 0)
    ratio = b / a
    assert np.all((ratio > 1.0) & (ratio < 1.2))
    # rotations about one axis add: the tip turns by the sum of the device-frame angles
    tip = pa.extra["bend_angle_device"] + pb.extra["bend_angle_device"]
    assert np.allclose(fe.tip_angle, tip, rtol=0, atol=1e-9)
    assert abs(fe.tip_angle[-1]) < 0.15 * (a[-1] + b[-1])
    # both modules see the one pressure line: the same points, chambers inflating alike
    assert np.array_equal(pa.pressure, pb.pressure)
    assert np.all(pa.extra["volume_ratio"][1:] > 1) and np.all(pb.extra["volume_ratio"][1:] > 1)
    assert fe.responses["a"].characteristic.signal == "curvature"
    # per-module Pc/Ph against the reduced model: the structure of the comparison
    top = float(fe.pressure.max())
    cmp = compare_device(fe, _FakeRom(fe, 0.5 * top))
    for name in ("a", "b"):
        pc_fe, ph_fe = fe.activation(name)
        assert cmp[name]["ph_fe"] == ph_fe
        assert cmp[name]["pc_fe"] == pc_fe and cmp[name]["pc_rom"] == 0.5 * top
        assert cmp[name]["ph_rom"] is None and cmp[name]["ph_rel"] is None
        expect = None if pc_fe is None else (0.5 * top - pc_fe) / pc_fe
        assert cmp[name]["pc_rel"] == expect
        # the stand-in is FE's own response: both curves of comparison.png are the same
        curves = cmp[name]["curves"]
        assert curves["quantity"] == "bend_angle_deg"
        assert curves["pressure_pa_rom"] == curves["pressure_pa_fe"]
        np.testing.assert_allclose(curves["rom"], curves["fe"], rtol=1e-12, atol=1e-12)


class _FakeRom:
    """A reduced-model stand-in: every module's FE response with its Pc at ``pc``, no Ph
    (structure test only)."""

    def __init__(self, fe: FEDeviceResult, pc: float) -> None:
        from dataclasses import replace

        from multimorph.device import module_strains

        modules = {module.name: module for module in fe.mesh.modules}
        self.strains = {
            name: module_strains(modules[name], replace(
                r, characteristic=replace(r.characteristic, critical=pc, hardening=None)))
            for name, r in fe.responses.items()}


def test_stretching_module_stretches_without_bending() -> None:
    """A mirror-symmetric stretching module: its z-symmetric mesh gives no bend, its
    centroid arc lengthens with pressure, and Pc/Ph are read on the axial stretch."""
    dev = _series(("s", "stretching", _seal_cell(), 1, 0.0))
    fe = simulate_device(dev, FESettings(mesh=DENS, p_max=0.12 * MU))
    p = fe.responses["s"].path
    assert fe.responses["s"].characteristic.signal == "axial_stretch"
    assert np.max(np.abs(p.extra["bend_angle"])) < 1e-6  # round-off of the symmetric mesh
    assert np.all(np.diff(p.axial_stretch) > 0) and p.axial_stretch[-1] > 1.005
    assert fe.tip[-1, 1] > fe.tip[0, 1]


@pytest.mark.parametrize("change, field", [
    (dict(count=3, radius=5e-3), "count"),
    (dict(start=25e-3), "start"),
])
def test_unsupported_devices_are_refused(change: dict, field: str) -> None:
    g = _bend_cell()
    base = Module("base", "bending", g, n_cells=2)
    tip = Module(**{"name": "tip", "kind": "bending", "cell": g, "start": base.end, **change})
    with pytest.raises(SpecError, match=rf"module 'tip'\.{field}.*FE devices support"):
        device_mesh(Device((base, tip)))


def _fingers_on(trunk: Module, count: int = 2, radius: float = 5e-3) -> Device:
    finger = Module("finger", "bending", _bend_cell(), branch="f", attach_to=trunk.name,
                    count=count, radius=radius)
    return Device((trunk, finger))


def test_branches_that_fe_cannot_hold_are_refused() -> None:
    g = _bend_cell()
    fingers = _fingers_on(Module("base", "bending", g, n_cells=2)).modules
    tip = Module("tip", "bending", g, branch="t", attach_to="finger")
    with pytest.raises(SpecError, match=r"module 'tip'\.attach_to: 'finger' has 2 copies"):
        simulate_device(Device((*fingers, tip)))
    loose = Module("loose", "bending", g, branch="l")  # a second clamped branch
    with pytest.raises(SpecError, match=r"2 clamped branches \(l, main\)"):
        device_mesh(Device((*fingers, loose)))
    with pytest.raises(SpecError, match="single series"):
        fe_device_modules(Device(fingers))


def test_mesh_of_parallel_fingers_places_them_as_the_reduced_model() -> None:
    """Copies j = 0, 1, 2 start at the parent's end section, turned by 120° j about its axis
    and ``radius`` out along the turned z (the reduced model's placement); each copy is the
    series grid of its branch, moved rigidly; one hub ties the parent's end section and the
    copies' start sections, its two extra nodes in no element."""
    from multimorph.device import simulate_device as rom_device

    trunk = Module("trunk", "bending", _bend_cell(), n_cells=2)
    dev = _fingers_on(trunk, count=3, radius=6e-3)
    m = device_mesh(dev, DENS)
    one = device_mesh(Device((Module("finger", "bending", _bend_cell()),)), DENS, half=False)
    assert [e.name for e in m.modules] == ["trunk", "finger#0", "finger#1", "finger#2"]
    assert m.source == ("trunk", "finger", "finger", "finger") and not m.half
    assert len(m.cells) == len(device_mesh(Device((trunk,)), DENS, half=False).cells) + 3 * len(
        one.cells)
    rom = rom_device(dev, 1.0).shape(0.0)  # undeformed centre lines, ROM frame
    axis = np.array([m.width / 2, 0.0, m.height / 2])  # the ROM's origin in the mesh frame
    end = m.frames[0][0] + np.array([0.0, trunk.length, 0.0])
    (h,) = m.hubs
    assert np.allclose(m.points[h.center], end) and h.parent == 0 and h.children == (1, 2, 3)
    assert h.rotation not in m.cells and h.center not in m.cells
    for j in range(3):
        o, Q = m.frames[1 + j]
        assert np.allclose(Q @ Q.T, np.eye(3)) and np.linalg.det(Q) == pytest.approx(1.0)
        assert np.allclose(o, axis + rom[f"finger#{j}"][0], atol=1e-12)  # start on the ROM
        assert np.allclose(o + Q[:, 1] * 10e-3, axis + rom[f"finger#{j}"][-1], atol=1e-12)
        # the copy is the standalone grid moved rigidly
        c = np.flatnonzero(m.module == 1 + j)
        d = np.linalg.norm(m.points[m.cells[c]] - m.points[m.cells[c]].mean(1, keepdims=True),
                           axis=2)
        d1 = np.linalg.norm(one.points[one.cells] - one.points[one.cells].mean(1, keepdims=True),
                            axis=2)
        assert np.allclose(np.sort(d.ravel()), np.sort(d1.ravel()))
        assert set(m.start_sections[1 + j]) <= set(h.points)
        faces = m.chamber_faces[m.face_module == 1 + j]
        g = _bend_cell()
        assert chamber_volume(m.points, faces) == pytest.approx(g.wc * g.hc * g.dc, rel=1e-12)
    assert set(m.end_sections[0]) <= set(h.points)
    assert m.clamped.sum() == len(m.start_sections[0])  # only the trunk's base


def test_fingers_on_a_bending_trunk_bend_as_clamped_fingers() -> None:
    """Two fingers on the end of a soft bending trunk, on one pressure line. The hub is
    rigid, so (follower pressure being objective) each finger bends relative to its base
    exactly as the same finger clamped alone, however the trunk carries it: the copies
    agree with each other and with the lone finger, the hub turns with the trunk's end
    section, and the tied nodes keep their distances."""
    trunk = Module("trunk", "bending", _bend_cell(), n_cells=1)
    dev = _fingers_on(trunk)
    s = FESettings(mesh=DENS, p_max=0.4 * MU, half=False)
    fe = simulate_device(dev, s)
    alone = simulate_device(Device((Module("finger", "bending", _bend_cell()),)), s)
    a0, a1 = (fe.responses[f"finger#{j}"].path.extra["bend_angle"] for j in (0, 1))
    P = fe.pressure
    assert np.allclose(a0, a1, rtol=1e-6, atol=1e-9)
    ref = alone.responses["finger"].path
    inside = ref.pressure <= P[-1]
    assert inside.sum() >= 5 and ref.extra["bend_angle"][inside][-1] > 0.3  # > 17°
    # the two paths sample different pressures; linear interpolation on this steepening
    # curve costs up to ~0.5 % (the copies, sampled alike, agree to 1e-6 above)
    got = np.interp(ref.pressure[inside], P, a0)
    assert np.allclose(got, ref.extra["bend_angle"][inside], rtol=1e-2, atol=1e-4)
    # the hub turns with the trunk's end (the trunk bends, clamped at its start)
    bend = fe.responses["trunk"].path.extra["bend_angle"]
    assert bend[-1] > 0.1
    assert np.allclose(fe.hub_rotation[:, 0], np.abs(bend), rtol=1e-3, atol=1e-6)
    h = fe.mesh.hubs[0]
    X = fe.mesh.points[h.points]
    x = X + fe.displacements[-1][h.points]
    D0 = np.linalg.norm(X[:, None] - X[None], axis=-1)
    D = np.linalg.norm(x[:, None] - x[None], axis=-1)
    assert np.max(np.abs(D - D0)) < 1e-4 * D0.max()
    info = fe.to_dict(paths=False)
    assert info["hubs"][0]["children"] == ["finger#0", "finger#1"]
    assert info["modules"]["finger#1"]["module"] == "finger"
    cmp_ = compare_device(fe)
    assert set(cmp_) == {"trunk", "finger#0", "finger#1"}
    assert cmp_["finger#0"]["pc_rom"] == cmp_["finger#1"]["pc_rom"]


def test_cli_refuses_an_unsupported_device_and_writes_nothing(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from multimorph.cli._app import _register, app

    _register()
    spec = Path(__file__).resolve().parents[1] / "examples" / "double_curvature.toml"
    text = spec.read_text().replace('orientation = "180 deg"',
                                    'orientation = "180 deg"\ncount = 2', 1)
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["fem", str(bad), "--out", str(out), "--json"])
    assert res.exit_code == 2
    assert ".count" in res.output and "FE devices support" in res.output
    assert not out.exists()
    res = CliRunner().invoke(app, ["fem", str(spec), "--cells", "2", "--out", str(out)])
    assert res.exit_code == 2 and "--cells" in res.output and not out.exists()


@pytest.mark.parametrize("file", ["fe_device.toml", "double_curvature.toml"])
def test_example_devices_mesh(file: str) -> None:
    """The FE example and the double-curvature grasper (20 and 10 mm wide cells, modules at
    180°) are FE devices: their coarse meshes enclose exactly their chambers."""
    from multimorph.device import device_from_spec
    from multimorph.io import load_toml

    dev = device_from_spec(load_toml(Path(__file__).resolve().parents[1] / "examples" / file))
    m = device_mesh(dev, "coarse")
    assert [mod.name for mod in m.modules] == [mod.name for mod in dev.modules]
    assert m.length == pytest.approx(sum(mod.length for mod in dev.modules))
    for i, mod in enumerate(m.modules):
        faces = m.chamber_faces[m.face_module == i]
        assert chamber_volume(m.points, faces, mirror_x=m.width / 2) == pytest.approx(
            mod.n_cells * mod.cell.wc * mod.cell.hc * mod.cell.dc, rel=1e-12)
    if file == "fe_device.toml":  # the size docs/fe.md quotes (8 480 free DOF)
        assert m.ndof - 3 * m.clamped.sum() - (m.mirror & ~m.clamped).sum() == 8480


def _run_fem_json(example: str, pmax: str, out: Path, monkeypatch: pytest.MonkeyPatch,
                  ) -> dict:
    """``multimorph fem examples/<example> --pmax <pmax> --json`` on the tiny test mesh
    (pressure steps); asserts exit 0 and returns the JSON."""
    import json

    from typer.testing import CliRunner

    from multimorph.cli._app import _register, app
    from multimorph.fe import MESH_PRESETS

    _register()
    monkeypatch.setitem(MESH_PRESETS, "coarse", DENS)
    spec = Path(__file__).resolve().parents[1] / "examples" / example
    res = CliRunner().invoke(app, ["fem", str(spec), "--mesh", "coarse", "--pmax", pmax,
                                   "--method", "pressure", "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.output)


def _step_volumes(path: Path) -> list[float]:
    """Volumes (mm³) of the solids in a STEP file, read back with gmsh."""
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        vols = gmsh.model.occ.importShapes(str(path))
        gmsh.model.occ.synchronize()
        return [gmsh.model.occ.getMass(*v) for v in vols]
    finally:
        gmsh.finalize()


def test_cli_fem_device_writes_its_files(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                        ) -> None:
    """``multimorph fem examples/fe_device.toml --json`` on the tiny test mesh: exit 0, the
    per-module summary, and every file it lists (CSV, PNG curves and snapshots, the VTU
    series). In curves.csv's last rows the stalk bends towards its stiff layer and the
    symmetric seal stretches, bending far less (only through its partition with the stalk)."""
    import csv
    import json

    out = tmp_path / "out"
    info = _run_fem_json("fe_device.toml", "10 kPa", out, monkeypatch)
    for f in ("summary.json", "curves.csv", "tip.csv", "curves.png", "snapshots.png",
              "device.step", "device.stl", "device.pvd", "device_0000.vtu", "report.html"):
        assert f in info["files"] and (out / f).exists(), f
    for f in ("curves.png", "snapshots.png"):
        assert (out / f).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the solid (STEP and STL, mm): the boxes of the two modules minus their four chambers,
    # one volume; read back with gmsh, its volume is exact
    (vol,) = _step_volumes(out / "device.step")
    seal, bend = (10 * 20 * 6) - 2 * (8 * 8 * 4.4), (8 * 20 * 6) - 2 * (6 * 8 * 3.7)
    assert vol == pytest.approx(seal + bend, rel=1e-9)
    pts = np.array([[float(v) for v in line.split()[1:4]]
                    for line in (out / "device.stl").read_text().splitlines()
                    if line.strip().startswith("vertex")])
    assert np.allclose(pts.min(axis=0), [0, 0, 0], atol=1e-9)
    assert np.allclose(pts.max(axis=0), [10, 40, 6], atol=1e-9)
    with open(out / "curves.csv") as fh:
        rows = list(csv.DictReader(fh))
    last = {r["module"]: r for r in rows if float(r["pressure_pa"]) == 10e3}
    assert set(last) == {"seal", "stalk"}
    stalk = float(last["stalk"]["bend_angle_deg"])
    assert stalk > 1.0 and abs(float(last["seal"]["bend_angle_deg"])) < 0.2 * stalk
    assert float(last["seal"]["axial_stretch"]) > 1.0
    # where each module's peak stretch is: inside that module, in a named region
    mods = json.loads((out / "summary.json").read_text())["device"]["modules"]
    start = 0.0
    for name in ("seal", "stalk"):
        fin, length = mods[name]["final"], mods[name]["length_m"]
        x, y, z = fin["peak_location_m"]
        assert start < y < start + length and 0 < x and 0 < z < 6e-3
        assert fin["peak_region"] in ("wall", "bottom layer")
        # the walls stretch more than the centroid line: the peak exceeds the mean stretch
        assert fin["peak_stretch"] > float(last[name]["axial_stretch"]) > 1.0
        start += length


def test_cli_fem_fingers_on_a_hub(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``multimorph fem examples/fe_fingers.toml --json`` (a stretching base carrying three
    fingers on a hub) on the tiny test mesh: every copy is a module entry and bends alike,
    the hub is reported, and the STEP holds the four pieces with exactly their volumes."""
    import csv

    out = tmp_path / "out"
    dev = _run_fem_json("fe_fingers.toml", "8 kPa", out, monkeypatch)["device"]
    assert set(dev["modules"]) == {"base", "finger#0", "finger#1", "finger#2"}
    assert dev["hubs"][0]["parent"] == "base"
    assert dev["hubs"][0]["children"] == ["finger#0", "finger#1", "finger#2"]
    with open(out / "curves.csv") as fh:
        rows = [r for r in csv.DictReader(fh) if float(r["pressure_pa"]) == 8e3]
    bend = {r["module"]: float(r["bend_angle_deg"]) for r in rows}
    assert bend["finger#0"] > 0.5
    assert bend["finger#1"] == pytest.approx(bend["finger#0"], rel=1e-5)
    assert bend["finger#2"] == pytest.approx(bend["finger#0"], rel=1e-5)
    assert abs(bend["base"]) < 1e-3 * bend["finger#0"]  # symmetric hub load: no bending
    vols = _step_volumes(out / "device.step")
    total = sum(vols)
    base, finger = (10 * 20 * 6) - 2 * (8 * 8 * 4.4), (8 * 20 * 6) - 2 * (6 * 8 * 3.7)
    # fingers 1 and 2 (at ±120°) touch the base's 10 × 6 mm end face and fuse with it,
    # finger 0 (7 mm out along z, 3 mm half height) clears it: two volumes
    assert len(vols) == 2 and total == pytest.approx(base + 3 * finger, rel=1e-9)


def _twister(n_cells: int = 1) -> Module:
    g = CellGeometry(10e-3, 10e-3, 8e-3, 1e-3, 2.5e-3, 1.5e-3, 1e-3, material=SOFT)
    return Module("twister", "twisting", g, n_cells=n_cells, tilt=math.radians(30.0),
                  shaft_radius=3.2e-3, strips=3)


def test_a_twisting_module_as_a_device_is_the_module() -> None:
    """A device of one twisting module is :func:`simulate_twisting_module`'s problem (the
    same mesh and the same nondimensional problem): the same path, the same twist angle
    (to round-off), and the same twist-rate sign convention."""
    from multimorph.fe import simulate_twisting_module

    tw = _twister()
    s = FESettings(mesh=DENS, method="pressure", p_max=0.2 * MU)
    fe = simulate_device(Device((tw,)), s)
    ref = simulate_twisting_module(tw, s)
    assert fe.stats["nfree"] == ref.stats["nfree"] and not fe.mesh.hubs
    p = fe.responses["twister"].path
    assert np.allclose(p.pressure, ref.pressure, rtol=0, atol=1e-9 * MU)
    assert np.allclose(p.extra["twist_angle"], ref.twist_angle, rtol=0, atol=1e-9)
    assert np.allclose(p.twist_rate, ref.response.path.twist_rate, rtol=0, atol=1e-9)
    assert abs(ref.twist_angle[-1]) > math.radians(1.0)  # it twisted
    assert fe.responses["twister"].characteristic.signal == "twist_rate"


def test_fingers_on_a_twisting_module() -> None:
    """Two fingers on the end of a twisting module (the gripper's layout, small): the hub
    turns with the twister's end section (about the axis: its twist), and the fingers,
    carried round, bend relative to their bases as a lone clamped finger does."""
    dev = Device((_twister(), *_fingers_on(_twister()).modules[1:]))
    m = device_mesh(dev, DENS)
    assert [e.name for e in m.modules] == ["twister", "finger#0", "finger#1"]
    assert m.clamped.sum() == len(m.start_sections[0]) and len(m.hubs) == 1
    s = FESettings(mesh=DENS, method="pressure", p_max=0.2 * MU)
    fe = simulate_device(dev, s)
    alone = simulate_device(Device((Module("finger", "bending", _bend_cell()),)), s)
    tw = fe.responses["twister"].path.extra["twist_angle"]
    assert abs(tw[-1]) > math.radians(1.0)
    assert np.allclose(fe.hub_rotation[:, 0], np.hypot(
        tw, fe.responses["twister"].path.extra["bend_angle"]), rtol=2e-3, atol=1e-6)
    a0, a1 = (fe.responses[f"finger#{j}"].path.extra["bend_angle"] for j in (0, 1))
    assert np.allclose(a0, a1, rtol=1e-6, atol=1e-9)
    ref = alone.responses["finger"].path
    assert np.allclose(np.interp(ref.pressure, fe.pressure, a0), ref.extra["bend_angle"],
                       rtol=1e-2, atol=1e-4)


_TWIST_DEVICE = """
[device]
name = "small bend-then-twist"
pmax = "20 kPa"

[materials.soft]
model = "gent"
mu = "100 kPa"
jm = 30

[materials.stiff]
model = "gent"
mu = "1 MPa"
jm = 30

[cells.twist]
length = "10 mm"
width = "10 mm"
height = "8 mm"
top_wall = "1 mm"
bottom_wall = "2.5 mm"
side_wall = "1.5 mm"
end_wall = "1 mm"
material = "soft"

[cells.finger]
length = "10 mm"
width = "8 mm"
height = "6 mm"
top_wall = "0.8 mm"
bottom_wall = "1.5 mm"
side_wall = "1 mm"
end_wall = "1 mm"
material = "soft"
bottom_material = "stiff"

[[module]]
name = "twister"
kind = "twisting"
cell = "twist"
cells = 1
tilt = "30 deg"
shaft_radius = "3.2 mm"
strips = 3

[[module]]
name = "finger"
kind = "bending"
cell = "finger"
cells = 1
attach_to = "twister"
count = 2
radius = "5 mm"
"""


def test_cli_fem_device_with_a_twisting_module(tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """A twisting module carrying two fingers through ``multimorph fem``: the twister's
    twist is in the summary and in curves.csv, the fingers bend alike; no STEP is written
    (tilted strips on a shaft are not boxes), and device.stl is the mesh's closed surface."""
    import csv

    spec = tmp_path / "twist.toml"
    spec.write_text(_TWIST_DEVICE)
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "out"
    from typer.testing import CliRunner

    from multimorph.cli._app import _register, app
    from multimorph.fe import MESH_PRESETS

    _register()
    monkeypatch.setitem(MESH_PRESETS, "coarse", DENS)
    res = CliRunner().invoke(app, ["fem", str(spec), "--pmax", "10 kPa", "--method",
                                   "pressure", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "twist°" in res.output and "device.step not written" in res.output
    assert not (out / "device.step").exists() and (out / "curves.png").exists()
    # device.stl: the undeformed mesh's closed surface (every edge in two triangles), whose
    # enclosed volume (divergence theorem over the triangles) is the mesh's
    from multimorph.fe.mesh import hex_boundary

    v = np.array([[float(t) for t in line.split()[1:4]]
                  for line in (out / "device.stl").read_text().splitlines()
                  if line.startswith("vertex")]).reshape(-1, 3, 3) / 1e3
    vol_stl = float(np.einsum("ki,ki->k", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum()) / 6
    _, vid = np.unique(np.round(v.reshape(-1, 3) * 1e9), axis=0, return_inverse=True)
    tri = vid.reshape(-1, 3)  # vertex ids (coordinates to the nm)
    edges = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    _, count = np.unique(edges, axis=0, return_counts=True)
    assert np.all(count == 2)
    from multimorph.device import device_from_spec
    from multimorph.io import load_toml

    m = device_mesh(device_from_spec(load_toml(spec)), DENS)
    assert vol_stl == pytest.approx(chamber_volume(m.points, hex_boundary(m.cells)), rel=1e-3)
    with open(out / "curves.csv") as fh:
        rows = [r for r in csv.DictReader(fh) if float(r["pressure_pa"]) == 10e3]
    last = {r["module"]: r for r in rows}
    assert abs(float(last["twister"]["twist_angle_deg"])) > 0.5
    assert float(last["twister"]["twist_rate_rad_per_m"]) > 0  # its own sense: positive
    b0, b1 = (float(last[f"finger#{j}"]["bend_angle_deg"]) for j in (0, 1))
    assert b0 > 0.5 and b1 == pytest.approx(b0, rel=1e-5)


def test_a_twisting_module_between_grids_is_tied_at_both_ends() -> None:
    """bending → twisting → bending on the clamped branch: three pieces (grid, strips on a
    shaft, grid) in series along y, joined by two rigid hubs at the twister's ends; only
    the first piece is clamped; a device without a twisting module or a branch stays one
    grid (no hubs)."""
    g = _bend_cell()
    a = Module("a", "bending", g)
    tw = replace(_twister(), start=a.end)
    b = Module("b", "bending", g, start=tw.end)
    m = device_mesh(Device((a, tw, b)), DENS)
    assert [e.name for e in m.modules] == ["a", "twister", "b"] and m.tip_entry == 2
    assert [(h.parent, h.children) for h in m.hubs] == [(0, (1,)), (1, (2,))]
    ys = [float(o[1]) for o, _ in m.frames]
    assert ys == pytest.approx([0.0, 10e-3, 20e-3], abs=1e-12)
    for h, y in zip(m.hubs, (10e-3, 20e-3), strict=True):
        assert m.points[h.center, 1] == pytest.approx(y)
        assert set(m.end_sections[h.parent]) | set(m.start_sections[h.children[0]]) == set(
            h.points)
    assert set(np.flatnonzero(m.clamped)) == set(m.start_sections[0])
    assert np.all(m.module[m.region == 2] == 1)  # the shaft belongs to the twister
    assert not device_mesh(Device((a, replace(b, start=a.end))), DENS).hubs


def test_fingers_on_a_trunk_resume_from_a_checkpoint(tmp_path: Path) -> None:
    """The rigid hubs carry no state (total rotation vector), so an interrupted device with
    fingers resumes on pressure steps to exactly the uninterrupted path: same pressures,
    same displacements (hub nodes included), same hub rotation."""
    from multimorph.fe import PathCheckpoint

    dev = _fingers_on(Module("trunk", "bending", _bend_cell()))
    s = FESettings(mesh=DENS, method="pressure", p_max=0.15 * MU)
    full = simulate_device(dev, s)

    def stop(p: float, n: int) -> None:
        if n == 4:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        simulate_device(dev, s, checkpoint=PathCheckpoint(tmp_path, "key"), progress=stop)
    ck = PathCheckpoint(tmp_path, "key")
    again = simulate_device(dev, s, checkpoint=ck)
    assert ck.resumed == 3 and again.stats["resumed_points"] == 3
    assert np.array_equal(again.pressure, full.pressure)
    assert np.allclose(again.displacements, full.displacements, rtol=0, atol=1e-12)
    assert np.allclose(again.hub_rotation, full.hub_rotation, rtol=0, atol=1e-12)
    assert full.hub_rotation[-1, 0] > 0.01


def test_a_module_turned_by_90_degrees_is_a_turned_piece() -> None:
    """A bending module at 90° cannot share the grid (its bending plane is not a grid
    plane): it is its own grid, placed turned about its axis as the reduced model turns
    it. Alone and clamped, it is the 0° module rotated: the same bend in its own frame (to
    round-off); after a 0° module its end moves sideways (−x) as in the reduced model."""
    from multimorph.device import simulate_device as rom_device

    g = _bend_cell()
    s = FESettings(mesh=DENS, method="pressure", p_max=0.15 * MU, half=False)
    flat = simulate_device(Device((Module("m", "bending", g),)), s)
    turned = simulate_device(Device((Module("m", "bending", g, orientation=math.pi / 2),)), s)
    assert turned.mesh.frames[0][1] @ [0.0, 0.0, 1.0] == pytest.approx([1.0, 0.0, 0.0])
    a0 = flat.responses["m"].path.extra["bend_angle"]
    a1 = turned.responses["m"].path.extra["bend_angle"]
    assert a0[-1] > 0.04 and np.allclose(a1, a0, rtol=1e-9, atol=1e-12)
    # the stiff side of the turned module faces −x: its free end moves towards −x
    assert turned.tip[-1, 0] < turned.tip[0, 0] - 1e-4
    a = Module("a", "bending", g)
    b = Module("b", "bending", g, start=a.end, orientation=math.pi / 2)
    dev = Device((a, b))
    fe = simulate_device(dev, s)
    assert [h.children for h in fe.mesh.hubs] == [(1,)]
    rom = rom_device(dev, 0.15 * MU).shape(0.15 * MU)
    assert rom["b"][-1][0] < 0 and fe.tip[-1, 0] - fe.tip[0, 0] < -1e-4
    assert fe.responses["b"].path.extra["bend_angle"][-1] > 0.04
