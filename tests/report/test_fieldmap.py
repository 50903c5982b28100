"""The field map's data (vinecli/report/fieldmap): rasters and vectors land where pyproj puts the world's points
(a UTM world, its grid 1.8 deg off north), hover values decode to the raster's, every layer of a spray run is
there with its legend, a new layer is one function, a failed check is located, and it stays small."""

from __future__ import annotations

import base64
import io
import json
import zlib
from pathlib import Path

import numpy as np
import pytest
from pyproj import Transformer

from vinecli.gis.georef import Georef
from vinecli.report.fieldmap.map_model import Legend, LocalFeature, MapLayer, Raster, map_data
from vinecli.report.fieldmap.overlay import overlay
from vinecli.report.fieldmap.run_map import LAYERS, run_map
from vinecli.rows.source import RowFrame

UTM = "EPSG:32616"
CENTRE = (296615.14709, 4888216.64168)  # the sample vineyard (Hancock, WI): grid convergence -1.77 deg
R = 6378137.0


def _utm_georef() -> Georef:
    return Georef(RowFrame(UTM, CENTRE))


def _to_utm(lon: float, lat: float) -> tuple[float, float]:
    return Transformer.from_crs("EPSG:4326", UTM, always_xy=True).transform(lon, lat)


def _pixel_lonlat(ov: dict, row: float, col: float, w: int, h: int) -> tuple[float, float]:
    """Lon/lat of a pixel centre of an overlay (bounds stretched over Web-Mercator, as Leaflet draws it)."""
    (s, wl), (n, e) = ov["bounds"]
    x0, x1 = R * np.radians(wl), R * np.radians(e)
    y0, y1 = (R * np.log(np.tan(np.pi / 4 + np.radians(v) / 2)) for v in (s, n))
    mx, my = x0 + (col + 0.5) * (x1 - x0) / w, y1 - (row + 0.5) * (y1 - y0) / h
    return float(np.degrees(mx / R)), float(np.degrees(2 * np.arctan(np.exp(my / R)) - np.pi / 2))


def _decode_png(uri: str) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(base64.b64decode(uri.split(",", 1)[1]))).convert("RGBA"))


def _decode_values(v: dict) -> np.ndarray:
    q = np.frombuffer(zlib.decompress(base64.b64decode(v["deflated"])), dtype="<u2").reshape(v["h"], v["w"])
    return np.where(q == 65535, np.nan, v["offset"] + q * v["step"])


def test_a_raster_cell_lands_where_pyproj_puts_it() -> None:
    """One hot cell on a 40 x 80 m local grid of a UTM world: its pixel in the overlay, and its hover value, sit
    on the cell's ground position (pyproj), within a cell and a pixel; so does a vector point."""
    cell, nx, ny = 0.5, 80, 160
    rgba = np.zeros((ny, nx, 4), np.uint8)
    values = np.full((ny, nx), np.nan)
    i, j = 130, 61  # north-east part: far from the centre, where a rotation would show
    rgba[i, j] = (255, 0, 0, 255)
    values[i, j] = 42.0
    r = Raster(rgba, -20.0, -40.0, cell, values=values, label="x", unit="u", digits=1, values_px=160)
    ov = overlay(r, _utm_georef(), max_px=400)
    px = _decode_png(ov["png"])
    hot = np.argwhere(px[..., 3] > 0)
    row, col = hot.mean(axis=0)
    want = (CENTRE[0] - 20.0 + (j + 0.5) * cell, CENTRE[1] - 40.0 + (i + 0.5) * cell)
    got = _to_utm(*_pixel_lonlat(ov, row, col, ov["w"], ov["h"]))
    pixel_m = 80.0 * 1.05 / ov["h"]
    assert np.hypot(got[0] - want[0], got[1] - want[1]) < cell + pixel_m
    vals = _decode_values(ov["values"])
    vr, vc = np.argwhere(np.isfinite(vals)).mean(axis=0)
    assert np.nanmax(vals) == pytest.approx(42.0, abs=0.05)
    got = _to_utm(*_pixel_lonlat(ov, vr, vc, ov["values"]["w"], ov["values"]["h"]))
    assert np.hypot(got[0] - want[0], got[1] - want[1]) < cell + 80.0 * 1.05 / ov["values"]["h"]
    # a vector point through map_data: pyproj to the millimetre
    layer = MapLayer("p", "p", [LocalFeature("Point", [(12.5, -31.0)])])
    data = map_data([layer], _utm_georef(), view_local=(-20, -40, 20, 40))
    lon, lat = data["layers"][0]["features"]["features"][0]["geometry"]["coordinates"]
    x, y = _to_utm(lon, lat)
    assert abs(x - (CENTRE[0] + 12.5)) < 1e-3 and abs(y - (CENTRE[1] - 31.0)) < 1e-3
    (s, w), (n, e) = data["view"]
    assert s < lat < n and w < lon < e


