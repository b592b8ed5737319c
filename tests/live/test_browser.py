"""The live page in a real browser: headless Chromium (Debian's chromium and
chromium-driver packages, `.ci/run` installs them) driven by Selenium. Load the page, drag
a stroke on the lake, wait for the update: pixels changed near the stroke and nowhere far
from it, and the scene's files hold the stroke. Skipped where the browser is missing."""
from __future__ import annotations

import shutil
import time

import numpy as np
import pytest

pytest.importorskip("uvicorn", reason="the live extra (pip install 'proxyshade[live]') is not installed")
pytest.importorskip("selenium", reason="selenium (the test extra) is not installed")

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")
if not (CHROMIUM and DRIVER):
    pytest.skip("headless Chromium is not installed (apt-get install chromium chromium-driver; .ci/run does)",
                allow_module_level=True)

from selenium import webdriver  # noqa: E402
from selenium.webdriver.common.action_chains import ActionChains  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402

from proxyshade.scene.build import build_stage  # noqa: E402
from proxyshade.scene.edit import load_spec  # noqa: E402

from ._live import STROKE_AT, edit_process  # noqa: E402

CANVAS = """const c = document.getElementById('image');
return [c.width, c.height, Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data)];"""


def browser(width=1000, height=800):
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
              f"--window-size={width},{height}"):
        opts.add_argument(a)
    return webdriver.Chrome(options=opts, service=webdriver.ChromeService(executable_path=DRIVER))


def canvas(driver) -> np.ndarray:
    w, h, data = driver.execute_script(CANVAS)
    return np.array(data, np.uint8).reshape(h, w, 4)


def test_drag_a_stroke_on_the_page(tmp_path):
    out = tmp_path / "out"
    with edit_process(out, tmp_path / "cache") as (proc, url):
        spec = out / "scene/lake.yaml"
        n0 = len(next(t for t in load_spec(spec)["terrains"] if t["name"] == "Ground")["strokes"])
        driver = browser()
        try:
            driver.get(url)
            wait = WebDriverWait(driver, 120, poll_frequency=0.1)
            wait.until(lambda d: d.execute_script("return window.live && window.live.pixels >= 1"))
            before = canvas(driver)
            assert before.shape == (256, 256, 4) and before[..., :3].std() > 5  # a picture, not a blank
            overlay = driver.find_element(By.ID, "overlay")
            r = overlay.rect  # the canvas shown at its own size (256 px): page offsets are image pixels
            sx, sy = r["width"] / 256, r["height"] / 256
            dx, dy = (STROKE_AT[0] - 128) * sx, (STROKE_AT[1] - 128) * sy
            ActionChains(driver).move_to_element_with_offset(overlay, int(dx), int(dy)).click_and_hold() \
                .move_by_offset(int(6 * sx), 0).move_by_offset(int(6 * sx), 0).release().perform()
            wait.until(lambda d: d.execute_script("return window.live.edits >= 1 || window.live.errors.length > 0"))
            assert driver.execute_script("return window.live.errors") == []
            time.sleep(0.3)  # the flash outline is on the overlay, not the image: nothing to wait for but paint
            after = canvas(driver)
            status = driver.find_element(By.ID, "status").text
            # a click shows the label AOV: the source's label colours, a few flat colours
            n = driver.execute_script("return window.live.pixels")
            driver.find_element(By.CSS_SELECTOR, "#views button[data-view=label]").click()
            wait.until(lambda d: d.execute_script("return window.live.pixels") > n)
            labels = canvas(driver)
        finally:
            driver.quit()
    changed = (before != after).any(-1)
    ys, xs = np.nonzero(changed)
    d = np.hypot(xs - STROKE_AT[0] - 6, ys - STROKE_AT[1])
    assert changed.sum() > 50 and (d < 20).sum() > 20  # near the stroke
    assert np.abs(ys - STROKE_AT[1]).max() <= 64  # and nowhere far from it (the shoreline moves across the width)
    assert "raise terrain" in status and " ms" in status
    colours = np.unique(labels[..., :3].reshape(-1, 3), axis=0)
    assert 2 <= len(colours) <= 8 and len(np.unique(after[..., :3].reshape(-1, 3), axis=0)) > 1000
    data = load_spec(spec)
    strokes = next(t for t in data["terrains"] if t["name"] == "Ground")["strokes"]
    assert len(strokes) > n0 and all(s["amount"] > 0 for s in strokes[n0:])
    stage = build_stage(data, str(spec))
    assert (out / "scene/lake.usda").read_text() == stage.GetRootLayer().ExportToString()
