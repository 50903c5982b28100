"""Replay a log through a vehicle model and measure how far it is from the flight, next to two baselines.

Open-loop windows (:data:`WINDOW_S`, airborne, no gap): at each window's start the model takes the log's
state (position, velocity, body rates; motors at their commanded speeds) and then flies on the log's motor
outputs alone (:class:`~vinecli.identify.replay_model.VehicleReplay`): its forces move it, at the attitude
the log measured (a 5-10 Hz log cannot hold a multicopter upright open loop), and its torques give the
predicted body rates. Compared at the output
samples: specific force (the model's averaged over the same interval as the IMU's; the IMU's steady
in-plane offset, measured in hover, removed), body rates, and the velocity at each window's end. The pack
runs over the whole flight from the log's start voltage: terminal voltage at the battery samples, and the
energy used since the start (the log's ``integral V I dt`` against the model's load). Errors: RMS; the
energy's is the RMS over the flight of the difference of the two energy-used curves over the flight's
energy (the signed error of the total and the largest difference beside it).

Baselines, scored the same way: ``log_mean`` predicts the log's own mean (specific force, rates,
acceleration, voltage, power) everywhere (its total energy is right by construction: only the shape of
its energy curve is scored); ``base_unfitted`` is the base vehicle replayed like the model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vinecli.errors import InputError
from vinecli.flight.battery import Battery
from vinecli.flightlog.flight_log import FlightLog
from vinecli.identify.battery_fit import soc_at_ocv
from vinecli.identify.replay_model import BATTERY_DT, RATE_HZ, RigidState6, VehicleReplay
from vinecli.identify.samples import FlightSamples, interval_means, make_samples, quat_at
from vinecli.specs.vehicle import VehicleSpec

__all__ = ["ERROR_KEYS", "WINDOW_S", "ReplayResult", "replay_log"]

WINDOW_S = 2.0
ERROR_KEYS = ("accel_rms_mps2", "velocity_rms_mps", "voltage_rms_v", "energy_error_fraction")


@dataclass(frozen=True)
class ReplayResult:
    """Errors per candidate (``vehicle``, ``base_unfitted``, ``log_mean``) and the series the figures draw."""

    errors: dict[str, dict[str, Any]]
    windows: list[tuple[float, float]]
    series: dict[str, Any] = field(default_factory=dict)
    imu_offset_xy: tuple[float, float] = (0.0, 0.0)
    span_s: tuple[float, float] = (0.0, 0.0)
    notes: tuple[str, ...] = ()


def _windows(s: FlightSamples, window_s: float) -> list[tuple[int, int]]:
    """Consecutive runs of airborne samples cut into windows of ``window_s`` (at least half of it long)."""
    air, t = s.airborne, s.t_s
    out = []
    i = 0
    while i < len(t):
        if not air[i]:
            i += 1
            continue
        j = i
        while j + 1 < len(t) and air[j + 1] and t[j + 1] - t[i] <= window_s:
            j += 1
        if t[j] - t[i] >= 0.5 * window_s:
            out.append((i, j))
        i = j + 1
    return out


def _fly_windows(model: VehicleReplay, s: FlightSamples, log: FlightLog, pos: np.ndarray,
                 wins: list[tuple[int, int]], h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The model over each window: specific force and predicted rates at the samples (NaN outside windows),
    velocity at each window's end. The attitude and body rates the forces act at are the log's, interpolated
    to each step (attitude at its rate, the IMU's rates averaged over the output intervals)."""
    n = len(s.t_s)
    f_out, w_out = np.full((n, 3), np.nan), np.full((n, 3), np.nan)
    v_end = np.full((len(wins), 3), np.nan)
    dt = 1.0 / RATE_HZ
    for w, (i, j) in enumerate(wins):
        st = RigidState6(tuple(pos[i]), tuple(s.quat[i]), tuple(s.vel_enu[i]), tuple(s.gyro_body[i]))  # type: ignore[arg-type]
        model.motors.reset(model.commands(s.u[i], True))
        t0 = float(s.t_s[i])
        steps = int(math.ceil((float(s.t_s[j]) + h - t0) / dt))
        ts = t0 + dt * np.arange(steps)  # the state after each step is at ts + dt
        k_of = np.clip(np.searchsorted(s.t_s, ts, side="right") - 1, i, j)
        quats = quat_at(log.attitude.t_s, log.attitude.quat_xyzw, ts + 0.5 * dt)
        rates = np.column_stack([np.interp(ts + 0.5 * dt, s.t_s[i:j + 1], s.gyro_body[i:j + 1, k]) for k in range(3)])
        fs, ws = np.empty((steps, 3)), np.empty((steps, 3))
        cmds = {k: model.commands(s.u[k], True) for k in range(i, j + 1)}
        end_step = max(0, int(round((float(s.t_s[j]) - t0) / dt)) - 1)
        for k in range(steps):
            st = model.step(st, cmds[int(k_of[k])], tuple(quats[k]), tuple(rates[k]))  # type: ignore[arg-type]
            fs[k], ws[k] = model.specific_force, st.omega
            if k == end_step:
                v_end[w] = st.vel
        # the forces of a step act over [ts, ts + dt]: averaged over the samples' intervals like the IMU's
        f_out[i:j + 1] = interval_means(ts + 0.5 * dt, fs, s.t_s[i:j + 1], h)[0]
        w_out[i:j + 1] = interval_means(ts + dt, ws, s.t_s[i:j + 1], h)[0]
    return f_out, w_out, v_end


