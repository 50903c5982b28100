"""Write a :class:`FlightLog` as an ArduPilot DataFlash binary log (``.bin``): each message is ``0xA3 0x95``,
its type id and the fields packed little-endian as its ``FMT`` message declares (``FMT`` itself is type 128,
``BBnNZ``). The messages are the ones ArduCopter 4.x writes and :mod:`~vinecli.flightlog.dataflash` reads,
with their field names and units: ``PARM``, ``MSG``, ``RCOU`` (PWM µs), ``IMU`` (instance 0, FRD),
``ATT`` (degrees), ``XKF1`` (EKF3 core 0, NED m and m/s), ``BAT`` (V, A), ``EV`` (armed / disarmed /
landed / not landed) and ``GPS`` (week and milliseconds), all time-stamped ``TimeUS`` since boot.
"""

from __future__ import annotations

import math
import struct
from pathlib import Path

import numpy as np

from vinecli.flightlog.flight_log import FlightLog
from vinecli.frames import attitude_enu_flu_to_ned_frd, enu_to_ned, flu_to_frd, quat_to_euler

__all__ = ["write_dataflash"]

HEAD = b"\xa3\x95"
BOOT_US = 10_000_000
#: name -> (type id, DataFlash format, columns)
MESSAGES = {
    "FMT": (128, "BBnNZ", "Type,Length,Name,Format,Columns"),
    "PARM": (129, "QNf", "TimeUS,Name,Value"),
    "MSG": (130, "QZ", "TimeUS,Message"),
    "RCOU": (131, "Q" + "H" * 14, "TimeUS," + ",".join(f"C{i}" for i in range(1, 15))),
    "IMU": (132, "QBffffff", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ"),
    "ATT": (133, "Qffffff", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw"),
    "XKF1": (134, "QBffffff", "TimeUS,C,VN,VE,VD,PN,PE,PD"),
    "BAT": (135, "QBff", "TimeUS,Inst,Volt,Curr"),
    "EV": (136, "QB", "TimeUS,Id"),
    "GPS": (137, "QBIH", "TimeUS,Status,GMS,GWk"),
}
STRUCT = {"B": "B", "H": "H", "I": "I", "Q": "Q", "f": "f", "n": "4s", "N": "16s", "Z": "64s"}
EV_ARMED, EV_DISARMED, EV_LAND_COMPLETE, EV_NOT_LANDED = 10, 11, 18, 28


def _pack(name: str, *vals: object) -> bytes:
    tid, fmt, _ = MESSAGES[name]
    fields = [v.encode() if isinstance(v, str) else v for v in vals]
    return HEAD + bytes([tid]) + struct.pack("<" + "".join(STRUCT[c] for c in fmt), *fields)


def _fmt_messages() -> bytes:
    out = b""
    for name, (tid, fmt, cols) in MESSAGES.items():
        length = 3 + struct.calcsize("<" + "".join(STRUCT[c] for c in fmt))
        out += _pack("FMT", tid, length, name, fmt, cols)
    return out


def _stream(log: FlightLog, t0: float) -> list[tuple[float, int, bytes]]:
    """Every timed message as (time s, order, bytes)."""
    def us(t: float) -> int:
        return BOOT_US + int(round((t - t0) * 1e6))

    out: list[tuple[float, int, bytes]] = []
    for t, pwm in zip(log.motors.t_s, log.motors.pwm_us, strict=True):
        ch = [int(round(x)) for x in pwm][:14] + [0] * (14 - min(len(pwm), 14))
        out.append((t, 1, _pack("RCOU", us(t), *ch)))
    for t, a, g in zip(log.imu.t_s, log.imu.accel_flu, log.imu.gyro_flu, strict=True):
        out.append((t, 2, _pack("IMU", us(t), 0, *flu_to_frd(tuple(g)), *flu_to_frd(tuple(a)))))  # type: ignore[arg-type]
    for t, q in zip(log.attitude.t_s, log.attitude.quat_xyzw, strict=True):
        r, p, y = (math.degrees(a) for a in quat_to_euler(attitude_enu_flu_to_ned_frd(tuple(q))))  # type: ignore[arg-type]
        out.append((t, 3, _pack("ATT", us(t), r, r, p, p, y % 360.0, y % 360.0)))
    for t, pos, vel in zip(log.position.t_s, log.position.pos_enu, log.position.vel_enu, strict=True):
        out.append((t, 4, _pack("XKF1", us(t), 0, *enu_to_ned(tuple(vel)), *enu_to_ned(tuple(pos)))))  # type: ignore[arg-type]
    if log.battery is not None:
        b = log.battery
        for t, v, i in zip(b.t_s, b.voltage_v, b.current_a, strict=True):
            out.append((t, 5, _pack("BAT", us(t), 0, float(v), float(i) if np.isfinite(i) else 0.0)))
    s = log.state
    for k, t in enumerate(s.t_s):
        if k == 0 or s.armed[k] != s.armed[k - 1]:
            out.append((t, 0, _pack("EV", us(t), EV_ARMED if s.armed[k] else EV_DISARMED)))
        if k == 0 or s.landed[k] != s.landed[k - 1]:
            out.append((t, 0, _pack("EV", us(t), EV_LAND_COMPLETE if s.landed[k] else EV_NOT_LANDED)))
    return out


def write_dataflash(log: FlightLog, path: str | Path, *, firmware: str = "ArduCopter V4.5.0 (vinecli simulation)",
                    frame: str = "QUAD", params: dict[str, float] | None = None, gps_week: int = 2300) -> Path:
    """Write ``log`` to ``path``; ``params`` default to the ArduPilot names of the log's configuration
    (MOT_PWM_MIN/MAX, FRAME_CLASS, MOT_BAT_VOLT_MAX from the cells)."""
    path = Path(path)
    cfg = log.config
    if params is None:
        params = {"MOT_PWM_MIN": cfg.pwm_min_us, "MOT_PWM_MAX": cfg.pwm_max_us, "RC3_MIN": cfg.pwm_min_us,
                  "RC3_MAX": cfg.pwm_max_us, "FRAME_CLASS": {4: 1.0, 6: 2.0, 8: 3.0}.get(cfg.n_motors, 1.0),
                  "MOT_THST_EXPO": 0.0}
        if cfg.cells:
            params["MOT_BAT_VOLT_MAX"] = 4.2 * cfg.cells
    t0 = min(float(log.motors.t_s[0]), float(log.imu.t_s[0]))
    out = bytearray(_fmt_messages())
    out += _pack("MSG", BOOT_US, firmware) + _pack("MSG", BOOT_US, f"Frame: {frame}")
    for k, v in params.items():
        out += _pack("PARM", BOOT_US, k[:16], float(v))
    out += _pack("GPS", BOOT_US, 3, 100_000_000, gps_week)
    for _, _, msg in sorted(_stream(log, t0), key=lambda m: (m[0], m[1])):
        out += msg
    path.write_bytes(bytes(out))
    return path