def test_the_grid_is_turned_by_the_convergence() -> None:
    """A north-south line of cells along the UTM grid's y axis leans by the grid convergence on the map."""
    cell, nx, ny = 0.5, 40, 200
    rgba = np.zeros((ny, nx, 4), np.uint8)
    rgba[:, 20] = (0, 0, 255, 255)
    ov = overlay(Raster(rgba, -10.0, -50.0, cell), _utm_georef(), max_px=400)
    px = _decode_png(ov["png"])
    rows = np.arange(px.shape[0])
    cols = np.array([np.mean(np.flatnonzero(px[k, :, 3] > 0)) if (px[k, :, 3] > 0).any() else np.nan for k in rows])
    ok = np.isfinite(cols)
    slope = np.polyfit(rows[ok], cols[ok], 1)[0]  # columns per row (pixels are ~square on the ground)
    gamma = np.degrees(np.arctan(slope))
    assert gamma == pytest.approx(1.77, abs=0.15)  # the grid's north points 1.77 deg west of true north


def test_a_spray_runs_map_has_every_layer_with_its_legend(ci_runs: Path) -> None:
    data = run_map(ci_runs / "spray")
    keys = [lay["key"] for lay in data["layers"]]
    assert keys == ["hillshade", "canopy", "deposition", "field", "fence", "rows", "path_sprayer", "path_phase",
                    "events"]
    by = {lay["key"]: lay for lay in data["layers"]}
    assert all(by[k].get("legend") for k in keys if k != "hillshade")
    assert by["path_sprayer"]["visible"] and not by["path_phase"]["visible"]  # a spraying run opens on its sprayer
    assert not by["canopy"]["visible"] and by["deposition"]["visible"]
    assert "the run's world folder is gone" in data["note"]  # the synthetic world has no folder
    # the deposition's hover values are the raster's rates (nearest cells, 0.1 L/ha steps)
    import rasterio

    with rasterio.open(ci_runs / "spray" / "deposition.tif") as ds:
        top = float(np.nanmax(np.where(ds.read(1) == ds.nodata, np.nan, ds.read(1))))
    vals = _decode_values(by["deposition"]["raster"]["values"])
    assert np.nanmax(vals) <= top + 0.06 and np.nanmax(vals) > 0.8 * top
    ticks = dict((lab, f) for f, lab in by["deposition"]["legend"]["ticks"])
    assert ticks["0"] == 0.0 and 0.4 < ticks[next(k for k in ticks if k.endswith("asked"))] < 0.6
    # targeted rows carry their dose in their hover text
    tips = [f["properties"]["tip"] for f in by["rows"]["features"]["features"] if f["properties"].get("targeted")]
    assert tips and all("L/ha" in t and "covered" in t for t in tips)
    assert len(json.dumps(data)) < 150_000


def test_a_new_layer_is_one_function(ci_runs: Path) -> None:
    def prescription(ctx):  # e.g. a prescription map: here one zone around the first row
        x, y = zip(*ctx.rows[0], strict=True)
        ring = [(min(x) - 1, min(y)), (max(x) + 1, min(y)), (max(x) + 1, max(y)), (min(x) - 1, max(y))]
        return MapLayer("prescription", "Prescription, L/ha", [LocalFeature("Polygon", ring, {"tip": "zone A: 80 L/ha"})],
                        style={"color": "#6a1b9a"}, legend=Legend(swatches=[("#6a1b9a", "zone", "fill")]))

    data = run_map(ci_runs / "gust", layers=[*LAYERS, prescription])
    lay = data["layers"][-1]
    assert lay["key"] == "prescription" and lay["features"]["features"][0]["properties"]["tip"] == "zone A: 80 L/ha"


def test_a_failed_check_is_located_on_the_path_of_its_window(failing_runs: Path) -> None:
    """The gust's failed hold: the path flown in the check's window, in red, linked from the check."""
    from vinecli.report.fieldmap.context import load_context

    data = run_map(failing_runs / "gust")
    assert data["located"] == ["holds_position"]
    failed = next(lay for lay in data["layers"] if lay["key"] == "failed")
    (f,) = failed["features"]["features"]
    assert f["properties"]["check"] == "holds_position" and f["properties"]["style"]["className"] == "fm-failed"
    summary = json.loads((failing_runs / "gust" / "summary.json").read_text())
    t0, t1 = next(c["window"] for c in summary["checks"] if c["name"] == "holds_position")
    ctx = load_context(failing_runs / "gust")
    sel = (ctx.cols["t_s"] >= t0) & (ctx.cols["t_s"] <= t1)
    want = ctx.georef.to_lonlat([(float(ctx.cols["pos_enu_x_m"][sel][0]), float(ctx.cols["pos_enu_y_m"][sel][0]))])[0]
    assert np.allclose(f["geometry"]["coordinates"][0], want, atol=1e-7)


