"""Optional MCAP output of a run for Foxglove (``run.mcap``).

JSON-encoded channels with JSON schemas:

* ``/pose`` — ``foxglove.PoseInFrame`` (frame ``world``, ENU, position m, orientation x y z w),
* ``/state`` — the main scalars (altitude, speeds, tilt, mean rotor speed, thrust, tank, wind),
* ``/events`` — run events (kind, message).

Log time = simulation time in ns.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

POSE_SCHEMA = {
    "title": "foxglove.PoseInFrame",
    "type": "object",
    "properties": {
        "timestamp": {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
        "frame_id": {"type": "string"},
        "pose": {
            "type": "object",
            "properties": {
                "position": {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}},
                "orientation": {"type": "object", "properties": {k: {"type": "number"} for k in "xyzw"}},
            },
        },
    },
}

STATE_COLUMNS = (
    "height_agl_m", "pos_enu_z_m", "vel_enu_x_mps", "vel_enu_y_mps", "vel_enu_z_mps", "tilt_rad", "roll_rad",
    "pitch_rad", "yaw_rad", "thrust_total_n", "tank_level_l", "tank_flow_lps", "tank_force_enu_z_n",
    "total_mass_kg", "wind_enu_x_mps", "wind_enu_y_mps", "drag_enu_z_n",
)

EVENT_SCHEMA = {
    "title": "vinecli.Event",
    "type": "object",
    "properties": {"kind": {"type": "string"}, "message": {"type": "string"}},
}


def _stamp(t_s: float) -> dict[str, int]:
    ns = int(round(t_s * 1e9))
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def write_mcap(path: Path, ts: Mapping[str, np.ndarray], events: Sequence[Any] = ()) -> int:
    """Write ``run.mcap``; returns the number of messages written."""
    from mcap.writer import CompressionType, Writer

    t = np.asarray(ts["t_s"], dtype=float)
    state_cols = [c for c in STATE_COLUMNS if c in ts]
    rotor_cols = [c for c in ts if c.startswith("rotor") and c.endswith("_w_radps")]
    state_schema = {
        "title": "vinecli.State",
        "type": "object",
        "properties": {c: {"type": "number"} for c in [*state_cols, "rotor_mean_w_radps"]},
    }
    n = 0
    with open(path, "wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD)
        w.start(profile="", library="vinecli")
        s_pose = w.register_schema("foxglove.PoseInFrame", "jsonschema", json.dumps(POSE_SCHEMA).encode())
        s_state = w.register_schema("vinecli.State", "jsonschema", json.dumps(state_schema).encode())
        s_event = w.register_schema("vinecli.Event", "jsonschema", json.dumps(EVENT_SCHEMA).encode())
        c_pose = w.register_channel("/pose", "json", s_pose)
        c_state = w.register_channel("/state", "json", s_state)
        c_event = w.register_channel("/events", "json", s_event)
        have_pose = all(k in ts for k in ("pos_enu_x_m", "quat_w"))
        cols = {c: np.asarray(ts[c], dtype=float) for c in state_cols}
        rotor_mean = np.mean([np.asarray(ts[c], dtype=float) for c in rotor_cols], axis=0) if rotor_cols else None
        for i, ti in enumerate(t):
            log_time = int(round(ti * 1e9))
            if have_pose:
                msg = {
                    "timestamp": _stamp(ti),
                    "frame_id": "world",
                    "pose": {
                        "position": {k: float(ts[f"pos_enu_{k}_m"][i]) for k in "xyz"},
                        "orientation": {k: float(ts[f"quat_{k}"][i]) for k in "xyzw"},
                    },
                }
                w.add_message(c_pose, log_time=log_time, data=json.dumps(msg).encode(), publish_time=log_time, sequence=i)
                n += 1
            state = {c: _finite(v[i]) for c, v in cols.items()}
            if rotor_mean is not None:
                state["rotor_mean_w_radps"] = _finite(rotor_mean[i])
            w.add_message(c_state, log_time=log_time, data=json.dumps(state).encode(), publish_time=log_time, sequence=i)
            n += 1
        for j, ev in enumerate(events):
            log_time = int(ev.t_us) * 1000
            msg = {"kind": ev.kind, "message": ev.message}
            w.add_message(c_event, log_time=log_time, data=json.dumps(msg).encode(), publish_time=log_time, sequence=j)
            n += 1
        w.finish()
    return n


def _finite(v: float) -> float | None:
    v = float(v)
    return v if np.isfinite(v) else None
