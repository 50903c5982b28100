"""Failsafes of the built-in autopilot on the rigid-body double: a draining battery (PX4
BAT_CRIT_THR -> return, BAT_EMERGEN_THR -> land) and lost control; each records a ``failsafe``
event and switches the sprayer off for the rest of the run."""

from __future__ import annotations

import pytest
from repo_paths import VEHICLES

from vinecli.autopilot.base import RunStatus
from vinecli.autopilot.builtin import BuiltinAutopilot
from vinecli.specs import load_spec
from vinecli.specs.mission import MissionSpec
from vinecli.specs.vehicle import VehicleSpec

from .rigid_body import RigidBodyDouble


class _Draining(RigidBodyDouble):
    """The double with a state of charge falling 1 %/s from ``soc0`` (the autopilot's view of the battery)."""

    soc0 = 0.2

    def observe(self):  # type: ignore[no-untyped-def]
        obs = super().observe()
        obs.battery_soc = max(0.0, self.soc0 - 0.01 * self.t_us * 1e-6)
        return obs


def test_low_battery_returns_then_lands_with_the_sprayer_off() -> None:
    v = load_spec(VEHICLES / "x500-sprayer.yaml", VehicleSpec)
    assert v.battery is not None and v.battery.critical_soc == pytest.approx(0.07)
    d = _Draining(v)
    ap = BuiltinAutopilot()
    ap.reset(d.context(MissionSpec(name="t", truth=True, phases=[
        {"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "goto", "position_enu": [10.0, 0.0]},
        {"type": "sprayer", "flow_lps": 0.02}, {"type": "hold", "duration_s": 60.0}, {"type": "land"}])))
    tr = d.fly(ap, 40)
    ev = ap.drain_events()
    fs = [e for e in ev if e.kind == "failsafe"]
    # critical (7 %) at 13 s: return to launch; emergency (5 %) at 15 s on the way back: land there
    assert [(e.data["cause"], e.data["action"]) for e in fs] == [("low_battery", "rtl"), ("low_battery", "land")]
    assert [round(e.t_us * 1e-6) for e in fs] == [13, 15]
    assert "battery 7.0% below the critical level 7%" in fs[0].data["detail"]
    i_rtl = next(i for i, t in enumerate(tr.t) if t >= fs[0].t_us * 1e-6 + 0.1)
    assert max(tr.flow[:i_rtl]) == pytest.approx(0.02) and max(tr.flow[i_rtl:]) == 0.0  # sprayer off at once
    st = ap.status()
    assert st.status is RunStatus.FAILSAFE and "low battery" in st.detail and d.on_ground
    i_land = next(i for i, t in enumerate(tr.t) if t >= fs[1].t_us * 1e-6)
    assert max(p[2] for p in tr.pos[i_rtl:i_land]) > 3.5  # climbing to the 5 m return altitude
    assert abs(d.pos[0] - fs[1].data["position_est_enu"][0]) < 1.0  # then landed where the emergency came


def test_lost_control_is_a_failsafe() -> None:
    v = load_spec(VEHICLES / "x500-sprayer.yaml", VehicleSpec)
    d = RigidBodyDouble(v)
    d.ext_torque = lambda t: (10.0, 0.0, 0.0) if 6.0 <= t < 7.0 else (0.0, 0.0, 0.0)  # a hard roll kick, N m
    ap = BuiltinAutopilot()
    ap.reset(d.context(MissionSpec(name="t", truth=True, phases=[
        {"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "sprayer", "flow_lps": 0.02},
        {"type": "hold", "duration_s": 20.0}])))
    tr = d.fly(ap, 20)
    ev = ap.drain_events()
    st = ap.status()
    assert st.status is RunStatus.LOST_CONTROL
    (fs,) = [e for e in ev if e.kind == "failsafe"]
    assert fs.data["cause"] == "lost_control" and fs.data["action"] == "disarm" and "beyond 70 deg" in fs.data["detail"]
    sprayer = [(e.t_us, e.data["flow_lps"]) for e in ev if e.kind == "sprayer"]
    assert [f for _, f in sprayer] == [0.02, 0.0] and sprayer[-1][0] == fs.t_us  # off at the failsafe
    assert ap.flow == 0.0 and max(tr.flow) == pytest.approx(0.02)
