"""What every report figure shares: the run's plotted data (:class:`PlotData`), sizes, colours, and
the matplotlib object-API figure, title and PNG helpers (no pyplot state). SI units, ENU/FLU frames."""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.constants import STANDARD_GRAVITY

DPI = 100
#: figure sizes in inches (pixels = inches * DPI)
SIZES = {"fig16": (12.0, 5.2), "fig17": (9.0, 5.6), "fig18": (9.0, 7.0), "fig19": (9.0, 5.6),
         "fig20": (9.0, 7.0), "fig21": (9.0, 7.0), "fig22": (9.0, 5.6), "fig23": (11.0, 8.0), "fig24": (9.0, 6.0),
         "fig25": (11.0, 5.0), "fig26": (12.0, 7.0), "fig27": (12.0, 4.6)}
C_OK, C_FAIL = "#2ca02c", "#d62728"


class NoData(Exception):
    """The run has no data for this figure; the message is the note shown instead."""


@dataclass
class PlotData:
    """What the figures read of one run: time-series columns (SI), events, summary and terrain preview."""

    cols: dict[str, np.ndarray]
    events: list[dict[str, Any]] = field(default_factory=list)
    summary: dict[str, Any] = field(default_factory=dict)
    preview: dict[str, np.ndarray] | None = None
    run_dir: Path | None = None  # for the per-run files (deposition.json / .tif)
    gravity: float = STANDARD_GRAVITY  # m/s², the run's world's (standard gravity when that world is gone)

    def has(self, *names: str) -> bool:
        return all(n in self.cols and np.isfinite(self.cols[n]).any() for n in names)

    @property
    def t(self) -> np.ndarray:
        return self.cols["t_s"]

    def event_times(self, kind: str) -> list[float]:
        """Times of events of ``kind``; ``tank_empty`` falls back to the level column reaching 0."""
        times = sorted(float(e["t_s"]) for e in self.events if e.get("kind") == kind)
        if not times and kind == "tank_empty" and self.has("tank_level_l"):
            lvl = self.cols["tank_level_l"]
            if lvl.size and float(np.nanmax(lvl)) > 0:
                idx = np.flatnonzero(lvl <= 1e-6)
                if idx.size:
                    times = [float(self.t[idx[0]])]
        return times

    def rotors(self) -> list[str]:
        i, out = 1, []
        while f"rotor{i}_w_radps" in self.cols:
            out.append(f"rotor{i}_w_radps")
            i += 1
        return out if out and self.has(*out) else []

    def liftoff(self) -> float | None:
        """The main lift-off: first on_ground 1 -> 0 transition after which the vehicle stays up >= 1 s."""
        t = self.t
        if "on_ground" in self.cols and t.size > 1:
            og = self.cols["on_ground"] > 0.5
            for i in np.flatnonzero(og[:-1] & ~og[1:]):
                later = np.flatnonzero(og[i + 1:])
                stay = (t[i + 1 + later[0]] if later.size else t[-1]) - t[i + 1]
                if stay >= 1.0:
                    return float(t[i + 1])
        ev = self.event_times("liftoff")
        return ev[-1] if ev else None


def columns_needed() -> list[str]:
    """Every column any figure reads (rotor columns up to 8 rotors)."""
    base = ["pos_enu_x_m", "pos_enu_y_m", "pos_enu_z_m", "vel_enu_x_mps", "vel_enu_y_mps", "vel_enu_z_mps",
            "acc_enu_z_mps2", "quat_x", "quat_y", "quat_z", "quat_w", "roll_rad", "pitch_rad", "yaw_rad", "tilt_rad",
            "wind_enu_x_mps", "wind_enu_y_mps", "wind_enu_z_mps", "drag_enu_x_n", "drag_enu_y_n", "drag_enu_z_n",
            "rotor_drag_flu_x_n", "rotor_drag_flu_y_n", "rotor_drag_flu_z_n", "tank_level_l", "tank_mass_kg",
            "tank_flow_lps", "tank_flow_cmd_lps", "tank_force_enu_z_n", "tank_force_grav_enu_z_n",
            "tank_force_inertial_enu_z_n", "total_mass_kg", "terrain_z_m", "height_agl_m", "on_ground",
            "phase_index", "sp_pos_enu_x_m", "sp_pos_enu_y_m", "sp_pos_enu_z_m",
            "battery_soc", "battery_voltage_v", "power_elec_w", "sortie"]
    return base + [f"rotor{i}_w_radps" for i in range(1, 9)]


def new_figure(name: str, rows: int = 1, cols: int = 1, sharex: bool = True) -> tuple[Any, Any]:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=SIZES[name], dpi=DPI)
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, cols, sharex=sharex, squeeze=False)
    # fixed margins (a layout engine costs about half of the rendering time); room for twin-axis labels
    fig.subplots_adjust(left=0.11, right=0.89, top=0.91, bottom=0.09 if rows < 3 else 0.075, hspace=0.18)
    return fig, axes


def png_bytes(fig: Any) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, metadata={"Software": None}, pil_kwargs={"compress_level": 4})
    return buf.getvalue()


def set_title(fig: Any, data: PlotData, what: str) -> None:
    s = data.summary
    who = f"{s.get('case') or s.get('run_id', '')} ({s.get('mission', '')}, seed {s.get('seed', '-')})"
    sep = "\n" if len(what) + len(who) > 90 else " — "
    fig.suptitle(f"{what}{sep}{who}", fontsize=11 if sep == " — " else 10)
