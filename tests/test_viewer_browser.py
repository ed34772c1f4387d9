"""voiopt show in a real browser: Debian's headless Chromium driven by selenium through
Debian's chromedriver, given by its path (nothing is downloaded at run time). The page's
``state()`` is compared at every slot with the simulator and with a reference written here
from MODEL.md sections 3, 4 and 10; a screenshot must not be blank.

Without Chromium these tests skip, and ``make test`` says at the end that they did not run
(tests/conftest.py)."""

from __future__ import annotations

import io
import math
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import voiopt
from voiopt.cli.main import main

ROOT = Path(__file__).resolve().parent.parent
CHROMIUM = os.environ.get("VOIOPT_CHROMIUM", "/usr/bin/chromium")
CHROMEDRIVER = os.environ.get("VOIOPT_CHROMEDRIVER", "/usr/bin/chromedriver")
NO_BROWSER = "browser tests did not run"


def _missing() -> str | None:
    for path in (CHROMIUM, CHROMEDRIVER):
        if not Path(path).exists() and shutil.which(Path(path).name) is None:
            return f"{NO_BROWSER}: {path} is not installed (apt-get install chromium chromium-driver)"
    try:
        import selenium  # noqa: F401
    except ImportError:
        return f"{NO_BROWSER}: selenium is not installed (pip install -e '.[test]')"
    return None


@pytest.fixture(scope="module")
def browser():
    why = _missing()
    if why:
        pytest.skip(why)
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM if Path(CHROMIUM).exists() else shutil.which("chromium")
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1400,1000"):
        options.add_argument(arg)
    service = Service(executable_path=CHROMEDRIVER if Path(CHROMEDRIVER).exists() else shutil.which("chromedriver"))
    driver = webdriver.Chrome(service=service, options=options)
    yield driver
    driver.quit()


def reference(inst: voiopt.Instance, plan) -> list[dict]:
    """Per slot t = 0..T-1: p_k(t), A_i(t), V_i(t), from MODEL.md alone (not voiopt.core.simulate)."""
    ch = inst.channel
    g0, n0, B = 10 ** (ch.g0_db / 10), 10 ** (ch.noise_dbm_per_hz / 10) / 1000, ch.bandwidth_hz
    aoi = [s.initial_aoi for s in inst.sensors]
    q = [inst.initial_distance(i) for i in range(inst.n_sensors)]
    out = []
    for t in range(inst.horizon):
        voi = []
        for i, s in enumerate(inst.sensors):
            x = s.power_w * g0 * s.rho ** aoi[i] / (B * n0 * q[i] ** 2 + s.power_w * g0)
            voi.append(-B * math.log1p(-x) / math.log(2))
        out.append({"positions": [list(r.positions[t]) for r in plan.robots], "aoi": list(aoi), "voi": voi})
        ups = {r.schedule[t]: math.dist(r.positions[t], inst.sensors[r.schedule[t]].position)
               for r in plan.robots if r.schedule[t] is not None}
        aoi = [1 if i in ups else a + 1 for i, a in enumerate(aoi)]
        q = [ups.get(i, d) for i, d in enumerate(q)]
    return out


def _show(capsys, tmp_path, inst_path, *files) -> Path:
    page = tmp_path / "page.html"
    code = main(["show", *map(str, files), "--instance", str(inst_path), "-o", str(page)])
    assert code == 0, capsys.readouterr().err
    return page


def _check_every_slot(driver, page: Path, inst: voiopt.Instance, plan) -> None:
    driver.get(page.as_uri())
    assert driver.execute_script("return window.voiopt.T") == inst.horizon
    traj = voiopt.simulate(inst, plan)
    ref = reference(inst, plan)
    slots = list(range(inst.horizon))
    states = driver.execute_script(
        "return arguments[0].map(t => { window.voiopt.setSlot(t); return window.voiopt.state(); });", slots)
    for t, state in enumerate(states):
        assert state["slot"] == t
        assert state["positions"] == ref[t]["positions"]
        assert state["aoi"] == ref[t]["aoi"] == traj.aoi[t].tolist()
        np.testing.assert_array_equal(state["voi"], traj.voi[t])  # the simulator's, to the last bit
        np.testing.assert_allclose(state["voi"], ref[t]["voi"], rtol=1e-9)
    assert driver.execute_script("return window.voiopt.state().slot") == inst.horizon - 1
    assert driver.get_log("browser") == [] if hasattr(driver, "get_log") else True


def _solve(inst_path: Path, method: str, out: Path) -> tuple[voiopt.Instance, object]:
    inst = voiopt.load(inst_path)
    result = voiopt.solve(inst, method=method)
    result.save(out)
    return inst, result.plan


def test_one_robot_every_slot(browser, capsys, tmp_path):
    inst = voiopt.load(ROOT / "instances" / "case-study.json")
    plan_file = ROOT / "instances" / "case-study.plan.json"
    page = _show(capsys, tmp_path, ROOT / "instances" / "case-study.json", plan_file)
    _check_every_slot(browser, page, inst, voiopt.load_plan(plan_file))


def test_fleet_every_slot(browser, capsys, tmp_path):
    inst, plan = _solve(ROOT / "instances" / "fleet.json", "greedy", tmp_path / "fleet.result.json")
    page = _show(capsys, tmp_path, ROOT / "instances" / "fleet.json", tmp_path / "fleet.result.json")
    _check_every_slot(browser, page, inst, plan)
    assert len(browser.execute_script("return window.voiopt.state().positions")) == inst.n_robots == 2


