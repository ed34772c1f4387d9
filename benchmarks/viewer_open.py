"""How quickly a large plan opens in voiopt show: a factory floor (20 x 20 m, racks, the dock
as start and end, T = 100, 30 sensors by default), greedy's plan and shortest-path's side by
side. Prints the page's size, the time to build it in Python (simulation included), and in
headless Chromium (Debian's chromium and chromedriver) the time from navigation to the load
event and the time to step through every slot with window.voiopt.setSlot.

    python benchmarks/viewer_open.py [--sensors 30] [--horizon 100] [--repeat 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import voiopt
from voiopt.networks import fields
from voiopt.viewer import page
from voiopt.viewer.story import Entry, story


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sensors", type=int, default=30)
    ap.add_argument("--horizon", type=int, default=100)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    inst = fields.factory(args.sensors, args.horizon, seed=1)
    entries = [Entry(m, voiopt.solve(inst, method=m).plan, "mean-min-voi", method=m) for m in ("greedy", "shortest-path")]
    builds = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        html = page.render(story(inst, entries))
        builds.append(time.perf_counter() - t0)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "factory.html"
        path.write_text(html, encoding="utf-8")
        options = webdriver.ChromeOptions()
        options.binary_location = "/usr/bin/chromium"
        for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1400,1000"):
            options.add_argument(a)
        driver = webdriver.Chrome(service=Service(executable_path="/usr/bin/chromedriver"), options=options)
        loads, steps = [], []
        try:
            for _ in range(args.repeat):
                driver.get(path.as_uri())
                loads.append(driver.execute_script(
                    "const n = performance.getEntriesByType('navigation')[0]; return n.loadEventEnd - n.startTime") / 1e3)
                steps.append(driver.execute_script(
                    "const t0 = performance.now(); for (let t = 0; t < window.voiopt.T; t++) window.voiopt.setSlot(t);"
                    " return performance.now() - t0") / 1e3)
        finally:
            driver.quit()
    print(f"factory floor, N = {inst.n_sensors}, T = {inst.horizon}, 2 plans side by side")
    print(f"page: {len(html.encode()) / 1e3:.0f} kB")
    print(f"build in Python (simulate, JSON, HTML): median {statistics.median(builds):.3f} s")
    print(f"Chromium: navigation to load event: median {statistics.median(loads):.3f} s")
    print(f"Chromium: setSlot through all {inst.horizon} slots: median {statistics.median(steps):.3f} s "
          f"({1e3 * statistics.median(steps) / inst.horizon:.1f} ms a slot)")


if __name__ == "__main__":
    import report

    sys.exit(report.run("viewer_open", main))
