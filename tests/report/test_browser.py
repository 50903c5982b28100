"""The report in a real browser: headless Chromium (the Debian ``chromium`` package, which ``make test`` installs)
driven by Playwright (pytest-playwright), offline. The page makes no request beyond itself, logs no error, every
figure and map loads, the map's layers toggle, hovering a deposition cell reads its rate, a failed check's row is
highlighted on the map, and the page works at 1400 px and 390 px wide.

Skipped with the reason when Playwright or Chromium is missing (a fresh clone before ``make test`` set it up).
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("playwright", reason="pytest-playwright is not installed (make test installs it)")

from .synth_runs import ORIGIN, terrain_height, write_ci_batch  # noqa: E402

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
STRICT_DOSE = "name: strict\nphases: [{{type: hold, duration_s: 1}}]\nchecks:\n  - {{name: dose_row_rates, " \
              "quantity: 'metric:row_rate_error_max', op: '<=', bound: {bound}}}\n"


@pytest.fixture(scope="session")
def browser_type_launch_args(browser_type_launch_args: dict[str, Any]) -> dict[str, Any]:
    """The system Chromium, never a browser Playwright downloads."""
    if not CHROMIUM.is_file():
        pytest.skip(f"{CHROMIUM} missing: apt-get install chromium (make test installs it)")
    return {**browser_type_launch_args, "executable_path": str(CHROMIUM), "args": CHROMIUM_ARGS, "headless": True}


def _row_errors(run_dir: Path) -> dict[int, float]:
    doc = json.loads((run_dir / "deposition.json").read_text())
    nominal = doc["metrics"]["nominal_rate_lpha"]
    return {r["row"]: abs(r["mean_rate_lpha"] / nominal - 1.0) for r in doc["rows"]}


def _bound(run_dir: Path) -> float:
    """Between the best row's dose error and the next one."""
    best, nxt = sorted(set(_row_errors(run_dir).values()))[:2]
    return round((best + nxt) / 2, 6)


