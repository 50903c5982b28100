"""PX4 ULog (``.ulg``) -> :class:`~vinecli.flightlog.flight_log.FlightLog`, read with pyulog.

Topics: ``actuator_outputs`` (the instance driving the motors, PWM µs), ``sensor_combined`` (IMU, FRD),
``vehicle_attitude`` (q NED<-FRD, w first), ``vehicle_local_position`` (NED), ``battery_status``,
``actuator_armed`` (or ``vehicle_status``), ``vehicle_land_detected``. Parameters: the output range
(PWM_MAIN_MIN/MAX or, with control allocation, PWM_MAIN_MINn/MAXn of the outputs whose PWM_MAIN_FUNCn is
a motor), the motor count (CA_ROTOR_COUNT or MAV_TYPE), BAT1_N_CELLS/BAT_N_CELLS, BAT1_CAPACITY,
MPC_THR_HOVER (and the ``hover_thrust_estimate`` topic), THR_MDL_FAC.
"""

from __future__ import annotations

import contextlib
import io
from collections.abc import Callable
from datetime import UTC, datetime

import numpy as np

from vinecli.errors import InputError
from vinecli.flightlog.arrays import (
    attitude_from_quat_ned,
    frd_to_flu_array,
    ned_to_enu_array,
    normalise_outputs,
    require,
    sorted_stream,
)
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
    gaps_of,
    merged_gaps,
)

__all__ = ["read_ulog"]

TOPICS = ["actuator_outputs", "sensor_combined", "vehicle_attitude", "vehicle_local_position", "battery_status",
          "actuator_armed", "vehicle_status", "vehicle_land_detected", "hover_thrust_estimate",
          "vehicle_gps_position", "sensor_gps"]
#: MAV_TYPE -> rotors (quad, hexa, octo, tri, helicopter-less multicopters only)
MAV_TYPE_ROTORS = {2: 4, 13: 6, 14: 8, 15: 3}
#: PX4 release types in ver_sw_release's low byte
RELEASE_TYPE = {255: "", 192: "rc", 128: "beta", 64: "alpha"}


def read_ulog(path: str, sha256: str) -> FlightLog:
    """Read a ULog; InputError naming the file and what is missing when it cannot be used."""
    notes = io.StringIO()
    try:
        with contextlib.redirect_stdout(notes):  # pyulog prints its warnings
            from pyulog import ULog

            ulog = ULog(path, TOPICS)
    except Exception as exc:  # noqa: BLE001 - pyulog raises many kinds on a corrupt file
        raise InputError(f"not a readable ULog ({type(exc).__name__}: {exc})", path=path) from None
    require(bool(ulog.data_list), path, "the ULog holds no logged data (truncated before its data section?)")
    t0 = int(ulog.start_timestamp)
    topics: dict[tuple[str, int], dict[str, np.ndarray]] = {(d.name, d.multi_id): d.data for d in ulog.data_list}
    params = {str(k): float(v) for k, v in ulog.initial_parameters.items()}
    config, chans = _config(params, topics, path, ulog.file_corruption)

    def secs(d: dict[str, np.ndarray]) -> np.ndarray:
        ts = d["timestamp"].astype(np.int64)  # a state published before logging started has timestamp 0
        return np.maximum(ts - t0, 0).astype(float) * 1e-6

    motors = _motors(topics, config, chans, secs, path)
    sc = _topic(topics, "sensor_combined", path, "IMU (sensor_combined)")
    t, acc, gyr = sorted_stream(secs(sc), _vec(sc, "accelerometer_m_s2[{}]"), _vec(sc, "gyro_rad[{}]"))
    imu = Imu(t, frd_to_flu_array(acc), frd_to_flu_array(gyr))
    va = _topic(topics, "vehicle_attitude", path, "attitude (vehicle_attitude)")
    t, q = sorted_stream(secs(va), _vec(va, "q[{}]", 4))
    attitude = Attitude(t, attitude_from_quat_ned(q))
    lp = _topic(topics, "vehicle_local_position", path, "local position (vehicle_local_position)")
    pos = np.column_stack([lp["x"], lp["y"], lp["z"]])
    vel = np.column_stack([lp["vx"], lp["vy"], lp["vz"]])
    t, pos, vel = sorted_stream(secs(lp), pos, vel)
    position = LocalPosition(t, ned_to_enu_array(pos), ned_to_enu_array(vel))
    battery = None
    bs = topics.get(("battery_status", 0))
    if bs is not None and np.any(bs["voltage_v"] > 0.5):
        cur = np.where(bs["current_a"] >= 0.0, bs["current_a"], np.nan)  # -1: not measured
        t, v, i = sorted_stream(secs(bs), bs["voltage_v"].astype(float), cur.astype(float))
        ok = v > 0.5
        battery = BatteryLog(t[ok], v[ok], i[ok])
    state = _state(topics, secs, motors)
    info_d = ulog.msg_info_dict
    version = None
    ver = ulog.get_version_info()
    if ver is not None:
        kind = RELEASE_TYPE.get(ver[3], "dev")
        version = f"{ver[0]}.{ver[1]}.{ver[2]}{'-' + kind if kind else ''}"
    sw = str(info_d.get("ver_sw", ""))
    parts = [str(info_d.get("sys_name", "PX4")), version, f"({info_d['ver_sw_branch']})" if info_d.get("ver_sw_branch")
             else None, (sw[:8] if version else sw) or None]
    firmware = " ".join(p for p in parts if p)
    end = max(float(s.t_s[-1]) for s in (motors, imu, attitude, position) if len(s.t_s))
    info = LogInfo(path=path, format="ulog", firmware=firmware, hardware=str(info_d.get("ver_hw", "?")),
                   date_utc=_date(topics, info_d), duration_s=end, sha256=sha256)
    gaps = merged_gaps(gaps_of(motors.t_s), gaps_of(imu.t_s, min_s=0.2))
    return FlightLog(info, config, motors, imu, attitude, position, battery, state, params, gaps)


