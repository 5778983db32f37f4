"""``report.html`` of ``multimorph simulate``, ``design`` and ``fem``: self-contained, the
device (or the FE surface) in 3D with a pressure slider, the stage, target and FE tables;
opened in headless Chromium where one is installed."""

from __future__ import annotations

import json
import re
import shutil
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest

from multimorph.device import device_from_spec, simulate_device
from multimorph.viz._report import device_figure, device_report_html
from test_device_simulate import SPEC, step_model

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
BENCH = ROOT / "benchmarks" / "runs"


@pytest.fixture(scope="module")
def result():
    return simulate_device(device_from_spec(tomllib.loads(SPEC)), 60e3, cell_model=step_model)


@pytest.fixture(scope="module")
def page(result, tmp_path_factory):
    path = tmp_path_factory.mktemp("report") / "report.html"
    device_report_html(result, path, summary=result.to_dict(), model_text="step stand-in",
                       frames=5)
    return path


def test_the_slider_morphs_the_device_frame_by_frame(result) -> None:
    fig = device_figure(result, [0.0, 30e3, 60e3])
    assert [f.name for f in fig.frames] == ["0", "30", "60"]
    assert [s["label"] for s in fig.layout.sliders[0].steps] == ["0", "30", "60"]
    assert [t.name for t in fig.data] == ["base (bending)", "tip (bending)"]
    assert fig.layout.scene.xaxis.title.text == "x (mm)"
    assert fig.layout.scene.zaxis.title.text == "z (mm)"
    first, last = (np.asarray(f.data[0].z) for f in (fig.frames[0], fig.frames[-1]))
    assert first.shape == last.shape
    # straight at 0 (z within ± h/2 = 4 mm), bent toward −z at 60 kPa
    assert np.ptp(first) == pytest.approx(8.0) and last.min() < first.min() - 1.0
    assert fig.frames[-1].layout.title.text.endswith("P = 60 kPa")


def test_the_page_is_one_file_that_needs_no_network(page) -> None:
    text = page.read_text(encoding="utf-8")
    assert not re.search(r"<script[^>]+src=", text)  # plotly.js is inlined
    assert text.count("<script") >= 3 and len(text) > 1_000_000
    assert "Cell model: step stand-in." in text
    for cell in ("<td>base</td>", "<td>bending</td>", "<td>15 kPa</td>", "<td>25 kPa</td>"):
        assert cell in text  # the stage table: base's Pc, Ph
    assert "gap (Pc later − Ph earlier = +20 kPa)" in text


# ------------------------------------------------------------------ in a browser
def _chrome():
    webdriver = pytest.importorskip("selenium.webdriver",
                                    reason="selenium is not installed (the test extra)")
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    if not (browser and driver):
        pytest.skip("no browser here: needs Debian's chromium and chromium-driver "
                    "(.ci/run installs them with apt-get)")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = browser
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                "--window-size=1200,2000"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(driver), options=options)