def _fail_a_dose_check(run_dir: Path, tmp: Path) -> str:
    """Re-evaluate the run's checks with a row-dose check that all but the best rows fail (real metrics, real check
    code) and record them in its summary.json as a run of that mission would; returns the failed check's name."""
    from vinecli.runs import recheck_run
    from vinecli.runs.rundir import SUMMARY, write_summary

    mission = tmp / "strict.yaml"
    mission.write_text(STRICT_DOSE.format(bound=_bound(run_dir)), encoding="utf-8")
    summary, results = recheck_run(run_dir, mission)
    failed = [r.to_dict() for r in results if not r.passed]
    assert [c["name"] for c in failed] == ["dose_row_rates"]
    summary["checks"] = [*summary["checks"], *failed]
    summary["passed"] = False
    write_summary(run_dir / SUMMARY, summary)
    return "dose_row_rates"


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The report of the synthetic chapter-5 batch with two failed checks: the gust's hold (a time window) and a
    row dose check on the spray run (its worst row)."""
    from vinecli.report import build_report

    tmp = tmp_path_factory.mktemp("browser")
    runs = write_ci_batch(tmp / "runs", fail={"gust": {"holds_position": {"bound": 0.1}}})
    check = _fail_a_dose_check(runs / "spray", tmp)
    res = build_report(runs, tmp / "report", workers=2)
    return {"html": res.html, "runs": runs, "dose_check": check, "summary": json.loads(res.files["json"].read_text())}


@pytest.fixture()
def open_page(browser: Any) -> Iterator[Any]:
    """Open a file in a fresh context of ``width`` px, offline: every request that is not the file itself (or a
    data/blob URL) is refused and recorded; console errors and page errors are recorded."""
    contexts = []

    def opener(path: Path, width: int) -> Any:
        ctx = browser.new_context(viewport={"width": width, "height": 900})
        contexts.append(ctx)
        blocked: list[str] = []
        errors: list[str] = []

        def route(r: Any) -> None:
            if r.request.url.startswith(("file:", "data:", "blob:")):
                r.continue_()
            else:
                blocked.append(r.request.url)
                r.abort()

        ctx.route("**/*", route)
        page = ctx.new_page()
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(path.as_uri())
        page.wait_for_function("[...document.querySelectorAll('div.fm, div.tsc')].every(d => d.dataset.ready === '1')")
        page.blocked, page.errors = blocked, errors
        return page

    yield opener
    for c in contexts:
        c.close()


@pytest.mark.parametrize("width", [1400, 390])
def test_the_page_loads_offline_with_every_figure_and_map(report: dict[str, Any], open_page: Any, width: int) -> None:
    page = open_page(report["html"], width)
    figures = page.eval_on_selector_all("figure img", "imgs => imgs.map(i => [i.complete, i.naturalWidth])")
    charts = page.eval_on_selector_all("figure div.tsc", """cs => cs.map(c => [
        JSON.parse(c.querySelector('script.tsc-data').textContent).panels.length, c.querySelectorAll('.uplot').length,
        [...c.querySelectorAll('canvas')].every(k => k.width > 0 && k.getBoundingClientRect().right <= innerWidth)])""")
    n_fig = sum(f == "rendered" for r in report["summary"]["runs"] for f in r["figures"].values())
    assert len(figures) + len(charts) == n_fig > 0 and all(ok and w > 0 for ok, w in figures)
    assert charts and all(panels == plots and fits for panels, plots, fits in charts)
    maps = page.eval_on_selector_all("div.fm", """ds => ds.map(d => [d.id, d.querySelectorAll('.leaflet-pane').length,
        [...d.querySelectorAll('img.fm-raster')].every(i => i.complete && i.naturalWidth > 0),
        d.querySelectorAll('svg path').length, d.querySelector('.fm-map').getBoundingClientRect().width])""")
    assert sorted(m[0] for m in maps) == sorted(f"map-{r['case']}" for r in report["summary"]["runs"])
    assert all(panes > 3 and rasters and paths > 0 and 0 < w <= width for _id, panes, rasters, paths, w in maps)
    assert page.blocked == [] and page.errors == []
    # nothing wider than the screen but what scrolls in its own box (the runs table)
    assert page.evaluate("document.documentElement.scrollWidth") <= width + 1
    panel = page.locator("#map-spray .fm-layers").bounding_box()
    box = page.locator("#map-spray .fm-map").bounding_box()
    if width < 700:  # the layer panel goes under the map on a phone
        assert panel["y"] >= box["y"] + box["height"] and box["width"] >= width - 40
    else:
        assert panel["x"] >= box["x"] + box["width"] and abs(panel["y"] - box["y"]) < 5


def _duration(report: dict[str, Any], case: str) -> float:
    return float(next(r["sim_time_s"] for r in report["summary"]["runs"] if r["case"] == case))


def test_a_time_series_figure_zooms_its_plots_together_and_reads_values(report: dict[str, Any], open_page: Any) -> None:
    """Fig. 18 of the gust: dragging across its first plot zooms all three (x, y, z) to that stretch; the legend reads
    the values under the cursor; a double-click zooms out again."""
    page = open_page(report["html"], 1400)
    fig = page.locator("#gust-fig18")
    fig.scroll_into_view_if_needed()
    over = fig.locator(".u-over")
    assert over.count() == 3
    box = over.first.bounding_box()
    page.mouse.move(box["x"] + 0.5 * box["width"], box["y"] + 0.5 * box["height"])
    legend = fig.locator(".u-legend").nth(1).text_content()  # the second plot's legend follows the cursor too
    got = re.search(r"time, s\s*([0-9.]+)\s*drag y, N\s*(-?[0-9.]+)", legend)
    assert got and 0.3 < float(got.group(1)) / _duration(report, "gust") < 0.7, legend
    # drag from 25 % to 50 % of the width on the first plot
    page.mouse.move(box["x"] + 0.25 * box["width"], box["y"] + 0.5 * box["height"])
    page.mouse.down()
    page.mouse.move(box["x"] + 0.5 * box["width"], box["y"] + 0.5 * box["height"], steps=5)
    page.mouse.up()
    scales = "() => document.querySelector('#gust-fig18 div.tsc').charts.map(u => [u.scales.x.min, u.scales.x.max])"
    ranges = page.evaluate(scales)
    duration = _duration(report, "gust")
    assert len(ranges) == 3 and ranges[0] == ranges[1] == ranges[2]  # the same stretch on every plot
    assert 0.15 * duration < ranges[0][1] - ranges[0][0] < 0.35 * duration
    page.mouse.dblclick(box["x"] + 0.5 * box["width"], box["y"] + 0.5 * box["height"])
    full = page.evaluate(scales)
    assert all(hi - lo > 0.95 * duration for lo, hi in full)


def test_layers_toggle(report: dict[str, Any], open_page: Any) -> None:
    page = open_page(report["html"], 1400)
    raster = "#map-spray img.fm-raster-deposition"
    rows = "#map-spray .leaflet-overlay-pane svg path"
    assert page.locator(raster).count() == 1
    n = page.locator(rows).count()
    page.locator('#map-spray .fm-layer[data-layer="deposition"] input').uncheck()
    assert page.locator(raster).count() == 0
    page.locator('#map-spray .fm-layer[data-layer="rows"] input').uncheck()
    data = json.loads(page.locator("#map-spray script.fm-data").text_content())
    n_rows = len(next(lay for lay in data["layers"] if lay["key"] == "rows")["features"]["features"])
    assert n_rows > 0 and page.locator(rows).count() == n - n_rows
    page.locator('#map-spray .fm-layer[data-layer="deposition"] input').check()
    page.locator('#map-spray .fm-layer[data-layer="rows"] input').check()
    assert page.locator(raster).count() == 1 and page.locator(rows).count() == n


def test_hovering_a_deposition_cell_reads_its_rate(report: dict[str, Any], open_page: Any) -> None:
    import rasterio

    from vinecli.report.fieldmap.context import load_context

    run = report["runs"] / "spray"
    doc = json.loads((run / "deposition.json").read_text())
    with rasterio.open(run / doc["geotiff"]["file"]) as ds:
        rate = np.flipud(ds.read(1).astype(float))  # row 0 south
    g = doc["grid"]
    # a wet cell on the crest of a swath (rows run north: its 7 neighbours along within 2 %; across, a swath 0.6 m
    # wide at half height changes 3 % a cell): its rate is what the cursor must read, not a neighbour's
    from scipy.ndimage import maximum_filter, minimum_filter

    hi, lo = maximum_filter(rate, (7, 1)), minimum_filter(rate, (7, 1))
    crest = rate >= maximum_filter(rate, (1, 3))
    ok = (rate > 0.5 * np.nanmax(rate)) & (hi - lo < 0.02 * rate) & crest
    i, j = np.argwhere(ok)[len(np.argwhere(ok)) // 2]
    (lon, lat), = load_context(run).georef.to_lonlat([(g["x0_m"] + (j + 0.5) * g["cell_m"],
                                                        g["y0_m"] + (i + 0.5) * g["cell_m"])])
    page = open_page(report["html"], 1400)
    page.locator("#map-spray").scroll_into_view_if_needed()
    xy = page.evaluate("""([lat, lon]) => { const m = document.getElementById('map-spray').fieldmap.map;
        m.setView([lat, lon], 23, {animate: false}); const p = m.latLngToContainerPoint([lat, lon]);
        const r = m.getContainer().getBoundingClientRect(); return [r.left + p.x, r.top + p.y]; }""", [lat, lon])
    page.mouse.move(*xy)
    text = page.locator("#map-spray .fm-readout").text_content()
    got = re.search(r"deposition ([0-9.]+) L/ha \(([0-9.]+)× asked\)", text)
    assert got, text
    assert abs(float(got.group(1)) - rate[i, j]) <= max(0.06, 0.02 * rate[i, j])
    nominal = doc["metrics"]["nominal_rate_lpha"]
    assert abs(float(got.group(2)) - rate[i, j] / nominal) <= 0.011
    # the hillshade under it reads the ground's elevation there: the origin's altitude + the terrain's height
    ground = re.search(r"ground ([0-9.]+) m", text)
    assert ground, text
    x, y = g["x0_m"] + (j + 0.5) * g["cell_m"], g["y0_m"] + (i + 0.5) * g["cell_m"]
    assert float(ground.group(1)) == pytest.approx(ORIGIN["alt"] + float(terrain_height(x, y)), abs=0.05)


def test_a_failed_checks_row_is_highlighted_on_the_map(report: dict[str, Any], open_page: Any) -> None:
    errors = _row_errors(report["runs"] / "spray")
    off = {r for r, e in errors.items() if e > _bound(report["runs"] / "spray")}
    assert 0 < len(off) < len(errors)
    page = open_page(report["html"], 1400)
    link = page.locator(f'#run-spray tr.fail a.fm-focus[data-check="{report["dose_check"]}"]')
    assert link.count() == 1
    link.click()
    data = json.loads(page.locator("#map-spray script.fm-data").text_content())
    layers = {lay["key"]: lay for lay in data["layers"]}
    failed = [f for f in layers["failed"]["features"]["features"] if f["properties"]["check"] == report["dose_check"]]
    rows = {f["properties"]["row"]: f["geometry"]["coordinates"] for f in layers["rows"]["features"]["features"]}
    assert sorted(f["geometry"]["coordinates"] for f in failed) == sorted(rows[r] for r in off)  # those rows, no other
    paths = page.locator("#map-spray path.fm-failed")
    assert paths.count() >= 1
    assert page.evaluate("getComputedStyle(document.querySelector('#map-spray path.fm-failed')).stroke") == \
        "rgb(255, 23, 68)"
    box, view = paths.first.bounding_box(), page.locator("#map-spray .fm-map").bounding_box()
    assert box["width"] * box["height"] > 0  # zoomed to it: inside the map's box
    assert view["x"] <= box["x"] + box["width"] / 2 <= view["x"] + view["width"]
    # the gust's failed hold: its window's path, on the gust's map
    assert page.locator('#run-gust tr.fail a.fm-focus[data-check="holds_position"]').count() == 1


def test_gis_exports_map_opens_offline(report: dict[str, Any], open_page: Any, tmp_path: Path) -> None:
    """``gis export``'s map beside the GeoPackage is the same map, standalone (the synthetic run's world is a
    stand-in: the map itself is exercised, the GeoPackage needs a real world and is tested in tests/gis)."""
    from vinecli.report.fieldmap.map_page import standalone_page
    from vinecli.report.fieldmap.run_map import run_map

    out = tmp_path / "spray.html"
    out.write_text(standalone_page(run_map(report["runs"] / "spray"), "spray"), encoding="utf-8")
    page = open_page(out, 390)
    assert page.locator("div.fm").count() == 1 and page.locator("img.fm-raster-deposition").count() == 1
    assert page.blocked == [] and page.errors == []
    # a basemap is asked for: then, and only then, the browser fetches its tiles
    out.write_text(standalone_page(run_map(report["runs"] / "spray"), "spray", basemap="https://tiles.invalid/{z}/{x}/{y}.png"),
                   encoding="utf-8")
    page = open_page(out, 390)
    assert page.blocked and all(u.startswith("https://tiles.invalid/") for u in page.blocked)



@pytest.fixture(scope="module")
def dose_report(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The report of the synthetic spray run with an as-applied log (tests/report/synth_dose.py): two prescription
    zones, one segment 25 % over, one gap."""
    import shutil

    from vinecli.report import build_report

    from .synth_dose import write_as_applied

    tmp = tmp_path_factory.mktemp("browser-dose")
    batch = write_ci_batch(tmp / "ci")
    runs = tmp / "runs"
    runs.mkdir()
    shutil.copytree(batch / "spray", runs / "spray")
    doc = write_as_applied(runs / "spray")
    res = build_report(runs, tmp / "report", workers=1)
    return {"html": res.html, "runs": runs, "doc": doc}


