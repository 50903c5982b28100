"""ArduPilot DataFlash (``.bin``) -> :class:`~vinecli.flightlog.flight_log.FlightLog`, read with pymavlink's DFReader.

Messages: ``RCOU`` (motor PWM, ``C1..`` or ArduCopter 3.x ``Chan1..``), ``IMU`` (FRD, instance 0), ``ATT``
(roll, pitch, yaw in degrees, NED/FRD), the EKF's ``XKF1``/``NKF1``/``EKF1`` (PN PE PD VN VE VD, NED),
the battery's ``BAT`` (V, A) or ``CURR`` (ArduCopter 3.x: centivolts and centiamps), ``EV`` (10 armed,
11 disarmed, 18 land complete, 28 not landed), ``GPS`` (week and milliseconds: the date), ``MSG``
(firmware, board, frame). Parameters from ``PARM``: MOT_PWM_MIN/MAX (else RC3_MIN/MAX), FRAME_CLASS,
BATT_CAPACITY, MOT_BAT_VOLT_MAX (cells), MOT_THST_HOVER or THR_MID, MOT_THST_EXPO (3.2's MOT_TCRV_* noted).
"""

from __future__ import annotations

import contextlib
import io
import math
from datetime import UTC, datetime, timedelta
from typing import Any

import numpy as np

