"""A small made-up flight log (not a physical flight) for reader, writer and bad-log tests: 30 s, armed
2-28 s, airborne 3-27 s at 5 m on a circle, every stream with its own rate and distinct values."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from vinecli.flightlog.flight_log import (
    Attitude,
    BatteryLog,
    FlightLog,
    Imu,
    LocalPosition,
    LogConfig,
    LogInfo,
    Motors,
    StateLog,
)
from vinecli.frames import quat_from_euler


def synthetic_log(n_motors: int = 4, *, airborne: bool = True, duration_s: float = 30.0) -> FlightLog:
    tm = np.round(np.arange(0.0, duration_s, 0.1), 6)
    armed_m = (tm >= 2.0) & (tm < duration_s - 2.0)
    u = 0.5 + 0.05 * np.sin(tm[:, None] + np.arange(n_motors)[None, :])
    pwm = np.where(armed_m[:, None], 1000.0 + 1000.0 * u, 900.0)
    motors = Motors(tm, pwm, np.where(armed_m[:, None], u, np.nan))
    ti = np.round(np.arange(0.0, duration_s, 0.01), 6)
    acc = np.column_stack([0.1 * np.sin(ti), 0.05 * np.cos(ti), 9.8 + 0.3 * np.sin(2 * ti)])
    gyr = np.column_stack([0.01 * np.sin(3 * ti), -0.02 * np.cos(ti), 0.1 + 0 * ti])
    ta = np.round(np.arange(0.0, duration_s, 0.05), 6)
    quat = np.array([quat_from_euler(0.05 * np.sin(t), -0.04 * np.cos(t), 0.1 * t - 1.0) for t in ta])
    tp = tm
    z = np.where((tp > 3.0) & (tp < duration_s - 3.0) & airborne, 5.0, 0.0)
    pos = np.column_stack([3.0 * np.cos(0.2 * tp), 3.0 * np.sin(0.2 * tp), z])
    vel = np.column_stack([-0.6 * np.sin(0.2 * tp), 0.6 * np.cos(0.2 * tp), 0.0 * tp])
    tb = np.round(np.arange(0.0, duration_s, 0.2), 6)
    cur = np.where((tb >= 2.0) & (tb < duration_s - 2.0), 10.0 + 2.0 * np.sin(tb), 0.5)
    bat = BatteryLog(tb, 16.4 - 0.01 * tb - 0.05 * cur, cur)
    ts = np.array([0.0, 2.0, 3.0, duration_s - 3.0, duration_s - 2.0])
    armed = np.array([False, True, True, True, False])
    landed = np.array([True, True, not airborne, True, True])
    cfg = LogConfig(n_motors=n_motors, pwm_min_us=1000.0, pwm_max_us=2000.0, pwm_disarmed_us=900.0,
                    frame=f"synthetic, {n_motors} motors", cells=4)
    info = LogInfo(path="synthetic", format="sim", firmware="test", hardware="test", date_utc=None,
                   duration_s=duration_s, sha256="")
    params = {"PWM_MAIN_MIN": 1000.0, "PWM_MAIN_MAX": 2000.0, "PWM_MAIN_DISARM": 900.0,
              "MAV_TYPE": {4: 2.0, 6: 13.0, 8: 14.0}[n_motors], "BAT1_N_CELLS": 4.0}
    return FlightLog(info, cfg, motors, Imu(ti, acc, gyr), Attitude(ta, quat), LocalPosition(tp, pos, vel), bat,
                     StateLog(ts, armed, landed), params)


def cut(log: FlightLog, t0: float, t1: float) -> FlightLog:
    """``log`` without its motor-output and IMU samples in [t0, t1) (a logger dropout)."""
    m = (log.motors.t_s < t0) | (log.motors.t_s >= t1)
    i = (log.imu.t_s < t0) | (log.imu.t_s >= t1)
    return replace(log, motors=replace(log.motors, t_s=log.motors.t_s[m], pwm_us=log.motors.pwm_us[m], u=log.motors.u[m]),
                   imu=replace(log.imu, t_s=log.imu.t_s[i], accel_flu=log.imu.accel_flu[i], gyro_flu=log.imu.gyro_flu[i]))
