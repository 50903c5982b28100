"""PX4's own log audited after a run (vinecli.sitl.px4.log_audit): periodic topics that stop mid-flight are
PX4's scheduler fault, and the "Battery unhealthy" they cause is not a battery warning of the pack. The ULogs
here are written byte by byte following the ULog format (header, formats, subscriptions, data, log lines) and
read back by pyulog, as PX4's are."""

from __future__ import annotations

import os
import struct
from pathlib import Path

from vinecli.missions.checks import implicit_checks
from vinecli.sitl.px4.log_audit import apply_audit, audit_ulog
from vinecli.sitl.px4.process import SAFE_BOOT_PARAMS, Px4Process

FORMATS = {"vehicle_status": "uint64_t timestamp;uint8_t arming_state",
           "battery_status": "uint64_t timestamp;float voltage_v",
           "cpuload": "uint64_t timestamp;float load"}
PACK = {"vehicle_status": "<QB", "battery_status": "<Qf", "cpuload": "<Qf"}


def _msg(kind: bytes, body: bytes) -> bytes:
    return struct.pack("<HB", len(body), kind[0]) + body


def write_px4_like_ulog(path: Path, end_s: float, last_s: dict[str, float], lines: list[tuple[float, str]]) -> Path:
    """vehicle_status at 2 Hz to ``end_s``; battery_status at 5 Hz and cpuload at 2 Hz until ``last_s[topic]``
    (default ``end_s``); ``lines`` as PX4 console messages (level WARNING)."""
    out = bytearray(b"ULog\x01\x12\x35" + b"\x01" + struct.pack("<Q", 0))
    out += _msg(b"B", bytes(8) + bytes(8) + struct.pack("<3Q", 0, 0, 0))
    for name, fmt in FORMATS.items():
        out += _msg(b"F", f"{name}:{fmt}".encode())
    records: list[tuple[int, bytes]] = []
    for msg_id, (name, rate) in enumerate((("vehicle_status", 2.0), ("battery_status", 5.0), ("cpuload", 2.0))):
        out += _msg(b"A", struct.pack("<BH", 0, msg_id) + name.encode())
        stop = last_s.get(name, end_s)
        for k in range(int(stop * rate) + 1):
            t_us = round(k / rate * 1e6)
            records.append((t_us, _msg(b"D", struct.pack("<H", msg_id) + struct.pack(PACK[name], t_us, 1))))
    for t, text in lines:
        records.append((round(t * 1e6), _msg(b"L", struct.pack("<BQ", ord("4"), round(t * 1e6)) + text.encode())))
    for _, rec in sorted(records, key=lambda r: r[0]):
        out += rec
    path.write_bytes(bytes(out))
    return path


def test_a_battery_status_stopped_mid_flight_is_px4s_fault_not_the_packs(tmp_path):
    ulg = write_px4_like_ulog(tmp_path / "00_00_00.ulg", 26.5, {"battery_status": 4.34, "cpuload": 4.0},
                              [(4.33, "[commander] Armed by external command"),
                               (9.43, "[health_and_arming_checks] Preflight Fail: Battery unhealthy")])
    audit = audit_ulog(ulg)
    assert [(s.topic, s.module, round(s.last_s, 2)) for s in audit.stops] == [
        ("battery_status", "battery_simulator", 4.2), ("cpuload", "load_mon", 4.0)]  # last 5 Hz sample <= 4.34
    assert [w for _, w in audit.stale_battery_warnings] == ["Preflight Fail: Battery unhealthy"]
    metrics = {"px4_battery_warnings": 1.0, "px4_stalls": 0.0}
    events: list = []
    apply_audit([tmp_path / "px4.log", ulg], metrics, events)
    assert metrics["px4_scheduler_faults"] == 2 and metrics["px4_battery_warnings"] == 0  # not the pack's warning
    (ev,) = events
    assert ev.kind == "px4_fault" and ev.t_us == 4_000_000 and ev.data["stopped"] == {"battery_status": 4.2, "cpuload": 4.0}
    assert "not the battery" in ev.message and "Battery unhealthy" in ev.message
    implicit = {c.name: c for c in implicit_checks([], metrics)}
    assert implicit["px4_scheduler_faults"].bound == 0.0  # the run's verdict shows it


def test_a_log_whose_periodic_work_ran_to_the_end_is_clean_and_a_real_low_battery_stays_a_warning(tmp_path):
    ulg = write_px4_like_ulog(tmp_path / "a.ulg", 60.0, {"cpuload": 59.0},
                              [(50.0, "[health_and_arming_checks] Preflight Fail: Battery unhealthy")])
    assert audit_ulog(ulg).stops == []  # 1 s before the end is a sample interval, not a stop
    metrics = {"px4_battery_warnings": 1.0}
    events: list = []
    apply_audit([ulg], metrics, events)
    assert metrics == {"px4_battery_warnings": 1.0, "px4_scheduler_faults": 0.0} and events == []
    only_cpu = write_px4_like_ulog(tmp_path / "b.ulg", 27.0, {"cpuload": 4.0}, [])
    assert [s.topic for s in audit_ulog(only_cpu).stops] == ["cpuload"]  # the race can leave the battery's timer


def test_no_log_or_an_unreadable_log_changes_nothing(tmp_path):
    metrics = {"px4_battery_warnings": 1.0}
    assert apply_audit([tmp_path / "px4.log"], metrics, []) is None
    bad = tmp_path / "cut.ulg"
    bad.write_bytes(b"ULog\x01\x12\x35\x01garbage")
    assert apply_audit([bad], metrics, []) is None and metrics == {"px4_battery_warnings": 1.0}


def test_every_px4_vinecli_starts_boots_without_gyro_calibration_unless_the_run_says(tmp_path):
    """gyro_calibration re-arms its own periodic timer at arming, racing PX4's hrt_call_invoke (process.py)."""
    (tmp_path / "etc" / "init.d-posix").mkdir(parents=True)
    (tmp_path / "etc" / "init.d-posix" / "rcS").write_text("#!/bin/sh\n")
    (tmp_path / "bin").mkdir()
    px4 = tmp_path / "bin" / "px4"
    px4.write_text("#!/bin/sh\n")
    os.chmod(px4, 0o755)
    assert SAFE_BOOT_PARAMS == {"IMU_GYRO_CAL_EN": 0}
    assert "param set IMU_GYRO_CAL_EN 0\n" in Px4Process(px4, 10, workdir=tmp_path / "w", params={"MIS_TAKEOFF_ALT": 8.0}).params
    assert "param set IMU_GYRO_CAL_EN 1\n" in Px4Process(px4, 10, workdir=tmp_path / "w", params={"IMU_GYRO_CAL_EN": 1}).params