from vinecli.errors import InputError
from vinecli.flightlog.arrays import (
    attitude_from_euler_ned,
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

__all__ = ["read_dataflash"]

TYPES = ["RCOU", "IMU", "ATT", "XKF1", "NKF1", "EKF1", "BAT", "CURR", "EV", "ARM", "GPS", "MSG", "VER"]
EKF_TYPES = ("XKF1", "NKF1", "EKF1")
#: FRAME_CLASS -> motors (1 quad, 2 hexa, 3 octa, 4 octaquad, 5 Y6, 12 dodecahexa, 14 deca)
FRAME_CLASS_MOTORS = {1: 4, 2: 6, 3: 8, 4: 8, 5: 6, 12: 12, 14: 10}
CLOCK_TYPES = ("IMU", "RCOU", "ATT")
EV_ARMED, EV_DISARMED, EV_LAND_COMPLETE, EV_NOT_LANDED = 10, 11, 18, 28
GPS_EPOCH = datetime(1980, 1, 6, tzinfo=UTC)
#: (first day, GPS - UTC seconds) of the leap seconds since 2009
LEAP_SECONDS = ((datetime(2009, 1, 1, tzinfo=UTC), 15), (datetime(2012, 7, 1, tzinfo=UTC), 16),
                (datetime(2015, 7, 1, tzinfo=UTC), 17), (datetime(2017, 1, 1, tzinfo=UTC), 18))

Rows = dict[str, list[dict[str, Any]]]
Formats = dict[str, tuple[str, list[str]]]


def read_dataflash(path: str, sha256: str) -> FlightLog:
    """Read a DataFlash log; InputError naming the file and what is missing when it cannot be used."""
    rows, params, formats = _collect(path)
    t_all = [_times(rows[k]) for k in ("RCOU", "IMU") if rows.get(k)]
    require(bool(t_all) and all(len(t) for t in t_all), path, "no motor outputs (RCOU) or IMU in the log")
    t0 = min(float(t[0]) for t in t_all)

    def secs(name: str) -> np.ndarray:
        return _times(rows[name]) - t0

    config, chans = _config(params, rows, path)
    require(bool(rows.get("RCOU")), path, "no motor outputs (RCOU) in the log")
    t, pwm = sorted_stream(secs("RCOU"), np.array([[r.get(c, np.nan) for c in chans] for r in rows["RCOU"]], float))
    require(bool(np.all(np.isfinite(pwm))), path, "motor outputs (RCOU) are not finite numbers")
    motors = Motors(t, pwm, normalise_outputs(pwm, config.pwm_min_us, config.pwm_max_us, config.pwm_disarmed_us))
    imu_rows = [r for r in rows.get("IMU", []) if r.get("I", 0) == 0]
    require(len(imu_rows) >= 2, path, "no IMU samples in the log")
    t, acc, gyr = sorted_stream(_times(imu_rows) - t0, _cols(imu_rows, "AccX", "AccY", "AccZ"),
                                _cols(imu_rows, "GyrX", "GyrY", "GyrZ"))
    imu = Imu(t, frd_to_flu_array(acc), frd_to_flu_array(gyr))
    require(len(rows.get("ATT", [])) >= 2, path, "no attitude (ATT) in the log")
    t, rpy = sorted_stream(secs("ATT"), np.radians(_cols(rows["ATT"], "Roll", "Pitch", "Yaw")))
    attitude = Attitude(t, attitude_from_euler_ned(rpy[:, 0], rpy[:, 1], rpy[:, 2]))
    ekf = next((k for k in EKF_TYPES if len(rows.get(k, [])) >= 2), None)
    require(ekf is not None, path, f"no local position and velocity ({'/'.join(EKF_TYPES)}) in the log")
    assert ekf is not None
    ekf_rows = [r for r in rows[ekf] if r.get("C", 0) == 0]
    t, pos, vel = sorted_stream(_times(ekf_rows) - t0, _cols(ekf_rows, "PN", "PE", "PD"), _cols(ekf_rows, "VN", "VE", "VD"))
    position = LocalPosition(t, ned_to_enu_array(pos), ned_to_enu_array(vel))
    battery = _battery(rows, formats, t0)
    state = _state(rows, t0, motors, position)
    msgs = [str(r.get("Message", "")) for r in rows.get("MSG", [])]
    firmware = next((m for m in msgs if m.startswith(("Ardu", "APM"))), "ArduPilot (version not logged)")
    hardware = next((m.split()[0] for m in msgs if m.startswith(("PX4v", "Pixhawk", "Cube", "fmuv", "CubeOrange"))), "?")
    end = max(float(s.t_s[-1]) for s in (motors, imu, attitude, position))
    info = LogInfo(path=path, format="dataflash", firmware=firmware, hardware=hardware, date_utc=_date(rows),
                   duration_s=end, sha256=sha256)
    gaps = merged_gaps(gaps_of(motors.t_s), gaps_of(imu.t_s, min_s=0.2))
    return FlightLog(info, config, motors, imu, attitude, position, battery, state, params, gaps)


def _collect(path: str) -> tuple[Rows, dict[str, float], Formats]:
    """Every message of :data:`TYPES` as a dict with its boot time ``_t`` (s), the parameters, and each
    type's format string and columns. Messages without a time of their own (ArduCopter 3.x ``EV``, ``MSG``) get the
    time of the last IMU, RCOU or ATT message before them (the first one's when none came before)."""
    from pymavlink import DFReader

    rows: Rows = {k: [] for k in TYPES}
    last_t = math.nan
    early: list[dict[str, Any]] = []  # untimed messages before the first clock: at its time
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            reader = DFReader.DFReader_binary(path, zero_time_base=False)
            while (m := reader.recv_match(type=TYPES)) is not None:
                kind = m.get_type()
                r = m.to_dict()
                t = _boot_time(kind, r)
                if kind in CLOCK_TYPES and math.isfinite(t):
                    last_t = t
                    for e in early:
                        e["_t"] = t
                    early.clear()
                r["_t"] = t if math.isfinite(t) else last_t
                if not math.isfinite(r["_t"]):
                    early.append(r)
                rows[kind].append(r)
    except Exception as exc:  # noqa: BLE001 - DFReader raises many kinds on a corrupt file
        raise InputError(f"not a readable DataFlash log ({type(exc).__name__}: {exc})", path=path) from None
    formats = {f.name: (f.format, list(f.columns)) for f in reader.formats.values()}
    params = {str(k): float(v) for k, v in reader.params.items() if isinstance(v, int | float) and math.isfinite(v)}
    return rows, params, formats


def _boot_time(kind: str, r: dict[str, Any]) -> float:
    """Boot time of a message, s: TimeUS, or ArduCopter 3.x TimeMS (its GPS message: T; TimeMS is GPS time)."""
    if "TimeUS" in r:
        return float(r["TimeUS"]) * 1e-6
    if kind == "GPS" and "T" in r:
        return float(r["T"]) * 1e-3
    return float(r["TimeMS"]) * 1e-3 if "TimeMS" in r else math.nan


def _times(rows: list[dict[str, Any]]) -> np.ndarray:
    """Boot times of messages, s."""
    return np.array([r["_t"] for r in rows], float)


def _cols(rows: list[dict[str, Any]], *names: str) -> np.ndarray:
    return np.array([[r.get(n, np.nan) for n in names] for r in rows], float).reshape(-1, len(names))


def _config(params: dict[str, float], rows: Rows, path: str) -> tuple[LogConfig, list[str]]:
    """The log's configuration and the RCOU columns of motors 1..n."""
    rc = rows.get("RCOU") or [{}]
    prefix = "C" if "C1" in rc[0] else "Chan"
    if params.get("MOT_PWM_MIN", 0) > 0 and params.get("MOT_PWM_MAX", 0) > params.get("MOT_PWM_MIN", 0):
        lo, hi, src = params["MOT_PWM_MIN"], params["MOT_PWM_MAX"], "MOT_PWM_MIN/MAX"
    else:
        lo, hi, src = params.get("RC3_MIN", 1000.0), params.get("RC3_MAX", 2000.0), "RC3_MIN/MAX"
    require(hi > lo, path, f"unusable motor PWM range {lo:g}..{hi:g} µs ({src})")
    msgs = [str(r.get("Message", "")) for r in rows.get("MSG", [])]
    frame = next((m for m in msgs if m.startswith("Frame:")), "")
    n = FRAME_CLASS_MOTORS.get(int(params.get("FRAME_CLASS", -1)), 0)
    if not n and frame:
        n = {"QUAD": 4, "HEXA": 6, "OCTA": 8, "OCTA_QUAD": 8, "Y6": 6}.get(frame.split(":", 1)[1].strip().split()[0], 0)
    if not n:  # count the leading channels that carry motor PWM
        pwm = np.array([[r.get(f"{prefix}{c}", 0.0) for c in range(1, 9)] for r in rc], float)
        active = ((pwm >= lo - 50) & (pwm <= hi + 50)).mean(axis=0) > 0.5
        n = int(np.argmin(active)) if not active.all() else 8
    require(n >= 3, path, "unsupported vehicle: no multicopter frame (FRAME_CLASS, 'Frame:' message or RCOU motors)")
    notes = [f"motor PWM range from {src}"]
    if params.get("MOT_TCRV_ENABLE", 0) > 0:
        notes.append(f"ArduCopter 3.x thrust curve MOT_TCRV on (mid {params.get('MOT_TCRV_MIDPCT', 0):g} %, max "
                     f"{params.get('MOT_TCRV_MAXPCT', 0):g} %): RCOU is after it")
    if "MOT_THST_HOVER" in params:
        hover, hsrc = params["MOT_THST_HOVER"], "MOT_THST_HOVER"
    elif "THR_MID" in params:
        hover, hsrc = params["THR_MID"] / 1000.0, "THR_MID / 1000"
    else:
        hover, hsrc = None, ""
    cells = int(round(params["MOT_BAT_VOLT_MAX"] / 4.2)) if params.get("MOT_BAT_VOLT_MAX", 0) > 0 else None
    cap = params.get("BATT_CAPACITY") if params.get("BATT_CAPACITY", 0) > 0 else None
    frame_desc = f"ArduCopter {frame or 'FRAME_CLASS ' + str(int(params.get('FRAME_CLASS', -1)))}".strip()
    config = LogConfig(
        n_motors=n, pwm_min_us=lo, pwm_max_us=hi, pwm_disarmed_us=lo, frame=f"{frame_desc}, {n} motors",
        cells=cells, capacity_mah=cap, hover_throttle=hover, hover_throttle_source=hsrc,
        thrust_expo=params.get("MOT_THST_EXPO"), thrust_expo_source="MOT_THST_EXPO" if "MOT_THST_EXPO" in params else "",
        notes=tuple(notes))
    return config, [f"{prefix}{c}" for c in range(1, n + 1)]


def _battery(rows: Rows, formats: Formats, t0: float) -> BatteryLog | None:
    """BAT (V, A) or CURR (3.x: integer centivolts / centiamps, per its format string)."""
    for name in ("BAT", "CURR"):
        rs = [r for r in rows.get(name, []) if r.get("Inst", r.get("Instance", 0)) == 0]
        if len(rs) < 2 or "Volt" not in rs[0]:
            continue
        fmt, cols = formats.get(name, ("", []))
        scale = {c: (0.01 if c in cols and len(fmt) == len(cols) and fmt[cols.index(c)] in "hHiI" else 1.0)
                 for c in ("Volt", "Curr")}
        v = _cols(rs, "Volt")[:, 0] * scale["Volt"]
        i = _cols(rs, "Curr")[:, 0] * scale["Curr"] if "Curr" in rs[0] else np.full(len(rs), np.nan)
        t, v, i = sorted_stream(_times(rs) - t0, v, i)
        ok = v > 0.5
        if ok.sum() >= 2:
            return BatteryLog(t[ok], v[ok], i[ok])
    return None


def _state(rows: Rows, t0: float, motors: Motors, position: LocalPosition) -> StateLog:
    """Armed and landed from EV events (before the first: disarmed and landed). A log without them:
    armed while the motors run, landed while disarmed or within 0.3 m of the lowest height."""
    evs = [r for r in rows.get("EV", []) if r.get("Id") in (EV_ARMED, EV_DISARMED, EV_LAND_COMPLETE, EV_NOT_LANDED)]
    evs = [r for r in evs if math.isfinite(r["_t"])]
    if not evs:
        armed = np.isfinite(motors.u).all(axis=1)
        z = np.interp(motors.t_s, position.t_s, position.pos_enu[:, 2])
        return StateLog(motors.t_s.copy(), armed, ~armed | (z < float(np.min(z)) + 0.3))
    a_list, l_list = [False], [True]
    for r in evs:
        i = r["Id"]
        a_list.append(True if i == EV_ARMED else False if i == EV_DISARMED else a_list[-1])
        l_list.append(True if i == EV_LAND_COMPLETE else False if i == EV_NOT_LANDED else l_list[-1])
    t = np.concatenate(([-1.0], _times(evs) - t0))
    ts, a, lnd = sorted_stream(t, np.array(a_list), np.array(l_list))
    return StateLog(ts, a, lnd)


def _date(rows: Rows) -> str | None:
    """UTC date and time of the first GNSS fix with a week number (ISO 8601), or None."""
    for r in rows.get("GPS", []):
        week, ms = r.get("GWk", r.get("Week")), r.get("GMS", r.get("TimeMS") if "Week" in r else None)
        if week and ms and r.get("Status", 0) >= 3:
            gps = GPS_EPOCH + timedelta(weeks=int(week), milliseconds=float(ms))
            leap = max((s for d, s in LEAP_SECONDS if gps >= d), default=15)
            return (gps - timedelta(seconds=leap)).isoformat(timespec="seconds")
    return None
