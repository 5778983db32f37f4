"""FE devices: bending and stretching modules in series in one mesh, on one pressure line.

Small cells (10 × 8 × 6 mm), one element through each wall, edges d/3 and low pressures keep
every run to a few seconds with SuperLU.
"""

from __future__ import annotations

import math
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
    simulate_cell,
    simulate_device,
)
from multimorph.fe._mesh import BOTTOM
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
    here 6–10 % on this one-element-through-the-wall mesh)."""
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


class _FakeRom:
    """A reduced-model stand-in: every module's Pc at ``pc``, no Ph (structure test only)."""

    def __init__(self, fe: FEDeviceResult, pc: float) -> None:
        from dataclasses import replace
        from types import SimpleNamespace

        self.strains = {
            name: SimpleNamespace(response=replace(
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
    (dict(kind="twisting", tilt=0.5, shaft_radius=3e-3), "kind"),
    (dict(count=3, radius=5e-3), "count"),
    (dict(orientation=math.pi / 2), "orientation"),
    (dict(start=25e-3), "start"),
])
def test_unsupported_devices_are_refused(change: dict, field: str) -> None:
    g = _bend_cell()
    base = Module("base", "bending", g, n_cells=2)
    tip = Module(**{"name": "tip", "kind": "bending", "cell": g, "start": base.end, **change})
    with pytest.raises(SpecError, match=rf"module 'tip'\.{field}.*FE devices support"):
        device_mesh(Device((base, tip)))


def test_parallel_branches_are_refused() -> None:
    g = _bend_cell()
    base = Module("base", "bending", g, n_cells=2)
    finger = Module("finger", "bending", g, branch="f", attach_to="base")
    with pytest.raises(SpecError, match=r"module 'finger'\.attach_to.*FE devices support"):
        simulate_device(Device((base, finger)))


def test_cli_refuses_an_unsupported_device_and_writes_nothing(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from multimorph.cli._app import _register, app

    _register()
    spec = Path(__file__).resolve().parents[1] / "examples" / "double_curvature.toml"
    text = spec.read_text().replace('orientation = "180 deg"', 'orientation = "90 deg"', 1)
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["fem", str(bad), "--out", str(out), "--json"])
    assert res.exit_code == 2
    assert "orientation" in res.output and "FE devices support" in res.output
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


def test_cli_fem_device_writes_its_files(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                        ) -> None:
    """``multimorph fem examples/fe_device.toml --json`` on the tiny test mesh: exit 0, the
    per-module summary, and every file it lists (CSV, PNG curves and snapshots, the VTU
    series). In curves.csv's last rows the stalk bends towards its stiff layer and the
    symmetric seal stretches, bending far less (only through its partition with the stalk)."""
    import csv
    import json

    from typer.testing import CliRunner

    from multimorph.cli._app import _register, app
    from multimorph.fe import MESH_PRESETS

    _register()
    monkeypatch.setitem(MESH_PRESETS, "coarse", DENS)
    spec = Path(__file__).resolve().parents[1] / "examples" / "fe_device.toml"
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["fem", str(spec), "--mesh", "coarse", "--pmax", "10 kPa",
                                   "--method", "pressure", "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    info = json.loads(res.output)
    for f in ("summary.json", "curves.csv", "tip.csv", "curves.png", "snapshots.png",
              "device.step", "device.stl", "device.pvd", "device_0000.vtu"):
        assert f in info["files"] and (out / f).exists(), f
    for f in ("curves.png", "snapshots.png"):
        assert (out / f).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the solid (STEP and STL, mm): the boxes of the two modules minus their four chambers,
    # one volume; read back with gmsh, its volume is exact
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        vols = gmsh.model.occ.importShapes(str(out / "device.step"))
        gmsh.model.occ.synchronize()
        assert len(vols) == 1
        vol = gmsh.model.occ.getMass(*vols[0])
    finally:
        gmsh.finalize()
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
