"""``fit.html`` and ``replay.html``: one self-contained page each (inline CSS, PNG figures as data URIs,
no scripts, every text escaped) that a person reads: what was fitted, how well, what was not."""

from __future__ import annotations

import base64
import html
import math
from typing import Any

from vinecli.flightlog.flight_log import FlightLog
from vinecli.identify.figures import fit_figures, replay_figures
from vinecli.identify.fit_result import FitResult
from vinecli.identify.replay import ERROR_KEYS, ReplayResult

__all__ = ["fit_page", "replay_page"]

CSS = ("body{font-family:sans-serif;max-width:1060px;margin:2em auto;color:#222}table{border-collapse:collapse;"
       "margin:.6em 0}td,th{border:1px solid #ccc;padding:3px 8px;text-align:left;font-size:14px}"
       "th{background:#f2f2f2}.base{color:#a33}figure{margin:1.2em 0}figcaption{font-size:13px;color:#555}"
       "li{margin:.2em 0}")


def _e(x: Any) -> str:
    return html.escape(str(x), quote=True)


def _num(v: Any, digits: int = 4) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    if isinstance(v, float):
        return f"{v:.{digits}g}"
    return str(v)


def _page(title: str, body: list[str]) -> str:
    return (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{_e(title)}</title>"
            f"<style>{CSS}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n")


def _figures(figs: list[tuple[str, bytes]]) -> list[str]:
    return [f"<figure><img alt=\"{_e(c)}\" src=\"data:image/png;base64,{base64.b64encode(png).decode()}\">"
            f"<figcaption>{_e(c)}</figcaption></figure>" for c, png in figs]


def _log_block(log: FlightLog) -> list[str]:
    i = log.info
    rows = [("file", i.path), ("format", i.format), ("firmware", i.firmware), ("hardware", i.hardware),
            ("flight date (UTC)", i.date_utc or "not in the log"), ("duration", f"{i.duration_s:.1f} s"),
            ("frame", log.config.frame), ("sha256", i.sha256)]
    return ["<table>"] + [f"<tr><th>{_e(k)}</th><td>{_e(v)}</td></tr>" for k, v in rows] + ["</table>"]


def _errors_table(errors: dict[str, dict[str, Any]]) -> list[str]:
    head = "".join(f"<th>{_e(k)}</th>" for k in (*ERROR_KEYS, "gyro_rms_radps"))
    out = ["<table>", f"<tr><th>model</th>{head}</tr>"]
    for name, e in errors.items():
        cells = "".join(f"<td>{_num(e.get(k))}</td>" for k in (*ERROR_KEYS, "gyro_rms_radps"))
        out.append(f"<tr><th>{_e(name)}</th>{cells}</tr>")
    return out + ["</table>"]


def fit_page(r: FitResult) -> str:
    """The fit's page: the log, the parameters with std and source, the checks, what is fixed, the figures."""
    rep = r.report
    body = [f"<h1>Vehicle fit: {_e(r.vehicle_yaml['name'])}</h1>", "<h2>Flight log</h2>", *_log_block(r.log),
            "<h2>Parameters</h2><p>value ± std (block bootstrap); <span class=base>red</span>: not identified by "
            "this log, taken from the base vehicle <b>" + _e(r.base.ref) + "</b>.</p>", "<table>",
            "<tr><th>parameter</th><th>value</th><th>std</th><th>unit</th><th>source</th><th>from</th></tr>"]
    for k, p in rep["parameters"].items():
        cls = " class=base" if p["source"] == "base" else ""
        body.append(f"<tr{cls}><td>{_e(k)}</td><td>{_num(p['value'])}</td><td>{_num(p['std'], 2)}</td>"
                    f"<td>{_e(p['unit'])}</td><td>{_e(p['source'])}</td><td>{_e(p['note'])}</td></tr>")
    body.append("</table>")
    hc, en = rep.get("hover_check") or {}, rep.get("energy") or {}
    checks = [f"hover throttle {_num(rep['hover_throttle'])} ({_num(rep['hover_pwm_us'], 5)} µs); the log's steady "
              f"hover ({hc.get('samples', 0)} samples) flies {_num(hc.get('log_hover_output'))}: "
              f"{_num(100 * hc['error_fraction'], 2) if 'error_fraction' in hc else '-'} %"]
    if en:
        held = ", ".join(f"{100 * x:+.1f} %" for x in en.get("held_out_error_fractions", []))
        checks.append(f"energy over the flight: log {_num(en['log_wh'])} Wh, model {_num(en['model_wh'])} Wh "
                      f"({_num(100 * en['error_fraction'], 2)} %; fitted on one half, predicting the other: {held})")
    if "replay" in rep:
        checks.append("replay of this log (in-sample): " + ", ".join(f"{k} {_num(v)}" for k, v in rep["replay"]["replay"].items()))
    body += ["<h2>Checks</h2><ul>", *(f"<li>{_e(c)}</li>" for c in checks), "</ul>",
             "<h2>Not identified by this log (from the base)</h2><ul>",
             *(f"<li>{_e(x)}</li>" for x in rep["fixed_from_base"]), "</ul>",
             "<h2>Notes</h2><ul>", *(f"<li>{_e(x)}</li>" for x in rep["notes"]), "</ul>",
             "<h2>Figures</h2>", *_figures(fit_figures(r))]
    if r.replay is not None:
        body += ["<h2>Replay of this log</h2>", *_errors_table(r.replay.errors), "<p>see replay.html</p>"]
    return _page(f"vinecli vehicle fit: {r.vehicle_yaml['name']}", body)


def replay_page(rep: ReplayResult, log: FlightLog, vehicle: str, base: str | None) -> str:
    """The replay's page: the errors of the vehicle and the baselines, the notes, the figures."""
    body = [f"<h1>Replay of {_e(log.info.path)} through {_e(vehicle)}</h1>", *_log_block(log),
            f"<p>{len(rep.windows)} open-loop windows, re-anchored to the log's state at each start; rigid body with "
            "vinecli's laws at 250 Hz in still air (no PyBullet). Baselines: the log's own mean, and the base vehicle "
            f"<b>{_e(base or '-')}</b> unfitted.</p>", *_errors_table(rep.errors),
            "<h2>Notes</h2><ul>", *(f"<li>{_e(x)}</li>" for x in rep.notes), "</ul>",
            "<h2>Figures</h2>", *_figures(replay_figures(rep, log))]
    return _page(f"vinecli vehicle replay: {vehicle}", body)
