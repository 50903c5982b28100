"""Figures 20-22: rotor speeds against mass and wind, the attitude against the wind (the tilt into the
gust, with the predicted steady tilt), the battery and the sorties of a refill job."""

from __future__ import annotations

import numpy as np

from vinecli.missions.metrics import airborne_mask, predicted_tilt_rad
from vinecli.report.figure_base import (
    NoData,
    PlotData,
    new_figure,
    png_bytes,
    set_title,
)
from vinecli.report.figure_marks import event_lines, need, shade_check_windows


def _varies(a: np.ndarray, share: float) -> bool:
    """A column that moves by more than ``share`` of its largest magnitude."""
    fin = a[np.isfinite(a)]
    return bool(fin.size and float(np.ptp(fin)) > share * max(float(np.max(np.abs(fin))), 1e-9))


def fig20_rotors(data: PlotData) -> bytes:
    """Rotor speeds against what drives them: total (tank) mass and the wind; a driver that stays constant gets no
    panel (the figure is shorter)."""
    rotors = data.rotors()
    if not rotors:
        raise NoData("no rotor speeds in this run")
    c, t = data.cols, data.t
    wind = np.hypot(c["wind_enu_x_mps"], c["wind_enu_y_mps"]) if data.has("wind_enu_x_mps", "wind_enu_y_mps") else None
    show_mass = data.has("total_mass_kg") and _varies(c["total_mass_kg"], 0.01)
    show_wind = wind is not None and float(np.nanmax(wind)) >= 0.5
    n = 1 + show_mass + show_wind
    fig, axes = new_figure("fig20", n, 1, size=(9.0, 3.0 + 2.0 * n))
    ax = axes[0, 0]
    for i, r in enumerate(rotors):
        ax.plot(t, c[r], lw=0.7, alpha=0.6, label=f"rotor {i + 1}")
    mean = np.mean([c[r] for r in rotors], axis=0)
    ax.plot(t, mean, color="0.35", lw=0.8, label="mean")
    if t.size > 3:
        dt = float(np.median(np.diff(t)))
        k = max(1, int(round(2.0 / dt))) if dt > 0 else 1
        if t.size > 3 * k:  # centred average, normalised at the edges
            box = np.ones(k)
            avg = np.convolve(mean, box, mode="same") / np.convolve(np.ones_like(mean), box, mode="same")
            ax.plot(t, avg, color="k", lw=1.8, label="mean, 2 s average")
    air = airborne_mask(c)
    if air.any():
        ymin, ymax = np.nanpercentile(mean[air], [1, 99])
        pad = max(20.0, 0.25 * (ymax - ymin))
        ax.set_ylim(ymin - pad, ymax + pad)
    ax.set_ylabel("rotor speed, rad/s")
    ax.legend(fontsize=7, ncol=min(5, len(rotors) + 1), loc="upper right")
    used = [ax]
    if show_mass:
        axm = axes[len(used), 0]
        used.append(axm)
        axm.plot(t, c["total_mass_kg"], color="#8c564b", lw=1.4, label="total mass, kg")
        if data.has("tank_mass_kg"):
            tw = axm.twinx()
            tw.plot(t, c["tank_mass_kg"], color="#1f77b4", lw=1.0, ls="--", label="tank liquid, kg")
            tw.set_ylabel("tank liquid, kg")
            lines = axm.get_lines()[:1] + tw.get_lines()
            axm.legend(lines, [ln.get_label() for ln in lines], fontsize=7, loc="upper right")
        axm.set_ylabel("total mass, kg")
    if show_wind:
        axw = axes[len(used), 0]
        used.append(axw)
        axw.plot(t, wind, color="#1f77b4", lw=1.2, label="horizontal wind speed, m/s")
        axw.legend(fontsize=7, loc="upper right")
        axw.set_ylabel("wind, m/s (ENU)")
    used[-1].set_xlabel("time, s")
    for a in used:
        a.grid(alpha=0.3)
        event_lines(a, data)
    shade_check_windows(used, "fig20", data)
    const = [w for w, shown in (("mass", show_mass), ("wind", show_wind)) if not shown]
    what = "Fig. 20  Rotor speeds vs mass and wind (hover: w ∝ √m)"
    set_title(fig, data, what + (f"; constant {' and '.join(const)} not shown" if const else ""))
    return png_bytes(fig)


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
    fig, axes = new_figure("fig21", 3, 1)
    ax, axy, axw = axes[0, 0], axes[1, 0], axes[2, 0]
    ax.plot(t, np.degrees(c["roll_rad"]), color="#1f77b4", lw=1.0, label="roll")
    ax.plot(t, np.degrees(c["pitch_rad"]), color="#ff7f0e", lw=1.0, label="pitch")
    if data.has("tilt_rad"):
        ax.plot(t, np.degrees(c["tilt_rad"]), color="k", lw=1.2, label="tilt |z_body ∠ up|")
    pred = _predicted_tilt_deg(data)
    if pred is not None:
        air = airborne_mask(c)
        ax.plot(t, np.where(air, pred, np.nan), color="#9467bd", lw=1.0, ls="--",
                label="predicted tilt atan(F_h / m g)")
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.set_ylabel("angle, deg\n(Z-Y-X, ENU/FLU)")
    ax.legend(fontsize=7, ncol=2, loc="upper right")
    if data.has("yaw_rad"):
        axy.plot(t, np.degrees(np.unwrap(c["yaw_rad"])), color="#2ca02c", lw=1.0, label="yaw (from east, CCW)")
        axy.legend(fontsize=7, loc="upper right")
    axy.set_ylabel("yaw, deg")
    if data.has("wind_enu_x_mps", "wind_enu_y_mps"):
        axw.plot(t, c["wind_enu_x_mps"], color="#1f77b4", lw=1.0, label="wind east x")
        axw.plot(t, c["wind_enu_y_mps"], color="#d62728", lw=1.0, label="wind north y")
        axw.legend(fontsize=7, loc="upper right")
    axw.set_ylabel("wind, m/s (ENU)")
    axw.set_xlabel("time, s")
    for a in (ax, axy, axw):
        a.grid(alpha=0.3)
        event_lines(a, data, ("liftoff", "touchdown"))
    shade_check_windows([ax, axy, axw], "fig21", data)
    set_title(fig, data, "Fig. 21  Attitude vs wind (tilt into the gust; pitch > 0 = nose down in FLU)")
    return png_bytes(fig)


