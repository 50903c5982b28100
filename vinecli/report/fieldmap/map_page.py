"""The field map in HTML: Leaflet 1.9.4 (vendored in ``assets/leaflet``, BSD-2-Clause, its LICENSE beside it) and
the map script and style inlined once per page (its images as data URIs: the page fetches nothing), and one
``<div class="fm">`` per map holding its data as JSON. A standalone page (``gis export``'s map) is the same block
in a page of its own."""

from __future__ import annotations

import base64
import html
import json
import re
from functools import cache
from pathlib import Path
from typing import Any

__all__ = ["ASSETS", "head_assets", "map_block", "share_repeats", "shared_block", "standalone_page"]

ASSETS = Path(__file__).parent / "assets"
LEAFLET_VERSION = "1.9.4"


def _inline_images(css: str, folder: Path) -> str:
    def data_uri(m: re.Match[str]) -> str:
        p = folder / m.group(1)
        if not p.is_file():
            return "none"
        return "url(data:image/png;base64," + base64.b64encode(p.read_bytes()).decode("ascii") + ")"

    return re.sub(r"url\((images/[A-Za-z0-9_.-]+\.png)\)", data_uri, css)


def _script(js: str) -> str:
    return "<script>" + js.replace("</script", "<\\/script") + "</script>"


@cache
def head_assets() -> str:
    """Leaflet's CSS and JS and the map's, inline (``<style>`` and ``<script>`` elements for the page's head)."""
    lf = ASSETS / "leaflet"
    css = _inline_images((lf / "leaflet.css").read_text(encoding="utf-8"), lf)
    own = (ASSETS / "fieldmap.css").read_text(encoding="utf-8")
    return (f"<!-- Leaflet {LEAFLET_VERSION} (BSD-2-Clause, (c) Volodymyr Agafonkin, CloudMade) -->\n"
            f"<style>{css}\n{own}</style>\n" + _script((lf / "leaflet.js").read_text(encoding="utf-8")) + "\n"
            + _script((ASSETS / "fieldmap.js").read_text(encoding="utf-8")))


def _json_for_script(data: Any) -> str:
    """JSON safe inside a ``<script>`` element (no ``</``, no ``<!--``)."""
    return json.dumps(data, separators=(",", ":"), allow_nan=False).replace("<", "\\u003c")


def _raster_strings(data: dict[str, Any]) -> list[tuple[dict[str, Any], str]]:
    """(holder, key) of each raster image and hover-value string of a map's data."""
    out = []
    for lay in data.get("layers") or []:
        r = lay.get("raster")
        if r:
            out.append((r, "png"))
            if r.get("values"):
                out.append((r["values"], "deflated"))
    return out


def share_repeats(maps: list[dict[str, Any]]) -> tuple[list[dict[str, Any]], dict[str, str]]:
    """The maps of one page with the raster images and hover values that several of them repeat (the world's
    hillshade under each run of a batch: 100-200 kB each) replaced by ``"@key"``, and ``{key: string}`` to write
    once (:func:`shared_block`). The maps given are not changed."""
    import copy
    import hashlib
    from collections import Counter

    count = Counter(holder[key] for m in maps for holder, key in _raster_strings(m))
    keys = {s: hashlib.blake2b(s.encode(), digest_size=8).hexdigest() for s, n in count.items() if n > 1}
    if not keys:
        return maps, {}
    out = []
    for m in maps:
        m = copy.deepcopy(m)
        for holder, key in _raster_strings(m):
            if holder[key] in keys:
                holder[key] = "@" + keys[holder[key]]
        out.append(m)
    return out, {k: s for s, k in keys.items()}


def shared_block(shared: dict[str, str]) -> str:
    """The strings the maps of a page share (:func:`share_repeats`), once."""
    return f'<script type="application/json" id="fm-shared">{_json_for_script(shared)}</script>' if shared else ""


def map_block(data: dict[str, Any], anchor: str, *, basemap: str | None = None) -> str:
    """The HTML of one map (:func:`vinecli.report.fieldmap.run_map.run_map`'s data) with id ``map-<anchor>``;
    ``basemap``: a tile URL template (``{z}/{x}/{y}``) drawn under the layers, fetched by the browser (off by
    default: the page is offline)."""
    payload = {**data, **({"basemap": basemap} if basemap else {})}
    note = f'<p class="fm-note">{html.escape(data["note"])}</p>' if data.get("note") else ""
    return (f'<div class="fm" id="map-{html.escape(anchor)}" data-map="{html.escape(anchor)}">'
            f'<div class="fm-main"><div class="fm-map" role="img" aria-label="{html.escape(data.get("title", ""))}">'
            '</div><div class="fm-readout">hover the map: the values under the cursor</div>'
            f'{note}</div><div class="fm-layers"></div>'
            f'<script type="application/json" class="fm-data">{_json_for_script(payload)}</script></div>')


def standalone_page(data: dict[str, Any], title: str, *, basemap: str | None = None) -> str:
    """A whole offline HTML page showing one map."""
    t = html.escape(title)
    return ("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
            f"<title>{t}</title>\n<style>body {{ font-family: system-ui, sans-serif; margin: 0 auto; max-width: 1280px;"
            " padding: 12px 20px; color: #1d2329; }} h1 {{ font-size: 20px; }}</style>\n"
            f"{head_assets()}\n</head>\n<body>\n<h1>{t}</h1>\n{map_block(data, 'run', basemap=basemap)}\n</body>\n</html>\n")
