"""Figures 20-22, drawn in the browser (:mod:`~vinecli.report.chart`): rotor speeds against mass and wind, the
attitude against the wind (the tilt into the gust, with the predicted steady tilt), the battery and the sorties of
a refill job."""

from __future__ import annotations

import numpy as np

from vinecli.missions.metrics import airborne_mask, predicted_tilt_rad
from vinecli.report.chart import Chart, Panel, Series, chart_bytes
from vinecli.report.figure_base import NoData, PlotData, title_text
from vinecli.report.figure_marks import check_windows, event_marks, need

#: matplotlib's default colour cycle (tab10), one colour per rotor
CYCLE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f")


def _varies(a: np.ndarray, share: float) -> bool:
    """A column that moves by more than ``share`` of its largest magnitude."""
    fin = a[np.isfinite(a)]
    return bool(fin.size and float(np.ptp(fin)) > share * max(float(np.max(np.abs(fin))), 1e-9))


def fig20_rotors(data: PlotData) -> bytes:
    """Rotor speeds against what drives them: total (tank) mass and the wind; a driver that stays constant gets no
    panel."""
    rotors = data.rotors()
    if not rotors:
        raise NoData("no rotor speeds in this run")
    c, t = data.cols, data.t
    wind = np.hypot(c["wind_enu_x_mps"], c["wind_enu_y_mps"]) if data.has("wind_enu_x_mps", "wind_enu_y_mps") else None
    show_mass = data.has("total_mass_kg") and _varies(c["total_mass_kg"], 0.01)
    show_wind = wind is not None and float(np.nanmax(wind)) >= 0.5
    lines = [Series(f"rotor {i + 1}", c[r], CYCLE[i % len(CYCLE)] + "99", 0.7) for i, r in enumerate(rotors)]
    mean = np.mean([c[r] for r in rotors], axis=0)
    lines.append(Series("mean", mean, "#595959", 0.8))
    if t.size > 3:
        dt = float(np.median(np.diff(t)))
        k = max(1, int(round(2.0 / dt))) if dt > 0 else 1
        if t.size > 3 * k:  # centred average, normalised at the edges
            box = np.ones(k)
            avg = np.convolve(mean, box, mode="same") / np.convolve(np.ones_like(mean), box, mode="same")
            lines.append(Series("mean, 2 s average", avg, "#000000", 1.8))
    ylim = None
    air = airborne_mask(c)
    if air.any():
        ymin, ymax = np.nanpercentile(mean[air], [1, 99])
        pad = max(20.0, 0.25 * (ymax - ymin))
        ylim = (float(ymin - pad), float(ymax + pad))
    panels = [Panel("rotor speed, rad/s", lines, ylim=ylim, height=240)]
    if show_mass:
        mass = [Series("total mass, kg", c["total_mass_kg"], "#8c564b", 1.4)]
        if data.has("tank_mass_kg"):
            mass.append(Series("tank liquid, kg", c["tank_mass_kg"], "#1f77b4", 1.0, (6, 4), right=True))
        panels.append(Panel("total mass, kg", mass, y2label="tank liquid, kg" if len(mass) > 1 else "", height=170))
    if show_wind:
        panels.append(Panel("wind, m/s (ENU)", [Series("horizontal wind speed, m/s", wind, "#1f77b4", 1.2)],
                            height=170))
    const = [w for w, shown in (("mass", show_mass), ("wind", show_wind)) if not shown]
    what = "Fig. 20  Rotor speeds vs mass and wind (hover: w ∝ √m)"
    return chart_bytes(Chart(title_text(data, what + (f"; constant {' and '.join(const)} not shown" if const else "")),
                             t, panels, events=event_marks(data), windows=check_windows("fig20", data)))


# ---------------------------------------------------------------- figure 21
def _predicted_tilt_deg(data: PlotData) -> np.ndarray | None:
    """The predicted steady tilt (:func:`vinecli.missions.metrics.predicted_tilt_rad`) in deg, with the rotors'
    H-force when the run recorded it and the run's gravity; None without drag or mass."""
    if not data.has("drag_enu_x_n", "drag_enu_y_n", "total_mass_kg"):
        return None
    c = data.cols
    cols = c if data.has("rotor_drag_flu_x_n", "quat_w") else \
        {k: c[k] for k in ("drag_enu_x_n", "drag_enu_y_n", "total_mass_kg")}
    return np.degrees(predicted_tilt_rad(cols, data.gravity))


def fig21_attitude(data: PlotData) -> bytes:
    """Roll/pitch (and yaw) vs the wind: the vehicle tilts into the gust."""
    need(data, "roll_rad", "pitch_rad", what="attitude")
    c, t = data.cols, data.t
    angles = [Series("roll", np.degrees(c["roll_rad"]), "#1f77b4", 1.0),
              Series("pitch", np.degrees(c["pitch_rad"]), "#ff7f0e", 1.0)]
    if data.has("tilt_rad"):
        angles.append(Series("tilt |z_body ∠ up|", np.degrees(c["tilt_rad"]), "#000000", 1.2))
    pred = _predicted_tilt_deg(data)
    if pred is not None:
        angles.append(Series("predicted tilt atan(F_h / m g)", np.where(airborne_mask(c), pred, np.nan), "#9467bd",
                             1.0, (6, 4)))
    yaw = [Series("yaw (from east, CCW)", np.degrees(np.unwrap(c["yaw_rad"])), "#2ca02c", 1.0)] \
        if data.has("yaw_rad") else []
    wind = [Series("wind east x", c["wind_enu_x_mps"], "#1f77b4", 1.0),
            Series("wind north y", c["wind_enu_y_mps"], "#d62728", 1.0)] \
        if data.has("wind_enu_x_mps", "wind_enu_y_mps") else []
    return chart_bytes(Chart(
        title_text(data, "Fig. 21  Attitude vs wind (tilt into the gust; pitch > 0 = nose down in FLU)"), t,
        [Panel("angle, deg (Z-Y-X, ENU/FLU)", angles, zero=True), Panel("yaw, deg", yaw, height=150),
         Panel("wind, m/s (ENU)", wind, height=170)],
        events=event_marks(data, ("liftoff", "touchdown")), windows=check_windows("fig21", data)))


# ---------------------------------------------------------------- figure 22
def fig22_battery(data: PlotData) -> bytes:
    """Battery voltage and state of charge, electrical power, and the sorties of a refill job."""
    need(data, "battery_soc", "battery_voltage_v", what="battery")
    c, t = data.cols, data.t
    power = [Series("electrical power drawn, W", c["power_elec_w"], "#e65100", 0.9)] if data.has("power_elec_w") else []
    sorties = data.has("sortie") and float(np.nanmax(c["sortie"])) > 1
    if sorties:
        power.append(Series("sortie", c["sortie"], "#0d47a1", 1.0, step=True, right=True))
    e_wh = (data.summary.get("metrics") or {}).get("energy_wh")
    what = "Fig. 22  Battery and sorties" + (f" ({e_wh:.1f} Wh drawn)" if isinstance(e_wh, float) else "")
    return chart_bytes(Chart(
        title_text(data, what), t,
        [Panel("voltage, V", [Series("terminal voltage, V", c["battery_voltage_v"], "#6a1b9a", 1.2),
                              Series("state of charge, %", 100.0 * c["battery_soc"], "#2e7d32", 1.6, right=True)],
               y2label="state of charge, %", y2lim=(0.0, 105.0)),
         Panel("power, W", power, y2label="sortie" if sorties else "")],
        events=event_marks(data, ("liftoff", "refill", "battery_swap")), windows=check_windows("fig22", data)))