def _topic(topics: dict[tuple[str, int], dict[str, np.ndarray]], name: str, path: str, what: str) -> dict[str, np.ndarray]:
    d = topics.get((name, 0))
    require(d is not None and len(d["timestamp"]) >= 2, path, f"no {what} in the log")
    assert d is not None
    return d


def _vec(d: dict[str, np.ndarray], pattern: str, n: int = 3) -> np.ndarray:
    return np.column_stack([d[pattern.format(i)].astype(float) for i in range(n)])


def _motor_channels(params: dict[str, float], n_guess: int) -> tuple[list[int], float, float, float]:
    """(output channels of motors 1..n, PWM min, max, disarmed) from the parameters."""
    funcs = {int(v) - 101: int(k[len("PWM_MAIN_FUNC"):]) - 1 for k, v in params.items()
             if k.startswith("PWM_MAIN_FUNC") and 101 <= v <= 112}
    if funcs:  # control allocation (PX4 >= 1.13): PWM_MAIN_FUNCn = 101 + motor index
        chans = [funcs[m] for m in sorted(funcs)]
        c = chans[0] + 1
        return (chans, params.get(f"PWM_MAIN_MIN{c}", 1000.0), params.get(f"PWM_MAIN_MAX{c}", 2000.0),
                params.get(f"PWM_MAIN_DIS{c}", 900.0))
    lo = params.get("PWM_MAIN_MIN", params.get("PWM_MIN", 1000.0))
    hi = params.get("PWM_MAIN_MAX", params.get("PWM_MAX", 2000.0))
    dis = params.get("PWM_MAIN_DISARM", params.get("PWM_DISARMED", 900.0))
    return list(range(n_guess)), lo, hi, dis


def _config(params: dict[str, float], topics: dict[tuple[str, int], dict[str, np.ndarray]], path: str,
            corrupt: bool) -> tuple[LogConfig, list[int]]:
    """The log's configuration and the output channels of motors 1..n."""
    mav_type = int(params.get("MAV_TYPE", 2))
    n = int(params.get("CA_ROTOR_COUNT", 0)) or MAV_TYPE_ROTORS.get(mav_type, 0)
    require(n > 0, path, f"unsupported vehicle: MAV_TYPE {mav_type} is not a multicopter vinecli can fit")
    chans, lo, hi, dis = _motor_channels(params, n)
    require(hi > lo, path, f"unusable PWM output range {lo:g}..{hi:g} µs in the parameters")
    cells = next((int(params[k]) for k in ("BAT1_N_CELLS", "BAT_N_CELLS") if params.get(k, 0) > 0), None)
    cap = next((params[k] for k in ("BAT1_CAPACITY", "BAT_CAPACITY") if params.get(k, -1) > 0), None)
    hover, hover_src = params.get("MPC_THR_HOVER"), "MPC_THR_HOVER"
    hte = topics.get(("hover_thrust_estimate", 0))
    if hte is not None and np.any(hte["valid"] > 0):
        hover, hover_src = float(np.median(hte["hover_thrust"][hte["valid"] > 0])), "hover_thrust_estimate (median)"
    notes = ("pyulog found corrupt data and skipped it (read up to the last intact message)",) if corrupt else ()
    autostart = int(params.get("SYS_AUTOSTART", 0))
    config = LogConfig(
        n_motors=len(chans), pwm_min_us=lo, pwm_max_us=hi, pwm_disarmed_us=dis,
        frame=f"PX4 SYS_AUTOSTART {autostart}, {len(chans)} motors (MAV_TYPE {mav_type})", cells=cells,
        capacity_mah=cap, hover_throttle=hover, hover_throttle_source=hover_src if hover is not None else "",
        thrust_expo=params.get("THR_MDL_FAC"), thrust_expo_source="THR_MDL_FAC" if "THR_MDL_FAC" in params else "",
        notes=notes)
    return config, chans


