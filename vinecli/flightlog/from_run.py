"""A simulated flight as the flight log a real one leaves: vinecli's time series -> :class:`FlightLog`.

Streams at the rates a real autopilot logs them: motor outputs as PWM snapshots at ``motor_rate_hz``
(10 Hz, PX4's default ``actuator_outputs`` rate) from the rotor speed commands through the vehicle's PX4
mapping ``u = (w_cmd - w_min) / (w_max - w_min)``, PWM = ``pwm_min + u (pwm_max - pwm_min)`` (disarmed:
``pwm_disarmed``); IMU (the simulated sensor's specific force and rates) and attitude at the record rate;
position and velocity at ``position_rate_hz``; battery terminal voltage and current at ``battery_rate_hz``.
The known-truth round trip writes this as a ULog and as DataFlash and fits it back.
"""

from __future__ import annotations

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
from vinecli.specs.vehicle import VehicleSpec

__all__ = ["flightlog_from_run", "PWM_RANGE"]

#: PWM of u = 0, u = 1 and disarmed, µs (PX4's PWM_MAIN_MIN / MAX / DISARM defaults)
PWM_RANGE = (1000.0, 2000.0, 900.0)


def _every(t: np.ndarray, rate_hz: float) -> np.ndarray:
    """Indices of the rows nearest to a ``rate_hz`` grid over ``t``."""
    grid = np.arange(t[0], t[-1], 1.0 / rate_hz)
    return np.unique(np.clip(np.searchsorted(t, grid), 0, len(t) - 1))


def flightlog_from_run(ts: dict[str, np.ndarray], vehicle: VehicleSpec, *, name: str = "simulated",
                       motor_rate_hz: float = 10.0, position_rate_hz: float = 10.0,
                       battery_rate_hz: float = 5.0) -> FlightLog:
    """The run's time series ``ts`` (vinecli's columns) as the log of a real flight (module docstring)."""
    t = np.asarray(ts["t_s"], dtype=float)
    n = vehicle.n_rotors
    lo, hi, dis = PWM_RANGE
    w_min, w_max = vehicle.px4.w_min_rad_s, vehicle.motor.w_max
    m = _every(t, motor_rate_hz)
    cmd = np.column_stack([ts[f"rotor{i}_cmd_radps"][m] for i in range(1, n + 1)])
    armed = ts["armed"] > 0.5
    u = np.clip((cmd - w_min) / (w_max - w_min), 0.0, 1.0)
    pwm = np.where(armed[m][:, None], lo + u * (hi - lo), dis)
    motors = Motors(t[m], pwm, np.where(armed[m][:, None], u, np.nan))
    imu = Imu(t, np.column_stack([ts[f"imu_accel_flu_{k}_mps2"] for k in "xyz"]),
              np.column_stack([ts[f"imu_gyro_flu_{k}_radps"] for k in "xyz"]))
    att = Attitude(t, np.column_stack([ts[f"quat_{k}"] for k in "xyzw"]))
    p = _every(t, position_rate_hz)
    pos = LocalPosition(t[p], np.column_stack([ts[f"pos_enu_{k}_m"][p] for k in "xyz"]),
                        np.column_stack([ts[f"vel_enu_{k}_mps"][p] for k in "xyz"]))
    battery = None
    if np.isfinite(ts.get("battery_voltage_v", np.array([np.nan]))).any():
        b = _every(t, battery_rate_hz)
        battery = BatteryLog(t[b], ts["battery_voltage_v"][b].astype(float), ts["battery_current_a"][b].astype(float))
    state = StateLog(t, armed, ts["on_ground"] > 0.5)
    cells = vehicle.battery.cells if vehicle.battery is not None else None
    config = LogConfig(n_motors=n, pwm_min_us=lo, pwm_max_us=hi, pwm_disarmed_us=dis,
                       frame=f"vinecli {vehicle.name}, {n} motors", cells=cells)
    info = LogInfo(path=name, format="sim", firmware="vinecli built-in autopilot", hardware="vinecli simulator",
                   date_utc=None, duration_s=float(t[-1] - t[0]), sha256="")
    params = {"PWM_MAIN_MIN": lo, "PWM_MAIN_MAX": hi, "PWM_MAIN_DISARM": dis,
              "MAV_TYPE": {4: 2.0, 6: 13.0, 8: 14.0}.get(n, 2.0), "THR_MDL_FAC": 0.0}
    if cells:
        params["BAT1_N_CELLS"] = float(cells)
    return FlightLog(info, config, motors, imu, att, pos, battery, state, params)