def test_field_instance_every_slot_and_a_picture(browser, capsys, tmp_path):
    """The factory floor (blocked racks, the dock as end, T = 100, a dp result) beside a
    shortest-path plan of it on one slider: state() is the first result's."""
    from PIL import Image

    inst_path = ROOT / "instances" / "factory.json"
    inst = voiopt.load(inst_path)
    assert inst.blocked and inst.end is not None
    _solve(inst_path, "shortest-path", tmp_path / "sp.result.json")
    page = _show(capsys, tmp_path, inst_path, ROOT / "instances" / "factory.result.json", tmp_path / "sp.result.json")
    _check_every_slot(browser, page, inst, voiopt.load_plan(ROOT / "instances" / "factory.result.json"))
    assert browser.execute_script("return window.voiopt.results") == 2
    browser.execute_script("window.voiopt.setSlot(40)")
    shot = Image.open(io.BytesIO(browser.get_screenshot_as_png())).convert("RGB")
    pixels = np.asarray(shot, dtype=float)
    assert pixels.shape[0] > 500 and pixels.shape[1] > 800
    assert pixels.std() > 20  # not blank: a one-colour page has 0
    assert len({tuple(p) for p in pixels[::7, ::7].reshape(-1, 3)}) > 50  # paths, sensors, charts, text


def test_keys_and_buttons_move_the_slot(browser, capsys, tmp_path):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    page = _show(capsys, tmp_path, ROOT / "instances" / "case-study.json", ROOT / "instances" / "case-study.plan.json")
    browser.get(page.as_uri())
    body = browser.find_element(By.TAG_NAME, "body")
    body.send_keys(Keys.ARROW_RIGHT, Keys.ARROW_RIGHT)
    assert browser.execute_script("return window.voiopt.slot()") == 2
    body.send_keys(Keys.END)
    assert browser.execute_script("return window.voiopt.slot()") == 9
    browser.find_element(By.ID, "back").click()
    assert browser.execute_script("return window.voiopt.slot()") == 8
    browser.find_element(By.ID, "first").click()
    assert browser.execute_script("return window.voiopt.slot()") == 0
    assert "Space" in browser.find_element(By.CLASS_NAME, "keys").text  # the keys are shown on the page
    error = browser.execute_script("try { window.voiopt.setSlot(10); return null } catch (e) { return e.name }")
    assert error == "RangeError"


def test_a_lossy_page_labels_its_values_gaps_and_sampled_run(browser, capsys, tmp_path):
    """Lossy links, as the page is read: an exact plan value and a Monte Carlo policy value are
    labelled as such, the Monte Carlo value's gap as an estimate (never proven), the charts as
    the sampled run's, and a slot whose upload fails in that run says so."""
    import json

    from selenium.webdriver.common.by import By

    d = voiopt.load(ROOT / "instances" / "case-study.json").to_dict() | {"horizon": 6}
    d["links"] = {"model": "bernoulli", "success": 0.6}
    inst_path = tmp_path / "case-study.json"
    inst_path.write_text(json.dumps(d))
    assert main(["solve", str(inst_path), "--method", "policy-dp", "-o", str(tmp_path / "pol.json"), "--quiet"]) == 0
    _solve(inst_path, "greedy", tmp_path / "greedy.json")
    mc = json.loads((tmp_path / "pol.json").read_text())
    v = mc["value"]
    mc.update(evaluation="monte-carlo", samples=500, value_ci=[0.95 * v, 1.05 * v], bound=1.5 * v, gap=1 / 3,
              bound_kind="lossless", status="feasible")
    (tmp_path / "mc.json").write_text(json.dumps(mc))
    page = _show(capsys, tmp_path, inst_path, tmp_path / "greedy.json", tmp_path / "mc.json")
    browser.get(page.as_uri())
    plan_card, policy_card = browser.find_elements(By.CLASS_NAME, "card")
    assert "(exact expectation)" in plan_card.text and "proven" in plan_card.text
    assert "Monte Carlo estimate" in policy_card.text and "500 samples" in policy_card.text
    assert [b.text for b in policy_card.find_elements(By.CSS_SELECTOR, ".facts .badge")] == ["estimate"]
    assert "proven" not in policy_card.find_element(By.CLASS_NAME, "facts").text
    assert "policy: adapts to outcomes" in policy_card.text
    assert all("the sampled run (seed 0)" in h.text for h in browser.find_elements(By.CSS_SELECTOR, ".side h3"))
    runs = browser.execute_script("return JSON.parse(document.getElementById('voiopt-data').textContent)"
                                  ".results.map(r => r.run.failed[0])")
    t, k = next((t, k) for k, failed in enumerate(runs) for t, f in enumerate(failed) if f)
    browser.execute_script(f"window.voiopt.setSlot({t})")
    card = [plan_card, policy_card][k]
    assert "fails in this sampled run" in card.find_element(By.CLASS_NAME, "now").text
    assert "one sampled run (seed 0" in browser.find_element(By.ID, "note").text
    assert browser.get_log("browser") == [] if hasattr(browser, "get_log") else True