def test_the_map_html_is_escaped_and_offline(ci_runs: Path, tmp_path: Path) -> None:
    from vinecli.report.fieldmap.map_page import head_assets, map_block

    data = run_map(ci_runs / "takeoff")
    data["title"] = "</script><script>alert(1)</script>"
    block = map_block(data, "t")
    assert "</script><script>alert" not in block and block.count("</script>") == 1
    assets = head_assets()
    assert "Leaflet 1.9.4" in assets and "url(images/" not in assets  # Leaflet's images inline
    assert (Path(__file__).parents[2] / "vinecli/report/fieldmap/assets/leaflet/LICENSE").read_text().startswith(
        "BSD 2-Clause License")


def test_zones_failsafes_faults_and_breakpoints_are_marked(ci_runs: Path, tmp_path: Path) -> None:
    """A spray run whose world has a no-spray zone and whose summary records a failsafe, a dose fault and sortie
    breakpoints (the formats run_mission writes, docs/architecture.md "Run directory"): each is on the map with its
    time and cause, a failed no-spray check highlights the zone, and the world's folder is found beside the runs."""
    import shutil

    runs = tmp_path / "runs"
    shutil.copytree(ci_runs / "spray", runs / "spray")
    world = runs / "_worlds" / "synthetic-vineyard"
    world.mkdir(parents=True)
    zone = [[6.0, -4.0], [9.0, -4.0], [9.0, 4.0], [6.0, 4.0]]
    (world / "world.json").write_text(json.dumps({
        "name": "synthetic-vineyard", "origin": {"lat": 46.001, "lon": 7.001, "alt": 510.0},
        "terrain": {"kind": "flat"}, "gis": {"files": {}, "no_spray_enu": [zone]}}))
    s = json.loads((runs / "spray" / "summary.json").read_text())
    s["failsafes"] = [{"t_s": 30.5, "cause": "geofence", "action": "hold", "detail": "left the fence by 0.4 m",
                       "position_enu": [-4.0, 10.0, 2.0]}]
    s["dose_faults"] = [{"row": 1, "kind": "gap", "from_m": 3.0, "to_m": 5.0, "ratio": 0.41, "t_s": 40.2,
                         "position_enu": [-2.5, -8.0]}]
    s["sorties"] = [{"sortie": 1, "t_end_s": 50.0, "end_reason": "tank empty", "breakpoint_enu": [-5.0, 3.0, 2.0]},
                    {"sortie": 2, "t_end_s": 90.0, "end_reason": "done", "breakpoint_enu": [0.0, 0.0, 2.0]}]
    s["checks"].append({"name": "dose_no_spray", "quantity": "metric:deposit_in_no_spray_fraction", "op": "<=",
                        "bound": 0.001, "value": 0.02, "passed": False})
    (runs / "spray" / "summary.json").write_text(json.dumps(s))
    data = run_map(runs / "spray")
    assert data["note"] == ""  # the world found in RUNS/_worlds/<name>
    by = {lay["key"]: lay for lay in data["layers"]}
    (z,) = by["no_spray"]["features"]["features"]
    assert len(z["geometry"]["coordinates"][0]) == 5
    tips = {f["properties"]["kind"]: f["properties"]["tip"] for f in by["events"]["features"]["features"]}
    assert "geofence" in tips["failsafe"] and "30.5" in tips["failsafe"] and "left the fence" in tips["failsafe"]
    assert "gap on row 1" in tips["gap"] and "0.41×" in tips["gap"] and "40.2 s" in tips["gap"]
    assert "sortie 1 ended at 50.0 s (tank empty)" in tips["breakpoint"]
    assert sum(f["properties"]["kind"] == "breakpoint" for f in by["events"]["features"]["features"]) == 1
    (f,) = [f for f in by["failed"]["features"]["features"] if f["properties"]["check"] == "dose_no_spray"]
    assert f["geometry"] == z["geometry"] and data["located"] == ["dose_no_spray"]


