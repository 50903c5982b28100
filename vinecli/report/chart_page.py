"""The time-series figures in HTML: uPlot 1.6.32 (vendored in ``assets/uplot``, MIT, its LICENSE beside it) and the
chart script and style (``assets/charts.js``, ``assets/charts.css``) inlined once per page, and one
``<div class="tsc">`` per figure holding its chart JSON (:mod:`vinecli.report.chart`). Nothing is fetched."""

from __future__ import annotations

import html
import json
from functools import cache
from pathlib import Path
from typing import Any

__all__ = ["ASSETS", "UPLOT_VERSION", "chart_assets", "chart_block"]

ASSETS = Path(__file__).parent / "assets"
UPLOT_VERSION = "1.6.32"


def _script(js: str) -> str:
    return "<script>" + js.replace("</script", "<\\/script") + "</script>"


@cache
def chart_assets() -> str:
    """uPlot's CSS and JS and the chart script's, inline (for the page's head)."""
    up = ASSETS / "uplot"
    css = (up / "uPlot.min.css").read_text(encoding="utf-8") + "\n" + (ASSETS / "charts.css").read_text(encoding="utf-8")
    return (f"<!-- uPlot {UPLOT_VERSION} (MIT, (c) Leon Sorokin) -->\n<style>{css}</style>\n"
            + _script((up / "uPlot.iife.min.js").read_text(encoding="utf-8")) + "\n"
            + _script((ASSETS / "charts.js").read_text(encoding="utf-8")))


def chart_block(chart: dict[str, Any]) -> str:
    """The HTML of one time-series figure: its title, an empty box charts.js fills, its notes and its data."""
    data = json.dumps(chart, separators=(",", ":"), allow_nan=False).replace("<", "\\u003c")
    notes = "".join(f'<p class="note">{html.escape(n)}</p>' for n in chart.get("notes") or [])
    return (f'<div class="tsc" role="img" aria-label="{html.escape(chart.get("title", ""))}">'
            f'<div class="tsc-title">{html.escape(chart.get("title", ""))}</div><div class="tsc-plots"></div>'
            f'{notes}<script type="application/json" class="tsc-data">{data}</script></div>')