def _rms(x: np.ndarray) -> float:
    x = x[np.isfinite(x).all(axis=1)] if x.ndim == 2 else x[np.isfinite(x)]
    return float(np.sqrt(np.mean(np.sum(x * x, axis=1) if x.ndim == 2 else x * x))) if len(x) else math.nan


def replay_log(log: FlightLog, vehicle: VehicleSpec, base: VehicleSpec | None, *,
               window_s: float = WINDOW_S) -> ReplayResult:
    """Replay ``log`` through ``vehicle`` (and ``base``) and score them and the log-mean baseline."""
    s = make_samples(log)
    wins = _windows(s, window_s)
    if not wins:
        raise InputError(f"no airborne stretch of {0.5 * window_s:g} s or more to replay", path=log.info.path)
    h = 0.5 * float(np.median(np.diff(s.t_s)))
    pos = np.column_stack([np.interp(s.t_s, log.position.t_s, log.position.pos_enu[:, k]) for k in range(3)])
    in_win = np.zeros(len(s.t_s), bool)
    for i, j in wins:
        in_win[i:j + 1] = True
    hov = s.hover()
    offset = np.nanmean(s.f_body[hov, :2], axis=0) if hov.sum() >= 3 else np.zeros(2)
    f_log = s.f_body.copy()
    f_log[:, :2] -= offset
    ends = np.array([j for _, j in wins])
    starts = np.array([i for i, _ in wins])
    dur = s.t_s[ends] - s.t_s[starts]
    span = s.span()
    series: dict[str, Any] = {"t_s": s.t_s, "f_log": f_log, "gyro_log": s.gyro_body, "in_window": in_win,
                              "windows": [(float(s.t_s[i]), float(s.t_s[j])) for i, j in wins]}
    errors: dict[str, dict[str, Any]] = {}
    cands = {"vehicle": vehicle, **({"base_unfitted": base} if base is not None else {})}
    for name, spec in cands.items():
        model = VehicleReplay(spec)
        f_m, w_m, v_end = _fly_windows(model, s, log, pos, wins, h)
        e = _flight_errors(f_m, w_m, f_log, s, in_win, v_end - s.vel_enu[ends])
        e.update(_battery_errors(model, log, s, span, series, name))
        errors[name] = e
        series[name] = {"f": f_m, "gyro": w_m, "v_end_error": v_end - s.vel_enu[ends]}
    acc_mean = np.nanmean((s.vel_enu[ends] - s.vel_enu[starts]) / dur[:, None], axis=0)
    f_mean = np.nanmean(f_log[in_win], axis=0)
    w_mean = np.nanmean(s.gyro_body[in_win], axis=0)
    v_mean_err = s.vel_enu[starts] + acc_mean * dur[:, None] - s.vel_enu[ends]
    e = _flight_errors(np.broadcast_to(f_mean, f_log.shape).copy(), np.broadcast_to(w_mean, f_log.shape).copy(),
                       f_log, s, in_win, v_mean_err)
    e.update(_mean_battery_errors(log, span))
    errors["log_mean"] = e
    series["log_mean"] = {"v_end_error": v_mean_err}
    notes = (f"the IMU's steady in-plane offset ({offset[0]:+.2f}, {offset[1]:+.2f}) m/s², measured over "
             f"{int(hov.sum())} hover samples, is removed from the log's specific force before comparing",)
    return ReplayResult(errors=errors, windows=series["windows"], series=series,
                        imu_offset_xy=(float(offset[0]), float(offset[1])), span_s=span, notes=notes + s.notes)


