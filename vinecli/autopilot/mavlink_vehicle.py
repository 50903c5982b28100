"""The built-in autopilot behind a MAVLink vehicle endpoint (``--mavlink udp:127.0.0.1:14540``).

:class:`MavlinkControlledAutopilot` implements the Autopilot protocol: each physics step it
serves MAVLink (:class:`~vinecli.mavlink.vehicle.VehicleEndpoint`) and steps a
:class:`~vinecli.autopilot.builtin.BuiltinAutopilot` whose phase list is replaced at run time
by what MAVLink clients command (arm, takeoff, land, RTL, hold, reposition, mission start,
sprayer). The run's mission phases are pre-loaded as the vehicle's onboard mission (download it,
or start it with MISSION_START / DO_SET_MODE AUTO.MISSION). The run ends ``completed`` once the
vehicle has flown and is landed and disarmed again.

Transport (:mod:`vinecli.mavlink.gcs_link`): ``udp:``/``udpout:`` send to the given address
(default 127.0.0.1:14540, where MAVSDK/pymavlink listen with ``udpin``) from ``local_port``
(udp: 14580 + instance, like PX4's API link); ``udpin:`` binds the address; ``tcpin:`` accepts
TCP clients; ``tcp:`` connects to a TCP server. Telemetry goes to every ground station that sent
a valid MAVLink message (up to 4). The address is resolved and must be loopback unless
``allow_remote=True``.

Pacing: with ``realtime`` the simulation follows the wall clock; otherwise (lockstep) it runs
as fast as it computes while executing a command or mission, and at wall-clock rate while it
waits for the operator (on the ground or holding after a command), so a script has time to
connect and send its next command.
"""

from __future__ import annotations

import logging
import math
import time
from typing import Any

from vinecli.autopilot.base import AutopilotContext, AutopilotStatus, RunStatus
from vinecli.autopilot.builtin import BuiltinAutopilot
from vinecli.autopilot.phases.phase import Phase, PhaseHost
from vinecli.errors import InputError
from vinecli.frames import attitude_grid_to_ned_frd, flu_to_frd, grid_to_ned, quat_to_euler, xyzw_to_wxyz
from vinecli.mavlink import px4modes as M
from vinecli.mavlink.gcs_link import checked_address, open_vehicle_link
from vinecli.mavlink.link import Link, parse_endpoint
from vinecli.mavlink.mission_items import MissionItem
from vinecli.mavlink.px4params import mission_params
from vinecli.mavlink.vehicle import DEFAULT_PARAMS, Telemetry, VehicleEndpoint
from vinecli.phase_items import DO_SET_ACTUATOR, PlanContext, items_to_phases, phases_to_items
from vinecli.rows.plan import plan_accel
from vinecli.specs.limits import MAX_DURATION_S  # phase timeout = none: max_duration_s ends the run
from vinecli.specs.mission import GotoPhase, LandPhase, RtlPhase, TakeoffPhase
from vinecli.types import ActuatorCommand, Event, Observation

log = logging.getLogger(__name__)

_BUILTIN_TO_PX4 = {"AUTO.TAKEOFF": "takeoff", "AUTO.LOITER": "hold", "AUTO.MISSION": "mission", "AUTO.LAND": "land",
                   "AUTO.RTL": "rtl"}


class _Tail(Phase):
    """Waiting for the operator: idle on the ground when armed there, hold position in the air."""

    MODE = "AUTO.LOITER"
    type = "wait"

    def start(self, ap: PhaseHost) -> None:
        self.sp = ap.hold_sp() if ap.armed else ap.pos

    def update(self, ap: PhaseHost, dt: float) -> bool:
        if ap.armed:
            if ap.airborne:
                ap.idle = False
                ap.set_position(self.sp, (0.0, 0.0, 0.0))
            else:
                ap.idle = True
        return False


