"""How real a run's vehicle is: the provenance of a fitted vehicle (``vinecli vehicle fit``) in one line.

summary.json ``vehicle_fit`` = the vehicle's ``provenance``: the log it was fitted to, firmware, flight
date, and the errors of replaying that log through it next to the baselines'.
"""

from __future__ import annotations

from typing import Any

__all__ = ["vehicle_fit_text"]

#: replay error keys with their short label and unit
ERRORS = (("accel_rms_mps2", "specific force", "m/s²", 1.0), ("velocity_rms_mps", "velocity drift", "m/s", 1.0),
          ("voltage_rms_v", "voltage", "V", 1.0), ("energy_error_fraction", "energy", "%", 100.0))


def _num(v: Any, scale: float) -> str:
    return "-" if not isinstance(v, int | float) else f"{v * scale:.3g}"


def vehicle_fit_text(summary: dict[str, Any]) -> str | None:
    """One line about the run's fitted vehicle, or None when the vehicle was not fitted to a log."""
    fit = summary.get("vehicle_fit")
    if not isinstance(fit, dict):
        return None
    date = f", flown {str(fit['flight_date_utc'])[:10]}" if fit.get("flight_date_utc") else ""
    head = f"vehicle fitted to {fit.get('log', '?')} ({fit.get('firmware', '?')}{date}; base {fit.get('base', '?')})"
    rep, base = fit.get("replay") or {}, (fit.get("replay_baselines") or {})
    parts = []
    for key, label, unit, scale in ERRORS:
        if key in rep:
            others = ", ".join(f"{name} {_num((b or {}).get(key), scale)}" for name, b in base.items())
            parts.append(f"{label} {_num(rep[key], scale)} {unit}" + (f" ({others})" if others else ""))
    return head + ("; replay errors: " + "; ".join(parts) if parts else "")
