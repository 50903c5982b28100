"""Flight logs out and back in: vinecli's ULog and DataFlash writers read back by the readers (pyulog,
pymavlink's DFReader) into the same streams, frames and configuration; gaps found and merged."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.flightlog.synthetic_log import cut, synthetic_log
from vinecli.flightlog.dataflash_write import write_dataflash
from vinecli.flightlog.flight_log import FlightLog
from vinecli.flightlog.read import read_flight_log
from vinecli.flightlog.ulog_write import write_ulog
from vinecli.frames import quat_rotate


def _same_attitude(a: np.ndarray, b: np.ndarray, tol: float) -> None:
    """Rotations equal (a quaternion and its negative are the same rotation)."""
    assert np.all(np.abs(np.abs(np.sum(a * b, axis=1)) - 1.0) < tol)


def _check(src: FlightLog, got: FlightLog, pwm_tol: float, att_tol: float) -> None:
    assert got.config.n_motors == src.config.n_motors
    assert (got.config.pwm_min_us, got.config.pwm_max_us) == (1000.0, 2000.0)
    assert got.config.cells == 4
    np.testing.assert_allclose(got.motors.t_s, src.motors.t_s - src.motors.t_s[0], atol=2e-6)
    np.testing.assert_allclose(got.motors.pwm_us, src.motors.pwm_us, atol=pwm_tol)
    assert np.array_equal(np.isnan(got.motors.u), np.isnan(src.motors.u))  # disarmed: stopped
    np.testing.assert_allclose(got.imu.accel_flu, src.imu.accel_flu, atol=1e-5)
    np.testing.assert_allclose(got.imu.gyro_flu, src.imu.gyro_flu, atol=1e-6)
    _same_attitude(got.attitude.quat_xyzw, src.attitude.quat_xyzw, att_tol)
    np.testing.assert_allclose(got.position.pos_enu, src.position.pos_enu, atol=1e-5)
    np.testing.assert_allclose(got.position.vel_enu, src.position.vel_enu, atol=1e-6)
    assert got.battery is not None and src.battery is not None
    np.testing.assert_allclose(got.battery.voltage_v, src.battery.voltage_v, atol=1e-5)
    np.testing.assert_allclose(got.battery.current_a, src.battery.current_a, atol=1e-5)
    t = np.linspace(0.5, 29.5, 59)
    for a, b in zip(got.state.at(t), src.state.at(t), strict=True):
        assert np.array_equal(a, b)


def test_ulog_round_trip(tmp_path: Path) -> None:
    src = synthetic_log()
    got = read_flight_log(write_ulog(src, tmp_path / "s.ulg", info={"sys_name": "PX4", "ver_sw": "abc123"}))
    assert got.info.format == "ulog" and got.info.sha256 and got.info.firmware == "PX4 abc123"
    _check(src, got, pwm_tol=1e-4, att_tol=1e-6)
    # the frames: a log's NED/FRD became ENU/FLU again (a vector along the body's nose points the same way)
    nose = np.array([quat_rotate(tuple(q), (1.0, 0.0, 0.0)) for q in got.attitude.quat_xyzw[:5]])
    ref = np.array([quat_rotate(tuple(q), (1.0, 0.0, 0.0)) for q in src.attitude.quat_xyzw[:5]])
    np.testing.assert_allclose(nose, ref, atol=1e-6)


def test_dataflash_round_trip(tmp_path: Path) -> None:
    src = synthetic_log()
    got = read_flight_log(write_dataflash(src, tmp_path / "s.bin"))
    assert got.info.format == "dataflash" and got.info.firmware.startswith("ArduCopter")
    assert got.info.date_utc is not None and got.info.date_utc.startswith("2024")  # GPS week 2300
    _check(src, got, pwm_tol=0.5, att_tol=1e-6)  # RCOU holds whole microseconds, ATT degrees as float


def test_pyulog_reads_the_written_ulog_as_px4_would(tmp_path: Path) -> None:
    """The file follows the ULog spec: pyulog's own parser sees the topics, fields and parameters PX4 writes."""
    from pyulog import ULog

    src = synthetic_log()
    u = ULog(str(write_ulog(src, tmp_path / "s.ulg")))
    names = {d.name for d in u.data_list}
    assert {"actuator_outputs", "sensor_combined", "vehicle_attitude", "vehicle_local_position",
            "battery_status", "actuator_armed", "vehicle_land_detected"} <= names
    assert u.initial_parameters["MAV_TYPE"] == 2 and isinstance(u.initial_parameters["MAV_TYPE"], int)
    acc = u.get_dataset("sensor_combined").data["accelerometer_m_s2[2]"]
    np.testing.assert_allclose(acc, -src.imu.accel_flu[:, 2], atol=1e-5)  # FRD: z down
    assert not u.file_corruption


@pytest.mark.parametrize("writer", [write_ulog, write_dataflash])
def test_gaps_are_found_and_merged(tmp_path: Path, writer) -> None:
    log = cut(synthetic_log(), 12.0, 15.0)
    got = read_flight_log(writer(log, tmp_path / ("g.ulg" if writer is write_ulog else "g.bin")))
    assert len(got.gaps) == 1
    a, b = got.gaps[0]
    assert a == pytest.approx(11.9, abs=0.02) and b == pytest.approx(15.0, abs=0.02)