def _wait(chrome, script: str, timeout: float = 20.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = chrome.execute_script(script)
        if value:
            return value
        time.sleep(0.1)
    raise AssertionError(f"timed out waiting for: {script}")


STATE = """const gd = document.getElementById('device');
return JSON.stringify({active: gd._fullLayout.sliders[0].active,
  z: Array.from(gd._fullData[0].z).slice(0, 400),
  title: gd._fullLayout.title.text});"""


@pytest.mark.browser
def test_moving_the_slider_in_a_browser_changes_the_3d_view(page) -> None:
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    chrome = _chrome()
    try:
        chrome.get(page.as_uri())
        _wait(chrome, "const gd = document.getElementById('device');"
                      "return gd && gd._fullData && gd._fullData.length > 0;")
        before = json.loads(chrome.execute_script(STATE))
        assert before["active"] == 0 and before["title"].endswith("P = 0 kPa")
        rail = chrome.find_element(By.CSS_SELECTOR, "#device .slider-rail-touch-rect")
        width = rail.size["width"]
        ActionChains(chrome).move_to_element_with_offset(rail, width // 2 - 3, 0).click(
            ).perform()
        _wait(chrome, "return document.getElementById('device')"
                      "._fullLayout.sliders[0].active === 4;")
        after = json.loads(_wait(chrome, STATE.replace(
            "return JSON", "if (!gd._fullLayout.title.text.endsWith('60 kPa')) return null;"
            " return JSON")))
        assert after["title"].endswith("P = 60 kPa")
        assert after["z"] != before["z"] and min(after["z"]) < min(before["z"]) - 1.0
        severe = [entry for entry in chrome.get_log("browser") if entry["level"] == "SEVERE"]
        assert severe == []
    finally:
        chrome.quit()


def _slide_to_middle(chrome, div: str) -> None:
    """Click the middle of the slider under the figure ``div``."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    rail = chrome.find_element(By.CSS_SELECTOR, f"#{div} .slider-rail-touch-rect")
    chrome.execute_script("arguments[0].scrollIntoView({block: 'center'});", rail)
    ActionChains(chrome).move_to_element_with_offset(rail, rail.size["width"] // 2 - 3, 0
                                                     ).click().perform()


def _open(chrome, page, div: str) -> None:
    chrome.get(page.as_uri())
    _wait(chrome, f"const gd = document.getElementById('{div}');"
                  "return gd && gd._fullData && gd._fullData.length > 0;")


def _severe(chrome) -> list:
    return [entry for entry in chrome.get_log("browser") if entry["level"] == "SEVERE"]


# ------------------------------------------------------------------ design
@pytest.fixture(scope="module")
def design_out(tmp_path_factory):
    """``multimorph design`` of the gripper target on the stand-in cell model (seconds)."""
    import typer
    from typer.testing import CliRunner

    import multimorph.design as des
    from multimorph.cli import _design
    from test_design_helpers import STANDIN

    out = tmp_path_factory.mktemp("design") / "gripper"
    app = typer.Typer(pretty_exceptions_enable=False)
    _design.register(app)
    app.command("noop")(lambda: None)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(des, "rom_batch_model", lambda vectorised=False: STANDIN)
        run = CliRunner().invoke(app, [
            "design", str(EXAMPLES / "target_gripper.toml"), "--out", str(out), "--budget",
            "900", "--population", "16", "--seed", "3", "--robustness", "0", "--model",
            "ritz", "--json"])
    assert run.exit_code == 0, run.output
    return out, json.loads(run.stdout)


def test_the_design_page_sets_the_target_against_the_design(design_out) -> None:
    out, data = design_out
    assert "report.html" in data["files"]
    assert "report.html" in json.loads((out / "report.json").read_text())["files"]
    text = (out / "report.html").read_text(encoding="utf-8")
    assert not re.search(r"<script[^>]+src=", text)
    assert "<h2>Target vs achieved</h2>" in text and "<h2>The designed device</h2>" in text
    best = {stage["name"]: stage for stage in data["designs"][0]["stages"]}
    # the twister's wanted Pc and Ph, and what the design reaches (kPa, .4g as the page)
    row = (f"<td>twister</td><td>twisting</td><td>{best['twister']['cells']}</td>"
           f"<td>30 kPa</td><td>{best['twister']['start_pressure'] / 1e3:.4g} kPa</td>"
           f"<td>40 kPa</td><td>{best['twister']['end_pressure'] / 1e3:.4g} kPa</td>")
    assert row in text
    assert "<b>Not FE-verified</b>: every number on this page is the ritz model's" in text
    assert "twister Ph wanted" in text  # the wanted pressures on the sequence plot


def test_the_design_page_shows_the_fe_verification_of_a_verified_run(tmp_path) -> None:
    """A real design run with --verify-fe --fe-rounds 1 (benchmarks/runs): its model vs FE
    table, FE's Pc "—" where the device FE did not reach it."""
    from multimorph.viz._design_report import design_report_html

    report = json.loads((BENCH / "design_jar_lifter_fe" / "report.json").read_text())
    design_report_html(report, tmp_path / "report.html", model_text="calibrated")
    text = (tmp_path / "report.html").read_text(encoding="utf-8")
    # an older report without fe_route: the device route, unnamed
    assert "<b>Not FE-verified</b>: 3D FE misses a target (2 FE rounds" in text
    first = report["fe_rounds"][0]["stages"][0]
    model_pc = first["search_model"]["start_pressure"] / 1e3
    assert (f"<td>0</td><td>{first['name']}</td><td>stretching</td><td>—</td>"
            f"<td>{model_pc:.4g} kPa</td><td>—</td><td>—</td>") in text
    assert "No device simulation" in text


@pytest.mark.browser
def test_the_design_page_opens_and_its_slider_morphs_the_device(design_out) -> None:
    chrome = _chrome()
    try:
        _open(chrome, design_out[0] / "report.html", "device")
        before = json.loads(chrome.execute_script(STATE))
        _slide_to_middle(chrome, "device")
        after = json.loads(_wait(chrome, STATE.replace(
            "return JSON", "if (gd._fullLayout.title.text.endsWith(' 0 kPa')) return null;"
            " return JSON")))
        assert after["title"] != before["title"] and after["z"] != before["z"]
        assert _severe(chrome) == []
    finally:
        chrome.quit()


# ------------------------------------------------------------------ fem
def _box(nx: int, ny: int, nz: int, size=(0.01, 0.004, 0.003)):
    """Points and hexahedra (VTK order) of a box of nx × ny × nz elements."""
    grid = np.stack(np.meshgrid(*(np.linspace(0, s, n + 1) for s, n in
                                  zip(size, (nx, ny, nz), strict=True)), indexing="ij"), -1)
    points = grid.reshape(-1, 3)
    index = np.arange(len(points)).reshape(nx + 1, ny + 1, nz + 1)
    cells = [[index[i + a, j + b, k + c] for c, b, a in
              ((0, 0, 0), (0, 0, 1), (0, 1, 1), (0, 1, 0), (1, 0, 0), (1, 0, 1), (1, 1, 1),
               (1, 1, 0))] for i in range(nx) for j in range(ny) for k in range(nz)]
    return points, np.array(cells)


@pytest.fixture(scope="module")
def fem_outcome():
    """A synthetic FE cell run (a box that bends up with pressure) and a model beside it."""
    from types import SimpleNamespace

    from multimorph.fe.analyses import compare_responses
    from test_fe_comparison_figure import _response

    fe, model = _response(20.0, 25e3, "fe"), _response(20.0, 40e3, "calibrated")
    points, cells = _box(6, 2, 2)
    P = fe.path.pressure
    bend = (P / P.max())[:, None] * (points[:, 0] / 0.01) ** 2 * 0.004
    displacements = np.zeros((len(P), *points.shape))
    displacements[..., 2] = bend
    stats = {"nfree": 300, "points": len(P), "newton_iterations": 900, "solver": "superlu",
             "wall_time": 12.5, "status": "converged", "stop_reason": "reached p_max"}
    result = SimpleNamespace(response=fe, stats=stats, displacements=displacements,
                             mesh=SimpleNamespace(points=points, cells=cells, half=True))
    comparison = compare_responses(model, fe)
    comparison.meta["model"] = "calibrated"
    return SimpleNamespace(job=SimpleNamespace(kind="cell"), result=result,
                           comparison=comparison)


@pytest.fixture(scope="module")
def fem_page(fem_outcome, tmp_path_factory):
    from multimorph.fe.report import write_report_html

    path = tmp_path_factory.mktemp("fem") / "report.html"
    write_report_html(fem_outcome, path, title="FE cell", lines=[" 300 DOF, 241 points"])
    return path


def test_the_fem_page_has_the_curves_the_comparison_and_the_surface(fem_page) -> None:
    text = fem_page.read_text(encoding="utf-8")
    assert not re.search(r"<script[^>]+src=", text)
    assert len(text) < 10e6  # the page stays small: 4.6 MB of it is plotly.js
    for div in ("fe-0", "compare-0", "surface"):
        assert f'id="{div}"' in text
    # the FE curve's axis; plotly's JSON encoder (orjson or json) may escape "κ" and "/"
    plain = text.replace("\\u002f", "/").replace("\\u03ba", "κ").replace("\\/", "/")
    assert "curvature κ (1/m)" in plain
    assert "<td>free DOF</td><td>300</td>" in text
    assert "<td>cell</td><td>calibrated</td>" in text  # the Pc, Ph table names the model
    assert "(half model: the symmetry plane is open) at 10 of the path's 241" in text


def test_a_surface_too_large_for_the_page_is_left_out_and_said_so(fem_outcome,
                                                                  tmp_path) -> None:
    from multimorph.fe.report import write_report_html

    write_report_html(fem_outcome, tmp_path / "r.html", title="FE cell", lines=[""],
                      max_bytes=1_000)
    text = (tmp_path / "r.html").read_text(encoding="utf-8")
    assert 'id="surface"' not in text and "Left out: the mesh's surface" in text


@pytest.mark.browser
def test_the_fem_page_opens_and_its_slider_deforms_the_surface(fem_page) -> None:
    chrome = _chrome()
    try:
        _open(chrome, fem_page, "surface")
        state = STATE.replace("'device'", "'surface'")
        before = json.loads(chrome.execute_script(state))
        _slide_to_middle(chrome, "surface")
        after = json.loads(_wait(chrome, state.replace(
            "return JSON", "if (gd._fullLayout.title.text.endsWith(' 0 kPa')) return null;"
            " return JSON")))
        assert max(after["z"]) > max(before["z"]) + 1.0  # bent up by mm
        assert _severe(chrome) == []
    finally:
        chrome.quit()
