"""Write a :class:`FlightLog` as a PX4 ULog (``.ulg``), following the ULog file format specification
(docs.px4.io, "ULog File Format", version 1): 16-byte header, a flag-bits message, formats, info and
parameter messages, then subscriptions and data messages in time order. Little-endian, packed.

The topics are the ones :mod:`~vinecli.flightlog.ulog` reads, with PX4's field names, in NED/FRD (through
:mod:`vinecli.frames`): ``actuator_outputs``, ``sensor_combined``, ``vehicle_attitude``,
``vehicle_local_position``, ``battery_status``, ``actuator_armed``, ``vehicle_land_detected``.
pyulog's own writer only re-serialises a parsed log, hence this one.
"""

from __future__ import annotations

import struct
from collections.abc import Collection
from pathlib import Path

import numpy as np

from vinecli.flightlog.flight_log import FlightLog
from vinecli.frames import attitude_enu_flu_to_ned_frd, enu_to_ned, flu_to_frd

__all__ = ["write_ulog"]

MAGIC = b"ULog\x01\x12\x35"
#: boot time of the first sample, µs (a real log starts some seconds after boot)
BOOT_US = 10_000_000
FORMATS = {
    "actuator_outputs": "uint64_t timestamp;uint32_t noutputs;float[16] output",
    "sensor_combined": "uint64_t timestamp;float[3] gyro_rad;float[3] accelerometer_m_s2",
    "vehicle_attitude": "uint64_t timestamp;float[4] q",
    "vehicle_local_position": "uint64_t timestamp;float x;float y;float z;float vx;float vy;float vz",
    "battery_status": "uint64_t timestamp;float voltage_v;float current_a",
    "actuator_armed": "uint64_t timestamp;bool armed",
    "vehicle_land_detected": "uint64_t timestamp;bool landed",
}
PACK = {"actuator_outputs": "<QI16f", "sensor_combined": "<Q3f3f", "vehicle_attitude": "<Q4f",
        "vehicle_local_position": "<Q6f", "battery_status": "<Q2f", "actuator_armed": "<Q?",
        "vehicle_land_detected": "<Q?"}
#: parameters PX4 stores as float even when the value is whole
FLOAT_PARAMS = {"THR_MDL_FAC", "MPC_THR_HOVER", "BAT1_CAPACITY", "BAT_CAPACITY", "BAT1_V_CHARGED", "BAT1_V_EMPTY"}


def _msg(kind: bytes, body: bytes) -> bytes:
    return struct.pack("<HB", len(body), kind[0]) + body


def _key_value(key: str, value: bytes) -> bytes:
    k = key.encode()
    return struct.pack("<B", len(k)) + k + value


def _rows(log: FlightLog) -> dict[str, list[tuple[float, tuple[float | bool, ...]]]]:
    """(time s, fields after the timestamp) per topic, in PX4's frames and units."""
    rows: dict[str, list[tuple[float, tuple[float | bool, ...]]]] = {k: [] for k in FORMATS}
    m = log.motors
    for t, pwm in zip(m.t_s, m.pwm_us, strict=True):
        out = [0.0] * 16
        out[:len(pwm)] = [float(x) for x in pwm]
        rows["actuator_outputs"].append((t, (len(pwm), *out)))
    for t, a, g in zip(log.imu.t_s, log.imu.accel_flu, log.imu.gyro_flu, strict=True):
        rows["sensor_combined"].append((t, (*flu_to_frd(tuple(g)), *flu_to_frd(tuple(a)))))  # type: ignore[arg-type]
    for t, q in zip(log.attitude.t_s, log.attitude.quat_xyzw, strict=True):
        x, y, z, w = attitude_enu_flu_to_ned_frd(tuple(q))  # type: ignore[arg-type]
        rows["vehicle_attitude"].append((t, (w, x, y, z)))
    p = log.position
    for t, r, v in zip(p.t_s, p.pos_enu, p.vel_enu, strict=True):
        rows["vehicle_local_position"].append((t, (*enu_to_ned(tuple(r)), *enu_to_ned(tuple(v)))))  # type: ignore[arg-type]
    if log.battery is not None:
        b = log.battery
        for t, v, i in zip(b.t_s, b.voltage_v, b.current_a, strict=True):
            rows["battery_status"].append((t, (float(v), float(i) if np.isfinite(i) else -1.0)))
    s = log.state
    for k, (t, a, ld) in enumerate(zip(s.t_s, s.armed, s.landed, strict=True)):
        if k == 0 or a != s.armed[k - 1]:
            rows["actuator_armed"].append((t, (bool(a),)))
        if k == 0 or ld != s.landed[k - 1]:
            rows["vehicle_land_detected"].append((t, (bool(ld),)))
    return rows


def write_ulog(log: FlightLog, path: str | Path, *, info: dict[str, str] | None = None,
               params: dict[str, float] | None = None, topics: Collection[str] | None = None) -> Path:
    """Write ``log`` to ``path`` (ULog version 1); ``info`` strings (sys_name, ver_sw, ver_hw...) and
    ``params`` (default: ``log.params``) go into the definitions section; ``topics``: only these of
    :data:`FORMATS` (default: all)."""
    path = Path(path)
    rows = {k: v for k, v in _rows(log).items() if topics is None or k in topics}
    t0 = min((r[0][0] for r in rows.values() if r), default=0.0)
    out = bytearray(MAGIC + b"\x01" + struct.pack("<Q", BOOT_US))
    out += _msg(b"B", bytes(16) + struct.pack("<3Q", 0, 0, 0))
    for name in rows:
        out += _msg(b"F", f"{name}:{FORMATS[name]};".encode())
    for key, val in {"sys_name": "vinecli", "ver_hw": "VINECLI_SIM", "ver_sw": "simulation", **(info or {})}.items():
        v = val.encode()
        out += _msg(b"I", _key_value(f"char[{len(v)}] {key}", v))
    for key, val in (log.params if params is None else params).items():
        if float(val).is_integer() and key not in FLOAT_PARAMS:
            out += _msg(b"P", _key_value(f"int32_t {key}", struct.pack("<i", int(val))))
        else:
            out += _msg(b"P", _key_value(f"float {key}", struct.pack("<f", float(val))))
    ids = {name: i for i, name in enumerate(rows)}
    for name, i in ids.items():
        out += _msg(b"A", struct.pack("<BH", 0, i) + name.encode())
    stream = sorted((t, ids[name], vals) for name, rs in rows.items() for t, vals in rs)
    names = list(rows)
    for t, i, vals in stream:
        us = BOOT_US + int(round((t - t0) * 1e6))
        out += _msg(b"D", struct.pack("<H", i) + struct.pack(PACK[names[i]], us, *vals))
    path.write_bytes(bytes(out))
    return path
