"""How long the HTML report takes to load in headless Chromium, and how large it is.

    python benchmarks/bench_html_load.py SITE [PAGE ...] [--repeat N]

SITE is a written site (its ``index.html``, e.g. ``reports/html``); each PAGE (default: every page of
the site's navigation bar) is opened from ``file://`` N times (default 5) in one fresh headless
Chromium (Debian's ``chromium`` and ``chromium-driver``), after one warm-up load, and timed from the
navigation's start until the page's load event and until BokehJS rendered every root of the page,
and by the main thread's task time of the load (Chrome's own count, less inflated by other processes).
Prints the median and the largest time per page, the site's size, and the machine (CPU model and load).
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from machine import describe  # noqa: E402

FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
         "--disable-sync", "--no-first-run", "--window-size=1300,1000")
RENDERED = ("const roots = [...document.querySelectorAll('[data-root-id]')];"
            "return document.readyState === 'complete' && (roots.length === 0 || (typeof Bokeh !== 'undefined' &&"
            " roots.every(e => e.children.length > 0)));")


def browser(profile: str):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = shutil.which("chromium")
    for flag in FLAGS + (f"--user-data-dir={profile}",):
        options.add_argument(flag)
    return webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=options)


def task_seconds(driver) -> float:
    """CPU seconds the page's main thread has spent on tasks so far (Chrome's Performance.getMetrics)."""
    metrics = driver.execute_cdp_cmd("Performance.getMetrics", {})["metrics"]
    return next(m["value"] for m in metrics if m["name"] == "TaskDuration")


def time_page(driver, url: str) -> tuple[float, float, float]:
    """Seconds from the navigation's start to the load event and to BokehJS having rendered the page, and the
    main thread's task time of that load (on a loaded machine, the part the page itself needs)."""
    driver.get("about:blank")
    driver.execute_cdp_cmd("Performance.enable", {})
    before = task_seconds(driver)
    driver.get(url)
    while not driver.execute_script(RENDERED):
        time.sleep(0.005)
    rendered = driver.execute_script("return performance.now()") / 1000.0  # since the navigation's start
    load = driver.execute_script("const t = performance.getEntriesByType('navigation')[0];"
                                 "return t.loadEventEnd / 1000.0;")
    return load, rendered, task_seconds(driver) - before


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("site", type=Path)
    parser.add_argument("pages", nargs="*", default=["index.html", "cases.html", "verdicts.html", "figures.html"])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    size = sum(p.stat().st_size for p in args.site.rglob("*") if p.is_file())
    n_pages = sum(1 for _ in args.site.rglob("*.html"))
    print(f"site {args.site}: {n_pages} pages, {size / 1e6:.1f} MB")
    print(describe())
    with tempfile.TemporaryDirectory() as profile:
        driver = browser(profile)
        try:
            for page in args.pages:
                path = args.site / page
                if not path.is_file():
                    print(f"{page}: not in the site")
                    continue
                url = path.resolve().as_uri()
                time_page(driver, url)  # warm-up: the browser's first start of BokehJS
                runs = [time_page(driver, url) for _ in range(args.repeat)]
                loads, rendered, tasks = ([r[i] for r in runs] for i in range(3))
                print(f"{page} ({path.stat().st_size / 1e3:.0f} kB): load event median {statistics.median(loads):.2f} s, "
                      f"rendered median {statistics.median(rendered):.2f} s (max {max(rendered):.2f} s, "
                      f"{args.repeat} loads); main-thread task time median {statistics.median(tasks):.2f} s")
        finally:
            driver.quit()
    print(describe())
    return 0


if __name__ == "__main__":
    sys.exit(main())