class MavlinkControlledAutopilot:
    """Built-in autopilot commanded over MAVLink (see the module docstring).

    Options: ``url`` ("udp:HOST:PORT", where the client listens), ``allow_remote``,
    ``realtime``, ``instance`` (sysid = instance + 1), ``local_port`` (default 14580 + instance),
    ``link`` (an existing Link, for the fake PX4 peer). Ground-truth runs: the context's estimator.
    """

    name = "builtin+mavlink"

    def __init__(self, *, url: str = "udp:127.0.0.1:14540", allow_remote: bool = False, realtime: bool = False,
                 instance: int = 0, local_port: int | None = None, link: Link | None = None,
                 pace: bool = True) -> None:
        self.scheme, host, port = parse_endpoint(url)
        # the one address check: resolved and checked as an IP now (not at reset); the link opens on this IP
        self.ip = checked_address(host, allow_remote) if link is None else None
        if local_port is not None and self.scheme not in ("udp", "udpout"):
            raise InputError(f"--mavlink {url}: --mavlink-port (vinecli's own port) applies to udp:/udpout: only")
        self.allow_remote = allow_remote
        self.url, self.host, self.port = url, host, port
        self.realtime, self.pace = realtime, pace
        self.instance = instance
        self.local_port = local_port  # None: the scheme's default (udp: 14580 + instance, udpout: any)
        self._given_link = link
        self.link: Link | None = None
        self.ap = BuiltinAutopilot()
        self._events: list[Event] = []
        self._closed = False

    # ------------------------------------------------------------------ protocol
    def reset(self, ctx: AutopilotContext) -> None:
        """Start the builtin autopilot idle on the ground and open the MAVLink endpoint."""
        self.ctx = ctx
        ap = self.ap
        ap.reset(ctx)
        ap.drain_events()
        self._run_phases([], "hold", waiting=True)
        v = ctx.vehicle
        self.nozzle = v.tank.nozzle_max_flow_lps if v.tank is not None else 0.0
        hx, hy, hz = ctx.home_enu
        self.home_geo = ctx.origin.enu_to_geodetic_fast(hx, hy, hz)
        params = dict(DEFAULT_PARAMS)
        params["MPC_XY_CRUISE"] = float(min(5.0, v.control.max_vel_xy))
        pc = PlanContext(ctx.origin, ctx.home_enu, ctx.vine_rows_enu,
                         ctx.terrain_height if callable(ctx.terrain_height) else None,  # type: ignore[arg-type]
                         v.tank.nozzle_max_flow_lps if v.tank is not None else None, accel_mps2=plan_accel(v),
                         no_spray_enu=ctx.no_spray_enu)
        try:  # the endpoint speaks PX4's dialect: DO_SET_ACTUATOR for the sprayer, PX4's parameter names
            preload = phases_to_items(ctx.mission, pc, sprayer=DO_SET_ACTUATOR)
            items, fence = preload.items, preload.fence
            params.update({k: val for k, val in mission_params(ctx.mission).items() if k in params})
        except InputError as exc:
            log.info("mission not pre-loaded as a MAVLink mission: %s", exc)
            items, fence = [], []
        if self._given_link is not None:
            self.link = self._given_link
        else:
            assert self.ip is not None  # checked in __init__
            self.link = open_vehicle_link(self.scheme, self.ip, self.port, local_port=self.local_port,
                                          instance=self.instance, src_system=self.instance + 1, src_component=1)
        self.endpoint = VehicleEndpoint(self.link, self, params, sysid=self.instance + 1)
        self.endpoint.missions[0] = list(items)
        self.endpoint.missions[1] = list(fence)
        self.mission_start_seq = 0
        self.mission_seq = 0
        self.mission_state = M.MISSION_STATE_NOT_STARTED if items else 0
        self.was_airborne = False
        self._wall0: float | None = None
        self._sim0 = 0
        self._status = AutopilotStatus(mode="DISARMED", phase_index=0, extra={})
        self._events = []
        self._emit(0, "mavlink", f"MAVLink vehicle on {self.scheme} {self.link_desc()}", {"url": self.url})

    def link_desc(self) -> str:
        local = getattr(self.link, "local", None)
        if local is None or self.scheme in ("udpin", "tcpin"):
            return self.url
        return f"{local[0]}:{local[1]} -> {self.host}:{self.port}"

    def _emit(self, t_us: int, kind: str, message: str, data: dict[str, object] | None = None) -> None:
        self._events.append(Event(t_us, kind, message, data or {}))

    # ------------------------------------------------------------------ phase control
    def _run_phases(self, specs: list[Any], mode: str, *, waiting: bool = False, src: list[int] | None = None) -> None:
        """Replace the builtin's phase list with ``specs`` followed by the waiting phase."""
        self.ap.replace_phases(specs, then=[_Tail()])
        self.mode = mode
        self.waiting = waiting or not specs
        self._src = src
        self._n_cmd = len(specs)

    def _param(self, name: str) -> float:
        return float(self.endpoint.params.get(name, DEFAULT_PARAMS.get(name, 0.0)))

    # ------------------------------------------------------------------ VehicleHandler
    def on_arm(self, arm: bool, force: bool) -> tuple[int, str]:
        ap = self.ap
        if arm:
            if ap.armed:
                return M.MAV_RESULT_ACCEPTED, ""
            if not ap.est_ready and not force:
                return M.MAV_RESULT_TEMP_REJECTED, "Arming denied: estimator not ready"
            ap.arm()
            ap.idle = True
            self._run_phases([], self.mode, waiting=True)
            if self.mode == "mission" and self.endpoint.missions[0]:
                self._start_mission()
            return M.MAV_RESULT_ACCEPTED, "Armed by external command"
        if not ap.armed:
            return M.MAV_RESULT_ACCEPTED, ""
        if ap.airborne and not force:
            return M.MAV_RESULT_DENIED, "Disarming denied: not landed"
        ap.disarm()
        self._run_phases([], self.mode, waiting=True)
        return M.MAV_RESULT_ACCEPTED, "Disarmed by external command"

    def on_mode(self, mode: str) -> int:
        if mode == "mission":
            self.mode = "mission"
            if self.ap.armed:
                return self._start_mission()
            return M.MAV_RESULT_ACCEPTED
        if mode == "hold":
            self._run_phases([], "hold", waiting=True)
            return M.MAV_RESULT_ACCEPTED
        if mode == "takeoff":
            return self.on_takeoff(None)
        if mode == "land":
            return self.on_land()
        if mode == "rtl":
            return self.on_rtl()
        return M.MAV_RESULT_DENIED

    def on_takeoff(self, alt_rel_m: float | None) -> int:
        if not self.ap.armed:
            self.endpoint.statustext("Takeoff denied: arm first", 4)
            return M.MAV_RESULT_DENIED
        alt = alt_rel_m if alt_rel_m is not None and alt_rel_m > 0 else self._param("MIS_TAKEOFF_ALT")
        self._run_phases([TakeoffPhase(altitude_agl_m=alt, climb_speed_mps=self._param("MPC_TKO_SPEED"))], "takeoff")
        return M.MAV_RESULT_ACCEPTED

    def on_land(self) -> int:
        if not self.ap.armed:
            return M.MAV_RESULT_DENIED
        land = LandPhase(descent_speed_mps=self._param("MPC_LAND_SPEED"), timeout_s=MAX_DURATION_S)
        self._run_phases([land], "land")
        return M.MAV_RESULT_ACCEPTED

    def on_rtl(self) -> int:
        if not self.ap.armed:
            return M.MAV_RESULT_DENIED
        rtl = RtlPhase(return_altitude_agl_m=max(0.5, self._param("RTL_RETURN_ALT")), timeout_s=MAX_DURATION_S)
        self._run_phases([rtl], "rtl")
        return M.MAV_RESULT_ACCEPTED

    def on_mission_start(self) -> int:
        if not self.ap.armed:
            self.endpoint.statustext("Mission start denied: arm first", 4)
            return M.MAV_RESULT_DENIED
        self.mode = "mission"
        return self._start_mission()

    def on_reposition(self, lat: float, lon: float, alt_amsl: float, speed: float) -> int:
        if not self.ap.armed or not self.ap.airborne:
            return M.MAV_RESULT_DENIED
        o = self.ctx.origin
        m_lat, m_lon = o.metres_per_degree
        x, y = (lon - o.lon) * m_lon, (lat - o.lat) * m_lat
        alt = None if not math.isfinite(alt_amsl) else alt_amsl - self.home_geo[2]
        sp = speed if math.isfinite(speed) and speed > 0 else self._param("MPC_XY_CRUISE")
        goto = GotoPhase(position_enu=(x, y), altitude_agl_m=alt, speed_mps=sp, timeout_s=MAX_DURATION_S)
        self._run_phases([goto], "hold")
        return M.MAV_RESULT_ACCEPTED

    def on_set_actuator(self, u: float) -> int:
        if self.nozzle <= 0:
            return M.MAV_RESULT_DENIED
        self.ap.set_flow(max(0.0, min(1.0, u)) * self.nozzle)
        return M.MAV_RESULT_ACCEPTED

    def on_change_speed(self, speed: float) -> int:
        if not (math.isfinite(speed) and speed > 0):
            return M.MAV_RESULT_DENIED
        self.endpoint.params["MPC_XY_CRUISE"] = float(speed)
        return M.MAV_RESULT_ACCEPTED

    def on_mission(self, mission_type: int, items: list[MissionItem]) -> None:
        if mission_type == 0:
            self.mission_start_seq = 0
            self.mission_seq = 0
            self.mission_state = M.MISSION_STATE_NOT_STARTED if items else 0
            self._emit(self.ap.t_us, "mavlink", f"mission uploaded ({len(items)} items)", {"count": len(items)})

    def on_set_current(self, seq: int) -> int:
        if not 0 <= seq < max(1, len(self.endpoint.missions[0])):
            return M.MAV_RESULT_DENIED
        self.mission_start_seq = seq
        self.mission_seq = seq
        return M.MAV_RESULT_ACCEPTED

    def on_param(self, name: str, value: float) -> None:
        self._emit(self.ap.t_us, "mavlink", f"parameter {name} = {value:g}", {"name": name, "value": value})

    def _start_mission(self) -> int:
        items = self.endpoint.missions[0][self.mission_start_seq:]
        if not items:
            self.endpoint.statustext("Mission start denied: no mission", 4)
            return M.MAV_RESULT_DENIED
        phases, src = items_to_phases(items, self.ctx.origin, self.home_geo[2], self.nozzle or None,
                                      takeoff_alt_default=self._param("MIS_TAKEOFF_ALT"))
        src = [s + self.mission_start_seq for s in src]
        if not self.ap.airborne and not (phases and isinstance(phases[0], TakeoffPhase)):
            phases.insert(0, TakeoffPhase(altitude_agl_m=self._param("MIS_TAKEOFF_ALT")))
            src.insert(0, self.mission_start_seq)
        self._run_phases(phases, "mission", src=src)
        self.mission_state = M.MISSION_STATE_ACTIVE
        self._emit(self.ap.t_us, "mavlink", "mission started", {"items": len(items)})
        return M.MAV_RESULT_ACCEPTED

    # ------------------------------------------------------------------ per step
    def step(self, obs: Observation) -> ActuatorCommand:
        """Serve MAVLink, step the builtin autopilot, pace (see the module docstring)."""
        ap = self.ap
        ep = self.endpoint
        ep.update(obs.t_us * 1e-6, self._telemetry(obs))
        armed = ap.armed
        cmd = ap.step(obs)
        self._track(obs)
        if ap.armed != armed:  # tell clients at once (the run may end on this very step after landing)
            ep.send_state_now(self._telemetry(obs))
        self._pace(obs.t_us)
        return cmd

    def _track(self, obs: Observation) -> None:
        ap = self.ap
        for ev in ap.drain_events():
            self._events.append(ev)
            if ev.kind == "phase" and ev.data.get("event") == "end" and self._src is not None:
                i = int(ev.data.get("index", -1))  # type: ignore[arg-type]
                src = self._src
                if 0 <= i < len(src) and (i + 1 >= len(src) or src[i + 1] != src[i]):  # last phase of that item
                    self.endpoint.mission_item_reached(src[i])
        i = ap.phase_index
        if self._src is not None and 0 <= i < len(self._src):
            self.mission_seq = self._src[i]
        if i >= self._n_cmd and not self.waiting:  # commanded phases done: now waiting for the operator
            self.waiting = True
            if self._src is not None:
                self.mission_state = M.MISSION_STATE_COMPLETE
                self.mission_seq = max(0, len(self.endpoint.missions[0]) - 1)
                self._emit(obs.t_us, "mavlink", "mission complete", {})
        if ap.airborne:
            self.was_airborne = True
        st = ap.status()
        if st.status is RunStatus.RUNNING and self.was_airborne and not ap.armed:
            st.status = RunStatus.COMPLETED
            st.detail = "landed and disarmed (commanded over MAVLink)"
            self._emit(obs.t_us, "status", f"completed: {st.detail}", {"status": "completed", "detail": st.detail})

    def _pace(self, t_us: int) -> None:
        if not self.pace:
            return
        now = time.monotonic()
        if not (self.realtime or self.waiting):
            self._wall0 = None
            return
        if self._wall0 is None:
            self._wall0, self._sim0 = now, t_us
            return
        due = self._wall0 + (t_us - self._sim0) * 1e-6
        if due > now:
            time.sleep(due - now)
        elif now - due > 0.5:  # fell behind (slow machine): do not try to catch up in a burst
            self._wall0, self._sim0 = now, t_us

    def _telemetry(self, obs: Observation) -> Telemetry:
        ap = self.ap
        o = self.ctx.origin
        lat, lon, alt = o.enu_to_geodetic_fast(*ap.pos)
        q_ned = attitude_grid_to_ned_frd(ap.quat, o.convergence_rad)  # against true north
        mode = self.mode
        if ap.armed and not self.waiting:
            mode = _BUILTIN_TO_PX4.get(ap.mode, mode) if self.mode != "mission" else "mission"
        if not ap.armed:
            landed = M.LANDED_ON_GROUND
        elif not ap.airborne:
            landed = M.LANDED_TAKEOFF if not self.waiting else M.LANDED_ON_GROUND
        else:
            landed = M.LANDED_LANDING if ap.mode == "AUTO.LAND" else M.LANDED_IN_AIR
        g = obs.gnss
        return Telemetry(
            armed=ap.armed, mode=mode, landed_state=landed, lat=lat, lon=lon, alt_amsl=alt, rel_alt=alt - self.home_geo[2],
            vel_ned=grid_to_ned(ap.vel, o.convergence_rad), q_wxyz=xyzw_to_wxyz(q_ned), rpy=quat_to_euler(q_ned),
            rates_frd=flu_to_frd(ap.omega), home=self.home_geo,
            gps_fix=3 if (g is None or g.fix_type >= 3) else g.fix_type,
            satellites=12 if g is None else g.satellites, eph_m=0.3 if g is None else g.eph_m,
            prearm_ok=bool(ap.est_ready), position_ok=bool(ap.est_ready), mission_seq=self.mission_seq, mission_state=self.mission_state,
            time_boot_ms=obs.t_us // 1000,
        )

    def status(self) -> AutopilotStatus:
        return self.ap.status()

    def drain_events(self) -> list[Event]:
        ev, self._events = self._events, []
        return ev

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        if self.link is not None and self._given_link is None:
            self.link.close()
        self.ap.close()


def serve_mavlink(url: str = "udp:127.0.0.1:14540", *, realtime: bool = False, allow_remote: bool = False,
                  instance: int = 0, local_port: int | None = None) -> MavlinkControlledAutopilot:
    """The autopilot to pass to ``run_simulation`` for ``vinecli run mission ... --mavlink URL [--realtime]``."""
    return MavlinkControlledAutopilot(url=url, realtime=realtime, allow_remote=allow_remote, instance=instance,
                                      local_port=local_port)