# ---------------------------------------------------------------- figure 22
def fig22_battery(data: PlotData) -> bytes:
    """Battery voltage and state of charge, electrical power, and the sorties of a refill job."""
    need(data, "battery_soc", "battery_voltage_v", what="battery")
    c, t = data.cols, data.t
    fig, axes = new_figure("fig22", 2, 1)
    ax, ax2 = axes[0, 0], axes[1, 0]
    ax.plot(t, c["battery_voltage_v"], color="#6a1b9a", lw=1.2, label="terminal voltage, V")
    ax.set_ylabel("voltage, V")
    tw = ax.twinx()
    tw.plot(t, 100.0 * c["battery_soc"], color="#2e7d32", lw=1.6, label="state of charge, %")
    tw.set_ylabel("state of charge, %")
    tw.set_ylim(0.0, 105.0)
    lines = ax.get_lines() + tw.get_lines()
    ax.legend(lines, [ln.get_label() for ln in lines], fontsize=7, loc="lower left")
    if data.has("power_elec_w"):
        ax2.plot(t, c["power_elec_w"], color="#e65100", lw=0.9, label="electrical power drawn, W")
    if data.has("sortie") and np.nanmax(c["sortie"]) > 1:
        tw2 = ax2.twinx()
        tw2.step(t, c["sortie"], where="post", color="#0d47a1", lw=1.0, label="sortie")
        tw2.set_ylabel("sortie")
        lines = ax2.get_lines() + tw2.get_lines()
        ax2.legend(lines, [ln.get_label() for ln in lines], fontsize=7, loc="upper right")
    else:
        ax2.legend(fontsize=7, loc="upper right")
    ax2.set_ylabel("power, W")
    ax2.set_xlabel("time, s")
    for a in (ax, ax2):
        a.grid(alpha=0.3)
        event_lines(a, data, ("liftoff", "refill", "battery_swap"))
    e_wh = (data.summary.get("metrics") or {}).get("energy_wh")
    what = "Fig. 22  Battery and sorties" + (f" ({e_wh:.1f} Wh drawn)" if isinstance(e_wh, float) else "")
    set_title(fig, data, what)
    return png_bytes(fig)
