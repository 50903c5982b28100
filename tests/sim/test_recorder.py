"""Recorder: block copies into chunks, growth with the rows recorded (not the capacity), column names."""

from __future__ import annotations

import numpy as np

from vinecli.sim.recorder import Recorder
from vinecli.sim.row import timeseries_columns


def test_rows_blocks_and_growth():
    cols = ["a", "b", "c"]
    rec = Recorder(cols, capacity=20)
    for i in range(1000):
        rec.append([float(i), 2.0 * i, -1.0])
    d = rec.columns_dict()
    assert list(d) == cols
    assert np.array_equal(d["a"], np.arange(1000.0)) and np.array_equal(d["b"], 2 * np.arange(1000.0))
    assert rec.n == 1000 and rec.capacity >= 1000
    rec.append([1.0, 2.0, 3.0])
    assert len(rec.columns_dict()["c"]) == 1001


def test_memory_grows_with_the_rows_not_the_capacity():
    """A 40 000 s mission at 100 Hz may record 4e6 rows; nothing of that is allocated up front."""
    cols = timeseries_columns(4)
    rec = Recorder(cols, capacity=40_000 * 100)
    assert rec.nbytes <= Recorder.CHUNK * len(cols) * 8
    for i in range(3 * Recorder.CHUNK + 5):  # crosses chunk borders
        rec.append([float(i)] * len(cols))
    t = rec.columns_dict()["t_s"]
    assert Recorder.CHUNK * 3 < rec.capacity <= Recorder.CHUNK * 4
    assert np.array_equal(t, np.arange(3 * Recorder.CHUNK + 5, dtype=float))
    huge = Recorder(cols, capacity=10**15)  # what max_duration_s: 1e12 asked for: 13.5 PiB before
    assert huge.nbytes == 0 and len(huge.columns_dict()["t_s"]) == 0


def test_contract_columns():
    cols = timeseries_columns(6)
    assert len(cols) == len(set(cols))
    for c in ("t_s", "pos_enu_z_m", "quat_w", "tilt_rad", "rotor6_thrust_n", "thrust_total_n", "air_app_enu_x_mps",
              "tank_force_grav_enu_z_n", "tank_force_inertial_enu_y_n", "imu_gyro_flu_z_radps", "gnss_lat_deg",
              "height_agl_m", "on_ground", "sp_pos_enu_z_m", "phase_index", "armed"):
        assert c in cols
    assert "rotor7_w_radps" not in cols