def _flight_errors(f_m: np.ndarray, w_m: np.ndarray, f_log: np.ndarray, s: FlightSamples, in_win: np.ndarray,
                   dv: np.ndarray) -> dict[str, Any]:
    d = (f_m - f_log)[in_win]
    return {"accel_rms_mps2": _rms(d), "accel_rms_xyz_mps2": [_rms(d[:, k]) for k in range(3)],
            "gyro_rms_radps": _rms((w_m - s.gyro_body)[in_win]), "velocity_rms_mps": _rms(dv),
            "velocity_rms_xyz_mps": [_rms(dv[:, k]) for k in range(3)]}


def _cumulative_wh(t: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Energy since ``t[0]`` at each time, Wh (trapezoid)."""
    return np.concatenate(([0.0], np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(t)))) / 3600.0 if len(t) else t


def _energy_scores(t: np.ndarray, e_model: np.ndarray, e_log: np.ndarray) -> dict[str, Any]:
    """The energy-over-the-flight errors of a predicted cumulative energy ``e_model`` against the log's
    ``e_log`` at the battery samples ``t``, both Wh from the span's start."""
    tot = float(e_log[-1]) if len(e_log) else math.nan
    if not tot > 0:
        return {"energy_error_fraction": math.nan}
    d = e_model - e_log
    return {"energy_error_fraction": float(np.sqrt(np.mean(d * d)) / tot),
            "energy_max_error_fraction": float(np.max(np.abs(d)) / tot),
            "energy_total_error_fraction": float(d[-1] / tot), "energy_log_wh": tot, "energy_model_wh": float(e_model[-1])}


def _log_track(log: FlightLog, span: tuple[float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Battery samples in ``span`` with a current: (mask, times, the log's cumulative energy Wh)."""
    bt = log.battery
    assert bt is not None
    bm = (bt.t_s >= span[0]) & (bt.t_s <= span[1]) & np.isfinite(bt.current_a)
    return bm, bt.t_s[bm], _cumulative_wh(bt.t_s[bm], (bt.voltage_v * bt.current_a)[bm])


def _battery_errors(model: VehicleReplay, log: FlightLog, s: FlightSamples, span: tuple[float, float],
                    series: dict[str, Any], name: str) -> dict[str, Any]:
    bt, spec = log.battery, model.vehicle.battery
    if bt is None or spec is None or not np.isfinite(bt.current_a).any():
        return {"voltage_rms_v": math.nan, "energy_error_fraction": math.nan}
    m = (s.t_s >= span[0]) & (s.t_s <= span[1])
    bm = (bt.t_s >= span[0]) & (bt.t_s <= span[1]) & np.isfinite(bt.current_a)
    pack = Battery(spec)
    first = np.flatnonzero(bm)[:3]
    e0 = float(np.mean(bt.voltage_v[first] + bt.current_a[first] * pack.r_ohm))
    soc0 = soc_at_ocv(pack, e0 / spec.cells)
    volts, loads, ts = model.battery_run(s.t_s[m], s.u[m], s.running[m], soc0, bt.t_s[bm])
    _, tb, e_log = _log_track(log, span)
    e_model = np.interp(tb, np.concatenate(([ts[0]], ts + BATTERY_DT)),
                        np.concatenate(([0.0], np.cumsum(loads) * BATTERY_DT / 3600.0)))
    e_model -= e_model[0]  # from the first battery sample, as the log's
    series[f"{name}_battery"] = {"t_s": tb, "voltage_v": volts, "energy_wh": e_model}
    out = {"voltage_rms_v": _rms(volts - bt.voltage_v[bm]), "soc_start": soc0}
    out.update(_energy_scores(tb, e_model, e_log))
    return out


def _mean_battery_errors(log: FlightLog, span: tuple[float, float]) -> dict[str, Any]:
    bt = log.battery
    if bt is None or not np.isfinite(bt.current_a).any():
        return {"voltage_rms_v": math.nan, "energy_error_fraction": math.nan}
    bm, tb, e_log = _log_track(log, span)
    p_mean = e_log[-1] * 3600.0 / (tb[-1] - tb[0]) if len(tb) > 1 else math.nan
    out = {"voltage_rms_v": _rms(bt.voltage_v[bm] - np.mean(bt.voltage_v[bm]))}
    out.update(_energy_scores(tb, p_mean * (tb - tb[0]) / 3600.0, e_log))
    return out