def _hover(page: Any, case: str, x: float, y: float, run_dir: Path) -> None:
    """Move the cursor over world point (x, y) m of run ``case``'s map, zoomed in."""
    from vinecli.report.fieldmap.context import load_context

    (lon, lat), = load_context(run_dir).georef.to_lonlat([(x, y)])
    page.locator(f"#map-{case}").scroll_into_view_if_needed()
    xy = page.evaluate("""([id, lat, lon]) => { const m = document.getElementById(id).fieldmap.map;
        m.setView([lat, lon], 21, {animate: false}); const p = m.latLngToContainerPoint([lat, lon]);
        const r = m.getContainer().getBoundingClientRect(); return [r.left + p.x, r.top + p.y]; }""",
                       [f"map-{case}", lat, lon])
    page.mouse.move(xy[0] - 3, xy[1])
    page.mouse.move(*xy)


def test_a_dosed_runs_map_shows_target_against_applied(dose_report: dict[str, Any], open_page: Any) -> None:
    """A run that flew segment rates: the dose layers are on its map with their legends (the error per segment
    shown when the page opens), hovering a segment reads its target, what the pump applied and the error, a zone's
    outline its error, and figures 26 and 27 load."""
    from .synth_dose import HOT

    page = open_page(dose_report["html"], 1400)
    assert page.errors == [] and page.blocked == []
    panel = page.locator("#map-spray .fm-layers")
    for key in ("prescription", "as_applied", "dose_error", "dose_zones", "canopy_segments"):
        assert panel.locator(f'.fm-layer[data-layer="{key}"] .fm-legend > *').count() >= 1, key
    assert panel.locator('.fm-layer[data-layer="dose_error"] input').is_checked()
    assert not panel.locator('.fm-layer[data-layer="prescription"] input').is_checked()
    for fid in ("fig26", "fig27"):
        assert page.evaluate("id => { const i = document.querySelector('#' + id + ' img');"
                             " return !!i && i.complete && i.naturalWidth > 600; }", f"spray-{fid}"), fid
    hot = next(g for g in dose_report["doc"]["segments"] if (g["row"], round(g["s0_m"] / 2)) == HOT)
    _hover(page, "spray", *hot["mid_enu"], dose_report["runs"] / "spray")
    tip = page.locator(".leaflet-tooltip").last.text_content()
    assert f"row {HOT[0]}" in tip and "target 30.0 L/ha" in tip and "applied (pump) 37.5 L/ha (+25.0 %)" in tip, tip
    # the prescription layer switched on: a strip per segment, in its target's colour
    before = page.locator("#map-spray path").count()
    panel.locator('.fm-layer[data-layer="prescription"] input').check()
    assert page.locator("#map-spray path").count() == before + len(dose_report["doc"]["segments"])
    # a zone's outline: its error
    zone = next(g for g in dose_report["doc"]["segments"] if g["row"] == 0 and g["s0_m"] == 0.0)
    _hover(page, "spray", zone["start_enu"][0] - 1.25, zone["mid_enu"][1], dose_report["runs"] / "spray")
    tip = page.locator(".leaflet-tooltip").last.text_content()
    assert tip.startswith("zone 20 L/ha") and "applied (pump)" in tip, tip