def test_the_hillshade_reads_the_grounds_elevation_at_the_worlds_resolution(tmp_path: Path) -> None:
    """A potato field's ridges (0.25 m high, 0.75 m apart, on a 5 cm terrain grid) read on hover as they are: the
    hover values come from the world's terrain grid, not from the run's preview (every 3rd column of it would read
    the ridges wrong), as elevations (the origin's altitude + world z)."""
    from vinecli.geo import GeoOrigin
    from vinecli.report.fieldmap.context import MapContext
    from vinecli.report.fieldmap.raster_layers import hillshade_layer

    dx = 0.05
    x = -9.5 + dx * np.arange(380)
    y = -34.0 + dx * np.arange(1360)
    z = 0.125 * np.sin(2 * np.pi * x / 0.75)[None, :] + 0.002 * y[:, None]  # ridges along y, a gentle slope
    (tmp_path / "terrain").mkdir()
    np.savez_compressed(tmp_path / "terrain" / "grid.npz", z=z.astype(np.float32),
                        x0=x[0], y0=y[0], dx=dx, dy=dx)
    origin = {"lat": 44.1189, "lon": -89.5418, "alt": 331.0}
    preview = {"x": x[::3], "y": y[::11], "z": z[::11, ::3]}  # how a run samples its preview (129 at most a side)
    ctx = MapContext(run_dir=tmp_path, summary={}, world={"origin": origin}, world_dir=tmp_path,
                     georef=Georef(None, GeoOrigin.from_dict(origin)), preview=preview)
    lay = hillshade_layer(ctx)
    assert lay is not None and lay.raster is not None
    r = lay.raster
    assert r.label == "ground" and "331.00 m" in lay.note
    v = r.values
    assert r.cell_m == pytest.approx(0.1)  # 2 x 2 block means of the 5 cm grid: the overlay's resolution
    across = v[v.shape[0] // 2]
    assert np.ptp(across) == pytest.approx(0.25, abs=0.03)  # each ridge's full height
    assert float(np.mean(across)) == pytest.approx(331.0 + 0.002 * y.mean(), abs=0.01)
    # hovered at the map's resolution (320 values on the long side: 0.21 m), the ridges still stand out
    ov = overlay(r, ctx.georef)
    hv = _decode_values(ov["values"])
    assert max(ov["values"]["w"], ov["values"]["h"]) == 320
    assert np.nanmax(np.ptp(hv, axis=1)) > 0.18
    # without the world, the run's preview (and the world z it records)
    no_world = hillshade_layer(MapContext(run_dir=tmp_path, summary={}, world={}, world_dir=None,
                                          georef=ctx.georef, preview=preview))
    assert no_world is not None and no_world.raster is not None and no_world.raster.label == "ground, world z"


def test_a_colour_scales_overlay_keeps_every_step(ci_runs: Path) -> None:
    """The deposition's overlay keeps the colour scale's steps exactly (an octree-quantized PNG merged the 256 steps
    of a scale into ~40 bands, up to 16 levels off): every drawn pixel is one of the scale's colours, and a ramp
    over the whole scale keeps each of its 255 steps."""
    from matplotlib import colormaps
    from matplotlib.colors import Normalize

    from vinecli.report.fieldmap.overlay import png_data_uri
    from vinecli.report.fieldmap.raster_layers import _rgba

    cmap = colormaps["RdYlBu_r"]
    v = np.linspace(0.0, 100.0, 600)[None, :].repeat(20, axis=0)
    ramp = _rgba(cmap, Normalize(0.0, 100.0), v, 0.85, v > 2.0)
    back = _decode_png(png_data_uri(ramp))
    assert np.array_equal(back, ramp)
    assert len(np.unique(back[back[..., 3] > 0].reshape(-1, 4), axis=0)) >= 245  # 98 % of the 255 steps shown
    data = run_map(str(ci_runs / "spray"))
    (dep,) = [lay for lay in data["layers"] if lay["key"] == "deposition"]
    px = _decode_png(dep["raster"]["png"])
    scale = np.rint(255 * cmap(np.linspace(0.0, 1.0, 255))).astype(np.uint8)[:, :3]
    drawn = px[px[..., 3] > 0][:, :3]
    assert drawn.size and np.isin(drawn.view("V3").ravel(), scale.view("V3").ravel()).all()


def test_a_page_writes_the_rasters_its_maps_repeat_once(ci_runs: Path, tmp_path: Path) -> None:
    """The runs of a batch fly over one world: its hillshade (image and hover heights) goes into the page once, each
    map refers to it, and a run's own rasters stay in its map."""
    from vinecli.report import build_report
    from vinecli.report.fieldmap.map_page import share_repeats

    a, b = run_map(str(ci_runs / "spray")), run_map(str(ci_runs / "gust"))
    (ma, mb), shared = share_repeats([a, b])
    hill = [lay["raster"] for lay in a["layers"] if lay["key"] == "hillshade"][0]
    assert set(shared.values()) == {hill["png"], hill["values"]["deflated"]}
    by = {lay["key"]: lay["raster"] for lay in ma["layers"] if lay.get("raster")}
    assert by["hillshade"]["png"].startswith("@") and shared[by["hillshade"]["png"][1:]] == hill["png"]
    assert by["deposition"]["png"].startswith("data:image/png")  # the spray run's own
    assert hill["png"].startswith("data:image/png")  # the maps given are not changed
    html = build_report(ci_runs, tmp_path / "r", workers=1).html.read_text(encoding="utf-8")
    assert html.count(hill["png"]) == 1 and 'id="fm-shared"' in html