Topics = dict[tuple[str, int], dict[str, np.ndarray]]


def _motors(topics: Topics, config: LogConfig, chans: list[int], secs: Callable[[dict[str, np.ndarray]], np.ndarray],
            path: str) -> Motors:
    """The ``actuator_outputs`` instance whose motor channels carry PWM in the configured range."""
    best: tuple[float, dict[str, np.ndarray]] | None = None
    for (name, _), d in topics.items():
        if name != "actuator_outputs" or not all(f"output[{c}]" in d for c in chans):
            continue
        pwm = np.column_stack([d[f"output[{c}]"].astype(float) for c in chans])
        in_range = (pwm >= config.pwm_min_us - 50.0) & (pwm <= config.pwm_max_us + 50.0)
        score = float(in_range.mean() + np.nan_to_num(np.nanstd(pwm, axis=0)).mean() * 1e-6)
        if best is None or score > best[0]:
            best = (score, d)
    require(best is not None and best[0] > 0.05, path,
            f"no motor outputs (actuator_outputs with {len(chans)} channels in "
            f"{config.pwm_min_us:g}..{config.pwm_max_us:g} µs) in the log")
    assert best is not None
    d = best[1]
    t, pwm = sorted_stream(secs(d), np.column_stack([d[f"output[{c}]"].astype(float) for c in chans]))
    require(len(t) >= 2 and bool(np.all(np.isfinite(pwm))), path, "motor outputs are not finite numbers")
    return Motors(t, pwm, normalise_outputs(pwm, config.pwm_min_us, config.pwm_max_us, config.pwm_disarmed_us))


def _state(topics: Topics, secs: Callable[[dict[str, np.ndarray]], np.ndarray], motors: Motors) -> StateLog:
    """Armed (actuator_armed, else vehicle_status, else spinning motors) and landed (vehicle_land_detected)."""
    aa, vs, ld = topics.get(("actuator_armed", 0)), topics.get(("vehicle_status", 0)), topics.get(("vehicle_land_detected", 0))
    if aa is not None:
        ta, armed = sorted_stream(secs(aa), aa["armed"] > 0)
    elif vs is not None:
        ta, armed = sorted_stream(secs(vs), vs["arming_state"] == 2)
    else:
        ta, armed = motors.t_s, np.isfinite(motors.u).all(axis=1)
    if ld is not None:
        tl, landed = sorted_stream(secs(ld), ld["landed"] > 0)
    else:  # no land detector: landed whenever disarmed
        tl, landed = ta, ~armed
    t = np.union1d(ta, tl)
    ia = np.clip(np.searchsorted(ta, t, side="right") - 1, 0, len(ta) - 1)
    il = np.clip(np.searchsorted(tl, t, side="right") - 1, 0, len(tl) - 1)
    return StateLog(t, armed[ia].astype(bool), landed[il].astype(bool))


def _date(topics: Topics, info: dict[str, object]) -> str | None:
    """UTC date and time of the first GNSS time stamp (ISO 8601), or None."""
    for name in ("vehicle_gps_position", "sensor_gps"):
        d = topics.get((name, 0))
        if d is not None and "time_utc_usec" in d:
            good = d["time_utc_usec"][d["time_utc_usec"] > 946684800_000000]  # after 2000-01-01
            if len(good):
                return datetime.fromtimestamp(int(good[0]) * 1e-6, UTC).isoformat(timespec="seconds")
    return None
