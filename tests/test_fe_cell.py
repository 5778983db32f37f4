"""FE unit cell: ballooning into hardening with continuation, mesh convergence of Pc, CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("felupe")
pytest.importorskip("contique")

from multimorph.errors import SpecError
from multimorph.fe import FESettings, MeshDensity, simulate_cell
from multimorph.geometry import CellGeometry
from multimorph.materials import Material

pytestmark = pytest.mark.slow

MU = 1.0e5


#: the small Gent cell of ``_cell`` as a spec for the CLI
_CELL_SPEC = (
    '[cell]\nlength = "10 mm"\nwidth = "8 mm"\nheight = "6 mm"\ntop_wall = "1 mm"\n'
    'bottom_wall = "1.5 mm"\nside_wall = "1.5 mm"\nend_wall = "1.5 mm"\n'
    '[cell.material]\nmodel = "gent"\nmu = "100 kPa"\njm = 30\n'
    '[cell.bottom_material]\nmodel = "gent"\nmu = "1 MPa"\njm = 30\n')


def _cell(model: str, **params: float) -> CellGeometry:
    """A small cell (10 × 8 × 6 mm, 1 mm top wall) with a 10× stiffer bottom layer."""
    wall = Material(model, {"mu": MU, **params})
    bottom = Material(model, {"mu": 10 * MU, **params})
    return CellGeometry(10e-3, 8e-3, 6e-3, 1e-3, 1.5e-3, 1.5e-3, 1.5e-3, material=wall,
                        bottom_material=bottom)


def test_ballooning_into_hardening_with_continuation() -> None:
    """Gent walls: pressure steps stall in the ballooning, contique carries the path on
    into the strain-hardening plateau up to p_max; the whole path is in the result."""
    g = CellGeometry(20e-3, 10e-3, 8e-3, 1e-3, 2e-3, 2e-3, 2e-3,
                     material=Material("gent", {"mu": MU, "jm": 30.0}),
                     bottom_material=Material("gent", {"mu": 10 * MU, "jm": 30.0}))
    r = simulate_cell(g, FESettings(mesh="coarse", p_max=0.5 * MU))
    path = r.response.path
    assert r.response.backend == "fe"
    assert r.stats["stop_reason"] == "reached p_max"
    assert path.pressure[-1] >= 0.5 * MU
    assert path.extra["arc_length"].any()  # continuation took over after the stall
    c = r.response.characteristic
    assert c.critical is not None and c.hardening is not None
    assert 0.2 * MU < c.critical < c.hardening < 0.5 * MU
    # ballooning: the chamber grows several-fold between Pc and the end
    v = path.extra["volume_ratio"]
    assert v[-1] > 3 * np.interp(c.critical, path.pressure, v)
    # hardening plateau: dκ/dP at the end is a small fraction of its peak
    k, p = path.curvature, path.pressure
    slope = np.gradient(k, p)
    assert slope[-1] < 0.25 * slope.max()
    # bending with the stiff bottom on the inside; twist-free by symmetry
    assert k[-1] * g.length > 0.5
    assert np.allclose(path.twist_rate, 0.0, atol=1e-9)
    # the FE arrays for the outputs have one row per path point
    assert r.displacements.shape[0] == len(path) == r.stretch.shape[0]


def test_mesh_convergence_of_limit_pressure() -> None:
    """Neo-Hookean walls give a true limit point; its pressure converges monotonically
    under refinement (1, 2, 3 elements through the walls; in-plane size d/5, d/8, d/12):
    the successive differences shrink (a Cauchy sequence) and the sequence is monotone."""
    g = _cell("neo-hooke")
    pcs = []
    for dens in (MeshDensity(1, length_fraction=1 / 5), MeshDensity(2, length_fraction=1 / 8),
                 MeshDensity(3, length_fraction=1 / 12)):
        r = simulate_cell(g, FESettings(mesh=dens, p_max=MU, stop_after_limit=True))
        c = r.response.characteristic
        assert c.critical_kind == "limit_point"
        assert (~r.response.path.stable).any() or r.response.path.pressure[-1] < c.critical
        pcs.append(c.critical)
    d1, d2 = pcs[0] - pcs[1], pcs[1] - pcs[2]
    assert d1 > 0 and d2 > 0  # monotone: coarse meshes are too stiff
    assert d2 < d1  # Cauchy: successive differences shrink
    assert abs(d2) / pcs[2] < 0.05


def test_cli_fem_writes_outputs(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from multimorph.cli._app import _register, app

    _register()
    spec = tmp_path / "cell.toml"
    spec.write_text(_CELL_SPEC)
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["fem", str(spec), "--element-size", "2 mm", "--pmax",
                                   "15 kPa", "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    info = json.loads(res.output)
    assert info["final"]["pressure_pa"] == pytest.approx(15e3)
    for name in ("summary.json", "path.csv", "curves.png", "cell.pvd", "cell_0000.vtu",
                 "cell.step", "cell.stl"):
        assert (out / name).is_file(), name
    assert not list(tmp_path.glob(".out.tmp-*"))  # the temporary folder is gone
    bad = CliRunner().invoke(app, ["fem", str(spec), "--mesh", "huge", "--out",
                                   str(tmp_path / "bad")])
    assert bad.exit_code == 2 and not (tmp_path / "bad").exists()


def test_cli_fem_compare_writes_the_comparison_figure(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    """``--compare``: comparison.json and comparison.png, against the calibrated model by
    default (``--model`` picks another); a stand-in cell model keeps the test to the FE run,
    the files and the model's name."""
    from typer.testing import CliRunner

    import multimorph.models
    from multimorph.cli._app import _register, app
    from multimorph.response import EquilibriumPath, build_response

    asked: list[str] = []

    def cell_model(name=None):  # κ rising steepest at 10 kPa, labelled as the model asked
        asked.append(name)

        def model(cell, p_max):
            P = np.linspace(0.0, p_max, 61)
            z = np.zeros_like(P)
            path = EquilibriumPath(P, 20.0 * (1 + np.tanh((P - 10e3) / 2e3)), z, z + 1,
                                   1 + P, z + 1, np.ones_like(P, bool))
            return build_response(path, length=cell.length, shear_modulus=cell.mu,
                                  backend="calibrated", meta={"model": name})
        return model

    monkeypatch.setattr(multimorph.models, "cell_model", cell_model)
    _register()
    spec = tmp_path / "cell.toml"
    spec.write_text(_CELL_SPEC)
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["fem", str(spec), "--element-size", "2 mm", "--pmax",
                                   "15 kPa", "--out", str(out), "--compare", "--no-vtu",
                                   "--json"])
    assert res.exit_code == 0, res.output
    assert asked == ["calibrated"]
    info = json.loads(res.output)
    assert {"comparison.json", "comparison.png"} <= set(info["files"])
    assert (out / "comparison.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert info["comparison"]["meta"]["model"] == "calibrated"
    assert info["comparison"]["critical_pressure"]["rom"] == pytest.approx(10e3, rel=0.05)
    # a model name that is not one of the fast models is refused before any FE work
    res = CliRunner().invoke(app, ["fem", str(spec), "--compare", "--model", "fe",
                                   "--out", str(tmp_path / "x"), "--json"])
    assert res.exit_code != 0 and "--model" in res.output
    assert not (tmp_path / "x").exists()


def test_chord_steps_trace_the_same_equilibria_with_fewer_factorisations() -> None:
    """Chord steps (and the converged cycle's tangent as the next predictor's) change which
    matrices are factorised, not what counts as converged: every point of the path is an
    equilibrium when its residual is evaluated afresh, Pc agrees, and fewer
    factorisations were needed."""
    from multimorph.fe import build_cell_problem

    g = _cell("gent", jm=30.0)
    runs = {c: simulate_cell(g, FESettings(element_size=2e-3, p_max=0.45 * MU, chord=c,
                                           method="arc-length"))
            for c in (0.0, 1e-3)}
    plain, chord = runs[0.0], runs[1e-3]
    assert plain.stats["chord_steps"] == 0 < chord.stats["chord_steps"]
    assert chord.stats["factorisations"] < plain.stats["factorisations"]
    pc0 = plain.response.characteristic.critical
    pc1 = chord.response.characteristic.critical
    assert pc0 is not None and pc1 is not None
    # Pc is read off the sampled path (12 points here), and contique samples the two paths
    # differently (its step control counts the chord iterations)
    assert pc1 == pytest.approx(pc0, rel=0.03)
    problem, L, mu = build_cell_problem(chord.mesh)
    path = chord.response.path
    for P, u in zip(path.pressure[1:], chord.displacements[1:], strict=True):
        problem.values[:] = u / L
        x = problem.get_x()
        problem.sync(x)
        r, g_unit = problem.residual(x, P / mu)
        assert np.linalg.norm(r) <= 1e-6 * (P / mu) * np.linalg.norm(g_unit)


def test_repeated_contique_evaluations_are_handed_out_again_unchanged(monkeypatch) -> None:
    """contique re-evaluates the converged point and its first iterate at every step (its
    pre-identification's result is discarded); handing the kept residuals, states and
    solves out again must give the bit-identical path with fewer residual evaluations."""
    from multimorph.fe import PressureProblem
    from multimorph.fe.engine._solve import _Bordered

    calls = {"n": 0}
    residual = PressureProblem.residual

    def counted(self, x, p):
        calls["n"] += 1
        return residual(self, x, p)

    monkeypatch.setattr(PressureProblem, "residual", counted)
    g = _cell("gent", jm=30.0)
    s = FESettings(element_size=2e-3, p_max=0.45 * MU, method="arc-length")
    out = {}
    for memo in (False, True):
        monkeypatch.setattr(_Bordered, "memo", memo)
        calls["n"] = 0
        out[memo] = (simulate_cell(g, s), calls["n"])
    (plain, n_plain), (memo, n_memo) = out[False], out[True]
    np.testing.assert_array_equal(memo.response.path.pressure, plain.response.path.pressure)
    np.testing.assert_allclose(memo.displacements, plain.displacements, rtol=0, atol=1e-14)
    assert memo.stats["factorisations"] == plain.stats["factorisations"]
    # two residuals per contique step saved (the converged point and its first iterate)
    assert n_memo <= n_plain - 2 * (len(plain.response.path.pressure) - 2)


def test_progress_callbacks_print_during_continuation(capsys) -> None:
    """contique's own step table is silenced, the caller's progress output is not."""
    g = _cell("gent", jm=30.0)
    simulate_cell(g, FESettings(element_size=2.5e-3, p_max=0.2 * MU, method="arc-length"),
                  progress=lambda p, n: print(f"point {n} at {p:.0f} Pa"))
    out = capsys.readouterr().out
    lines = [ln for ln in out.splitlines() if ln.startswith("point ")]
    assert len(lines) >= 3
    assert "Step" not in out and "|" not in out  # nothing of contique's table


def test_interrupted_path_resumes_from_its_checkpoint(tmp_path: Path) -> None:
    """A run interrupted (KeyboardInterrupt from its progress callback) keeps its converged
    points; a second run with the same key replays them and goes on. Pressure steps resume
    with the step size and secant predictor they would have had, so the path is the
    uninterrupted one; a path resumed on continuation keeps the saved points exactly and
    reaches the same end with less work. Another key discards the folder."""
    from multimorph.fe import PathCheckpoint

    g = _cell("gent", jm=30.0)
    dens = MeshDensity(1, length_fraction=1 / 5)

    def interrupted(settings: FESettings, folder: Path, k: int) -> None:
        def stop(p: float, n: int) -> None:
            if n == k:
                raise KeyboardInterrupt

        with pytest.raises(KeyboardInterrupt):
            simulate_cell(g, settings, checkpoint=PathCheckpoint(folder, "key"), progress=stop)

    s = FESettings(mesh=dens, p_max=0.6 * MU, method="pressure")
    full = simulate_cell(g, s)
    interrupted(s, tmp_path / "p", 5)
    ck = PathCheckpoint(tmp_path / "p", "key")
    again = simulate_cell(g, s, checkpoint=ck)
    assert ck.resumed == 4 and again.stats["resumed_points"] == 4
    assert np.array_equal(again.response.path.pressure, full.response.path.pressure)
    assert np.allclose(again.displacements, full.displacements, rtol=0, atol=1e-12)
    assert again.stats["newton_iterations"] < full.stats["newton_iterations"]

    s = FESettings(mesh=dens, p_max=0.6 * MU, method="auto")
    full = simulate_cell(g, s)
    arc = full.response.path.extra["arc_length"]
    k = int(np.argmax(arc)) + 4  # a few points into the continuation
    interrupted(s, tmp_path / "a", k)
    ck = PathCheckpoint(tmp_path / "a", "key")
    again = simulate_cell(g, s, checkpoint=ck)
    assert ck.resumed == k - 1
    p0, p1 = full.response.path.pressure, again.response.path.pressure
    assert np.array_equal(p1[:k], p0[:k])
    assert np.array_equal(again.displacements[:k], full.displacements[:k])
    assert again.response.path.extra["arc_length"][k:].all()
    assert again.stats["stop_reason"] == full.stats["stop_reason"] == "reached p_max"
    assert again.stats["newton_iterations"] < full.stats["newton_iterations"]

    other = PathCheckpoint(tmp_path / "a", "another key")
    assert other.load(again.stats["nfree"]) == [] and "changed" in (other.discarded or "")
    assert not (tmp_path / "a").exists()


def test_cli_fem_interrupted_resumes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C during ``multimorph fem``: exit 130, no output folder, the points kept in
    ``<out>.resume``; the same command resumes from them (the summary says how many) and
    removes the folder; ``--restart`` starts afresh."""
    import contextlib

    from typer.testing import CliRunner

    import multimorph.cli._fem as cli_fem
    from multimorph.cli._app import _register, app

    _register()
    spec = tmp_path / "cell.toml"
    spec.write_text(_CELL_SPEC)
    out = tmp_path / "out"
    args = ["fem", str(spec), "--element-size", "2 mm", "--pmax", "15 kPa", "--method",
            "pressure", "--out", str(out), "--json"]
    real = cli_fem._progress

    @contextlib.contextmanager
    def ctrl_c(label: str, p_end: float, quiet: bool):  # type: ignore[no-untyped-def]
        def progress(p: float, n: int) -> None:
            if n == 4:
                raise KeyboardInterrupt

        yield progress

    monkeypatch.setattr(cli_fem, "_progress", ctrl_c)
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 130
    assert "resume" in res.output and not out.exists()
    resume = tmp_path / "out.resume"
    assert len(list(resume.glob("point_*.npz"))) == 3
    monkeypatch.setattr(cli_fem, "_progress", real)
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    info = json.loads(res.output)
    assert info["stats"]["resumed_points"] == 3
    assert info["final"]["pressure_pa"] == pytest.approx(15e3)
    assert (out / "summary.json").is_file() and not resume.exists()
    monkeypatch.setattr(cli_fem, "_progress", ctrl_c)
    CliRunner().invoke(app, args)
    monkeypatch.setattr(cli_fem, "_progress", real)
    res = CliRunner().invoke(app, [*args, "--restart"])
    assert res.exit_code == 0 and json.loads(res.output)["stats"]["resumed_points"] == 0


def test_ctrl_c_inside_a_linear_solve_stops_continuation(monkeypatch: pytest.MonkeyPatch,
                                                         ) -> None:
    """contique wraps the linear solve in a bare ``except:`` (and iterates on NaN), which
    would swallow Ctrl-C; a KeyboardInterrupt raised inside a solve during continuation
    stops the run at once instead (no further solve)."""
    from multimorph.fe import LinearSolver

    calls = {"n": 0, "after": 0}
    real = LinearSolver.solve

    def solve(self: LinearSolver, K: object, b: np.ndarray) -> np.ndarray:
        calls["n"] += 1
        if calls["n"] == 12:
            raise KeyboardInterrupt
        if calls["n"] > 12:
            calls["after"] += 1
        return real(self, K, b)  # type: ignore[arg-type]

    monkeypatch.setattr(LinearSolver, "solve", solve)
    with pytest.raises(KeyboardInterrupt):
        simulate_cell(_cell("gent", jm=30.0),
                      FESettings(mesh=MeshDensity(1, length_fraction=1 / 5), p_max=0.6 * MU,
                                 method="arc-length"))
    assert calls["n"] == 12 and calls["after"] == 0


def test_path_end_rules() -> None:
    """Where a path stops: past a limit point (with ``stop_after_limit``), at p_max on a
    rising continuation point, and when continuation comes back through P = 0 (it retraced
    the path: seen on a device whose two equal chambers passed their limit point)."""
    from multimorph.fe.engine import path_end

    rising = [0.0, 1.0, 2.0, 3.0]
    assert path_end(rising, "pressure", 10.0, True) == ""
    assert path_end([*rising, 2.9, 2.8, 2.7], "arc-length", 10.0, True) == (
        "passed the limit point")
    assert path_end([*rising, 2.9, 2.8, 2.7], "arc-length", 10.0, False) == ""
    assert path_end([*rising, 10.5], "arc-length", 10.0, False) == "reached p_max"
    assert path_end([*rising, 10.5, 10.4], "arc-length", 10.0, False) == ""
    assert "turned back through P = 0" in path_end([*rising, 1.0, -0.1], "arc-length", 10.0,
                                                   False)
    assert path_end([0.0], "start", 10.0, False) == ""


def test_retraced_paths_are_told_from_folds() -> None:
    """A path that turns round and walks back over its own states (sampled at other
    points) is retraced; a path through a fold (the pressure falls but the state goes on
    changing) and a path that only comes back to the same pressures elsewhere are not."""
    from multimorph.fe.engine import retraced

    s = np.linspace(0.0, 1.0, 12)
    curve = np.column_stack([s, np.sin(2.0 * s), s**2])   # states along a smooth curve
    P = list(3.0 * s - s**2)
    back = np.linspace(0.95, 0.55, 5)                     # back over it, between samples
    states = [*curve, *np.column_stack([back, np.sin(2.0 * back), back**2])]
    Pb = P + list(3.0 * back - back**2)
    assert retraced(Pb, states)
    assert not retraced(Pb[:13], states[:13])             # one point back is not enough
    # a fold: pressure falls, the state moves on (new third component)
    fold_s = np.linspace(1.05, 1.4, 5)
    fold = [*curve, *np.column_stack([fold_s, np.sin(2.0 * fold_s), 1.0 + 3.0 * (fold_s - 1)])]
    Pf = P + list(2.0 - (fold_s - 1.0))
    assert not retraced(Pf, fold)
    # the same pressures again, far away in state
    shifted = np.column_stack([back, np.sin(2.0 * back), back**2 + 5.0])
    away = [*curve, *shifted]
    assert not retraced(Pb, away)


def test_a_path_that_turns_round_restarts_from_its_turning_point(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Continuation that turns round and walks back is restarted from the turning point:
    the points that walked back are dropped (from the run, the recorder and the
    checkpoint); contique restarts there with the rising pressure in control, and, when
    that turns round too, one secant step ahead in the direction of the step that reached
    the turning point; the path goes on from there. The continuation here is scripted (a
    curve in a 3-component state), so only the bookkeeping is tested; docs/fe.md has the
    FE device this was built for."""
    from multimorph.fe import PathCheckpoint, PathPoint, PathRun
    from multimorph.fe.engine import _path, trace_path

    def curve(t: float) -> tuple[np.ndarray, float]:
        return np.array([t, np.sin(2.0 * t), t * t]), 3.0 * t - t * t

    class Problem:
        nfree = 3

        def __init__(self) -> None:
            self.x = np.zeros(3)

        def get_x(self) -> np.ndarray:
            return self.x.copy()

        def set_x(self, x: np.ndarray) -> None:
            self.x = np.array(x, dtype=float)

    starts: list[tuple[np.ndarray, float, np.ndarray | None]] = []

    def scripted(problem, p_start, solver, *, on_point, direction=None, **_):
        """Call 1: forward to t = 1.0, then back over the path; call 2 (from t = 1.0):
        straight back; call 3: forward from where it was started, on to t = 1.6."""
        starts.append((problem.get_x(), p_start, direction))
        run = PathRun()
        ts = {1: [*np.linspace(0.1, 1.0, 10), *np.linspace(0.92, 0.5, 6)],
              2: list(np.linspace(0.95, 0.5, 8))}.get(
                  len(starts), list(np.linspace(problem.get_x()[0] + 0.1, 1.6, 5)))
        for t in ts:
            x, p = curve(float(t))
            pt = PathPoint(p, x, 3, True, "arc-length")
            run.points.append(pt)
            if on_point(pt):
                run.status = "stopped"
                return run
        run.status = "max_steps"
        return run

    monkeypatch.setattr(_path, "continuation", scripted)

    class Recorder:
        def __init__(self) -> None:
            self.rows: list[float] = [0.0]
            self.u: list[np.ndarray] = [np.zeros(3)]
            self.cell_stretch: list[int] = [0]
            self.stop_reason = ""

        def add(self, pt: PathPoint) -> bool:
            self.rows.append(pt.pressure)
            self.u.append(pt.x)
            self.cell_stretch.append(0)
            return False

        def truncate(self, n: int) -> None:  # keep the start and the first n points
            for kept in (self.rows, self.u, self.cell_stretch):
                del kept[n + 1:]

    rec = Recorder()
    ck = PathCheckpoint(tmp_path / "ck", "k")
    run = trace_path(Problem(), None, FESettings(method="arc-length"), 10.0, rec.add,
                     checkpoint=ck, truncate=rec.truncate)
    assert run.restarts == 2 and len(starts) == 3
    x9, p9 = curve(0.9)
    x10, p10 = curve(1.0)
    # the first restart: at the turning point (t = 1.0), rising pressure in control
    np.testing.assert_allclose(starts[1][0], x10)
    assert starts[1][1] == pytest.approx(p10) and starts[1][2] is None
    # the second: one secant step past it, in the direction of the step that reached it
    x0, p0, d = starts[2]
    np.testing.assert_allclose(x0, 2 * x10 - x9)
    assert p0 == pytest.approx(2 * p10 - p9)
    np.testing.assert_allclose(d, np.append(x10 - x9, p10 - p9))
    # the recorded path: forward to t = 1.0, none of the points that walked back, then on
    t = [float(x[0]) for x in rec.u[1:]]
    assert np.all(np.diff(t) > 0) and t[9] == pytest.approx(1.0) and t[-1] == pytest.approx(1.6)
    assert len(rec.rows) == len(rec.u) == len(rec.cell_stretch) == len(run.points) + 1
    kept = ck.load(3)
    assert [p.pressure for p in kept] == [p.pressure for p in run.points]


def test_an_end_plate_moves_the_end_face_rigidly_and_bends_the_cell() -> None:
    """``end="plate"`` ties the free end face to a rigid plate (penalty constraint): the face's
    nodes keep their mutual distances (to the penalty's 10⁻³) while the cell bends, and the
    plate's two nodes sit after the mesh's own."""
    from multimorph.io import load_toml

    g = CellGeometry.from_spec(load_toml(Path(__file__).parents[1] / "examples" / "cell.toml")
                               ["cell"])
    r = simulate_cell(g, FESettings(mesh="coarse", p_max=0.3 * g.mu), end="plate")
    mesh, path = r.mesh, r.response.path
    assert mesh.plate == (len(mesh.points) - 2, len(mesh.points) - 1)
    face = mesh.points[mesh.end_face]
    moved = face + r.displacements[-1][mesh.end_face]
    d0 = np.linalg.norm(face[:, None] - face[None], axis=-1)
    d1 = np.linalg.norm(moved[:, None] - moved[None], axis=-1)
    assert np.abs(d1 - d0).max() < 1e-3 * d0.max()
    assert path.curvature[-1] * g.length > 0.3          # it bends (κd ≈ 0.58 here)
    assert r.stats["end"] == "plate"
    with pytest.raises(SpecError, match="end: expected one of free, plate, mirror"):
        simulate_cell(g, FESettings(mesh="coarse", p_max=0.3 * g.mu), end="glued")


def test_the_plane_tie_force_and_tangent_are_the_derivatives_of_its_penalty() -> None:
    """:class:`PlaneTie` (the mirror end's constraint): its force is ∂Π/∂u and its tangent
    ∂²Π/∂u² (central differences, 10⁻⁸ relative), symmetric, at a turned, moved state."""
    from types import SimpleNamespace

    from multimorph.fe.engine import PlaneTie

    rng = np.random.default_rng(3)
    pts = rng.random((12, 3))
    pts[:6, 1] = 1.0                                     # the section y = 1
    tie = PlaneTie(np.arange(6), 10, 11, 3.0, pts)
    v = 0.05 * rng.standard_normal((12, 3))
    v[11, 0] = 0.4                                       # turned by 0.4 rad

    def field(values: np.ndarray) -> list[SimpleNamespace]:
        return [SimpleNamespace(values=values.reshape(12, 3))]

    def energy(values: np.ndarray) -> float:
        g = tie._state(values.reshape(12, 3))[0]
        return 0.5 * 3.0 * float(np.sum(g ** 2))

    f = tie.assemble.vector(field=field(v))
    K = tie.assemble.matrix(field=field(v)).toarray()
    h, x = 1e-6, v.ravel()
    fd = np.array([(energy(x + h * e) - energy(x - h * e)) / (2 * h) for e in np.eye(36)])
    Kfd = np.stack([(tie.vector(field(x + h * e)) - tie.vector(field(x - h * e))) / (2 * h)
                    for e in np.eye(36)], axis=1)
    assert np.abs(f - fd).max() < 1e-8 * np.abs(f).max()
    assert np.abs(K - Kfd).max() < 1e-7 * np.abs(K).max()
    np.testing.assert_allclose(K, K.T, atol=1e-12)


def test_mirror_ends_keep_the_sections_plane_but_let_them_stretch() -> None:
    """``end="mirror"``: the clamp face stays on y = 0 and the end face on a plane, both
    stretching in their planes (a rigid plate's face keeps its shape); the released
    sections make a one-elastomer cell softer than with the plate: more volume at the same
    pressure (relaxing constraints raises the compliance), and its end face turns with the
    tie's plane."""
    m = Material("gent", {"mu": 245e3, "jm": 25.0})
    g = CellGeometry(12.24e-3, 26.46e-3, 9.49e-3, 1.94e-3, 4.13e-3, 2.87e-3, 1.26e-3,
                     material=m, bottom_material=m)
    s = FESettings(mesh="coarse", p_max=0.2 * g.mu)
    r = simulate_cell(g, s, end="mirror")
    mesh, u = r.mesh, r.displacements[-1]
    assert mesh.slide and r.stats["end"] == "mirror"
    clamp = np.flatnonzero(mesh.clamped)
    assert np.abs(u[clamp, 1]).max() == 0.0
    assert np.abs(u[clamp][:, [0, 2]]).max() > 1e-3 * g.length   # it stretches in y = 0
    face = mesh.points[mesh.end_face] + u[mesh.end_face]
    centred = face - face.mean(axis=0)
    normal = np.linalg.svd(centred)[2][-1]
    assert np.abs(centred @ normal).max() < 1e-3 * g.length      # a plane ...
    d0 = np.linalg.norm(mesh.points[mesh.end_face][:, None] - mesh.points[mesh.end_face][None],
                        axis=-1)
    d1 = np.linalg.norm(face[:, None] - face[None], axis=-1)
    assert np.abs(d1 - d0).max() > 1e-2 * d0.max()                # ... that stretches
    plate = simulate_cell(g, s, end="plate")
    p_m, v_m = r.response.path.pressure, r.response.path.volume
    p_p, v_p = plate.response.path.pressure, plate.response.path.volume
    p = np.linspace(0.02, 1.0, 12) * min(p_m[-1], p_p[-1])
    assert np.all(np.interp(p, p_m, v_m) > np.interp(p, p_p, v_p))
    # a cell with a stiff bottom layer bends: its end face turns with the tie's plane (the
    # face's best-fit bend is the rotation node's θ), a little more than with the plate
    # (measured −2 % at 0.06 μ, +5 % at 0.3 μ on this coarse mesh; its Pc moves 0.1 %)
    from multimorph.io import load_toml

    ref = CellGeometry.from_spec(load_toml(Path(__file__).parents[1] / "examples" / "cell.toml")
                                 ["cell"])
    s = FESettings(mesh="coarse", p_max=0.3 * ref.mu)
    m_run, p_run = (simulate_cell(ref, s, end=e) for e in ("mirror", "plate"))
    # (displacements come back in m: the rotation node's value is θ·d)
    theta = m_run.displacements[-1][m_run.mesh.plate[1], 0] / ref.length
    bend = m_run.response.path.extra["bend_angle"]
    assert abs(bend[-1]) > 0.2 and abs(abs(bend[-1]) - abs(theta)) < 1e-2 * abs(theta)
    p = np.linspace(0.2, 1.0, 5) * min(m_run.response.path.pressure[-1],
                                       p_run.response.path.pressure[-1])
    b_m = np.interp(p, m_run.response.path.pressure, bend)
    b_p = np.interp(p, p_run.response.path.pressure, p_run.response.path.extra["bend_angle"])
    assert np.all(np.abs(b_m - b_p) <= 0.15 * b_p) and b_m[-1] > b_p[-1]
