"""Screenshot of one field map of a vinecli report (or of a ``gis export`` map page) in headless Chromium.

    .venv/bin/python scripts/screenshot_map.py REPORT.html OUT.png [--map CASE] [--width 1400] [--hover]

Uses the Debian ``chromium`` package through Playwright, offline (every request that is not the file is refused),
and shoots the map of run CASE (default: the first) with its layer panel; ``--hover`` first moves the cursor over
the map's centre so the readout under it shows the values there. Made docs/field-map.png.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("html", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--map", default=None, help="the run's case (default: the first map)")
    ap.add_argument("--width", type=int, default=1400)
    ap.add_argument("--hover", action="store_true", help="hover the map's centre first")
    a = ap.parse_args()
    if not a.html.is_file():
        print(f"screenshot_map: {a.html}: no such file", file=sys.stderr)
        return 2
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
        page = browser.new_page(viewport={"width": a.width, "height": 1000})
        page.route("**/*", lambda r: r.continue_() if r.request.url.startswith(("file:", "data:", "blob:"))
                   else r.abort())
        page.goto(a.html.resolve().as_uri())
        page.wait_for_function("[...document.querySelectorAll('div.fm')].every(d => d.dataset.ready === '1')")
        box = page.locator(f"#map-{a.map}" if a.map else "div.fm").first
        box.scroll_into_view_if_needed()
        if a.hover:
            m = box.locator(".fm-map").bounding_box()
            page.mouse.move(m["x"] + m["width"] / 2, m["y"] + m["height"] / 2)
        a.out.parent.mkdir(parents=True, exist_ok=True)
        box.screenshot(path=str(a.out))
        browser.close()
    print(a.out.resolve())
    return 0


if __name__ == "__main__":
    sys.exit(main())
