"""Time-series recording into preallocated numpy arrays (docs/architecture.md column names).

The loop appends one row (a plain list of floats, in :func:`timeseries_columns` order) per
record period; rows go into a preallocated array in blocks; :meth:`Recorder.columns_dict`
returns ``{name: 1-D array}`` at the end (the missions tools write them to Parquet).
"""

from __future__ import annotations

import numpy as np

__all__ = ["Recorder", "timeseries_columns"]


def _xyz(prefix: str, suffix: str) -> list[str]:
    return [f"{prefix}_{a}_{suffix}" for a in "xyz"]


def timeseries_columns(n_rotors: int) -> list[str]:
    """Column names in recording order (SI units, frame in the name, rotors numbered 1..n)."""
    cols = ["t_s"]
    cols += _xyz("pos_enu", "m") + _xyz("vel_enu", "mps") + _xyz("acc_enu", "mps2")
    cols += ["quat_x", "quat_y", "quat_z", "quat_w", "roll_rad", "pitch_rad", "yaw_rad", "tilt_rad"]
    cols += _xyz("omega_flu", "radps")
    for i in range(1, n_rotors + 1):
        cols += [f"rotor{i}_w_radps", f"rotor{i}_cmd_radps", f"rotor{i}_thrust_n"]
    cols += ["thrust_total_n"]
    cols += _xyz("wind_enu", "mps") + _xyz("air_app_enu", "mps") + _xyz("drag_enu", "n") + _xyz("rotor_drag_flu", "n")
    cols += ["tank_level_l", "tank_mass_kg", "tank_flow_lps", "tank_flow_cmd_lps"]
    cols += _xyz("tank_force_enu", "n") + ["tank_force_grav_enu_z_n"] + _xyz("tank_force_inertial_enu", "n")
    cols += ["total_mass_kg"]
    cols += _xyz("imu_accel_flu", "mps2") + _xyz("imu_gyro_flu", "radps")
    cols += ["baro_alt_m", "gnss_lat_deg", "gnss_lon_deg", "gnss_alt_m"]
    cols += ["terrain_z_m", "height_agl_m", "on_ground"]
    cols += _xyz("sp_pos_enu", "m") + ["phase_index", "armed"]
    cols += ["battery_soc", "battery_voltage_v", "battery_current_a", "power_elec_w", "sortie"]
    return cols


class Recorder:
    """Rows of floats collected into a preallocated (capacity, n_columns) float64 array.

    :meth:`append` only stores the row list; rows are copied into the array in blocks of
    :attr:`BLOCK` (one numpy call per block instead of one per row).
    """

    BLOCK = 256

    def __init__(self, columns: list[str], capacity: int) -> None:
        self.columns = list(columns)
        self.index = {c: i for i, c in enumerate(self.columns)}
        self.buf = np.full((max(int(capacity), 16), len(self.columns)), np.nan)
        self.n = 0
        self._pending: list[list[float]] = []

    def append(self, row: list[float]) -> None:
        """Append one row (len = number of columns)."""
        self._pending.append(row)
        if len(self._pending) >= self.BLOCK:
            self.flush()

    def flush(self) -> None:
        """Copy pending rows into the array (grows by doubling if full)."""
        k = len(self._pending)
        if not k:
            return
        while self.n + k > self.buf.shape[0]:
            grown = np.full((2 * self.buf.shape[0], self.buf.shape[1]), np.nan)
            grown[: self.n] = self.buf[: self.n]
            self.buf = grown
        self.buf[self.n : self.n + k] = self._pending
        self.n += k
        self._pending = []

    def columns_dict(self) -> dict[str, np.ndarray]:
        """``{column: 1-D float64 array}`` of every row recorded so far (copies)."""
        self.flush()
        data = self.buf[: self.n]
        return {c: data[:, i].copy() for i, c in enumerate(self.columns)}
