"""``report.html`` of ``multimorph simulate``: self-contained, the device in 3D with a
pressure slider, the stage table; opened in headless Chromium where one is installed."""

from __future__ import annotations

import json
import re
import shutil
import time
import tomllib

import numpy as np
import pytest

from multimorph.device import device_from_spec, simulate_device
from multimorph.viz._report import device_figure, device_report_html
from test_device_simulate import SPEC, step_model


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
