"""The built-in autopilot: estimator + PX4-style cascade + mission sequencer + safety checks.

It never touches PyBullet: each physics step it gets an
:class:`~vinecli.types.Observation` and returns rotor speed commands (rad/s) and the
sprayer flow (L/s). World ENU, body FLU, SI units. Altitudes ``*_agl_m`` of takeoff, goto,
waypoints and RTL are above home (PX4 relative altitude); the spray height is above the
terrain under the vehicle.

The parts, one job each:

- :mod:`vinecli.autopilot.builtin` (this module): :class:`BuiltinAutopilot`, the glue - builds the
  run's estimator, cascade and phases in ``reset``; each step state estimate -> position loop (at
  ``control.pos_loop_rate_hz``) -> attitude/rate loops -> :class:`~vinecli.types.ActuatorCommand`,
  or the rotor speeds of an open-loop phase; the lost-control check; at the position-loop rate the
  senses: terrain (:mod:`vinecli.autopilot.terrain`: the map, corrected by the rangefinder), land
  and take-off detection (:mod:`vinecli.autopilot.land_detector`), hover thrust and mass
  (:mod:`vinecli.autopilot.hover_thrust`).
- :mod:`vinecli.autopilot.supervisor`: modes, phase sequence, arming, preflight, failsafes
  (geofence, battery, cannot take off), events and the run status.
- :mod:`vinecli.autopilot.phases.phase`: the :class:`~vinecli.autopilot.phases.phase.Phase` base and what a phase
  may use of the autopilot; :mod:`vinecli.autopilot.phases` (``make_phase``: mission spec -> phase),
  :mod:`vinecli.autopilot.phases.flight`, :mod:`vinecli.autopilot.phases.spray` (refill sorties).
- :mod:`vinecli.autopilot.estimate` (the state estimate it flies on: its own
  :mod:`vinecli.autopilot.estimator`, or the one the simulator hands over in ground-truth runs),
  :mod:`vinecli.autopilot.geofence`, :mod:`vinecli.autopilot.preflight`, :mod:`vinecli.control`
  (cascade, path follower).

Nothing here reads the simulator's truth: the autopilot knows what its sensors, its map and its own
commands tell it.

Run-time missions (the MAVLink vehicle, :mod:`vinecli.autopilot.mavlink_vehicle`) use the public
:meth:`BuiltinAutopilot.replace_phases` and :attr:`BuiltinAutopilot.phase_index`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from vinecli.autopilot.base import RUNNING, AutopilotContext, AutopilotStatus, RunStatus
from vinecli.autopilot.estimator import Estimator
from vinecli.autopilot.geofence import Geofence
from vinecli.autopilot.hover_thrust import HoverThrustEstimator
from vinecli.autopilot.land_detector import LandDetector
from vinecli.autopilot.phases.flight import OpenLoop
from vinecli.autopilot.phases.from_spec import make_phase
from vinecli.autopilot.phases.phase import Phase
from vinecli.autopilot.supervisor import FlightSupervisor
from vinecli.autopilot.terrain import TerrainSense
from vinecli.control.cascade import Cascade, G
from vinecli.errors import AutopilotError, InputError
from vinecli.frames import Vec3, quat_to_euler, tilt_angle
from vinecli.types import ActuatorCommand, Event, Observation, RangeSample

_NAN = float("nan")


class BuiltinAutopilot(FlightSupervisor):
    """The built-in backend of the :class:`~vinecli.autopilot.base.Autopilot` protocol (no options).

    It flies on :attr:`AutopilotContext.estimator <vinecli.autopilot.base.AutopilotContext.estimator>`
    when the simulator gives one (ground-truth runs), else on its own estimator. Mode, phase
    sequence, arming and failsafes: :class:`FlightSupervisor`.
    """

    name = "builtin"

    def __init__(self, **opts: Any) -> None:
        if opts:
            raise InputError(f"builtin autopilot: unknown option(s) {', '.join(sorted(opts))}")
        self._status = AutopilotStatus(mode="DISARMED", phase_index=0)
        self._events = []
        self._ctx: AutopilotContext | None = None

    # ------------------------------------------------------------------ protocol
    def reset(self, ctx: AutopilotContext) -> None:
        """Build estimator, senses, controller and the phase list for ``ctx.mission``."""
        self._ctx = ctx
        self.vehicle = v = ctx.vehicle
        self.mission = ctx.mission
        if ctx.physics_dt_us <= 0:
            raise AutopilotError(f"invalid physics step {ctx.physics_dt_us} µs")
        self.dt = ctx.physics_dt_us * 1e-6
        self.cascade = c = Cascade(v, self.dt)
        self.n_pos = max(1, round(1.0 / (self.dt * v.control.pos_loop_rate_hz)))
        self.dt_pos = self.n_pos * self.dt
        self.estimator = ctx.estimator if ctx.estimator is not None else Estimator(v, ctx.origin)
        self.home = tuple(float(x) for x in ctx.home_enu)  # type: ignore[assignment]
        gear = v.frame.landing_gear_height_m
        self.terrain_sense = TerrainSense(ctx.terrain, v.sensors.rangefinder, self.home[2] - gear, gear)
        self.terrain = self.terrain_sense.height
        # hover thrust (normalised to the maximum thrust) and mass: the nominal from the spec
        # (empty + payload: MPC_THR_HOVER), then estimated in flight
        self.t_max = c.t_total_max
        hover0 = v.dry_mass() * G / self.t_max
        self.hte = HoverThrustEstimator(hover0, thr_range=v.control.hover_thrust_range,
                                        process_noise=v.control.hover_thrust_noise)
        self.land = LandDetector(c.thr_min / self.t_max, hover0)
        self.hover_thrust = hover0
        self._range: RangeSample | None = None
        self.geofence = Geofence(ctx.geofence, self.home) if ctx.geofence is not None else None
        self.cos_lost = math.cos(math.radians(v.control.lost_control_tilt_deg))
        self.spool_s = 0.5
        self.phases = [make_phase(p, ctx) for p in ctx.mission.phases]
        self._plan_failures = self._mission_preflight(ctx)
        # state
        self.t_us = 0
        self.pos = self.home
        self.vel = (0.0, 0.0, 0.0)
        self.quat = (0.0, 0.0, 0.0, 1.0)
        self.omega: Vec3 = (0.0, 0.0, 0.0)
        self.est_ready = False
        self.armed = False
        self.idle = False
        self.airborne = False
        self.ground_contact = True
        self.landed = True
        self.height_terrain = 0.0
        self.flow = 0.0
        self.mass = hover0 * self.t_max / G
        self.tank_empty = False
        self.tank_level_l = 0.0
        self.battery_soc = math.nan
        self.sortie = 1
        self._service = None
        self.mode = "DISARMED"
        self._phase_i = -1
        self._phase = None
        self._phase_t = 0.0
        self._failsafe = False
        self._failsafe_detail = ""
        self._failsafe_status = RunStatus.FAILSAFE
        self._battery_level = 0  # 0 ok, 1 critical (returning), 2 emergency (landing)
        self.sprayer_inhibited = False
        self._countdown = 0
        self._z_armed = self.home[2]
        self._sat_t = 0.0
        self._sp = None
        self._w_cmd = (0.0,) * v.n_rotors
        self._off = ActuatorCommand((0.0,) * v.n_rotors, 0.0, False)
        self._status = AutopilotStatus(mode="DISARMED", phase_index=0,
                                       extra={"sp_x": _NAN, "sp_y": _NAN, "sp_z": _NAN, "mass_est_kg": self.mass,
                                              "sortie": 1.0})
        self._events = []
        self._next_phase()

    def replace_phases(self, phases: Sequence[object], *, then: Sequence[Phase] = ()) -> None:
        """Replace the remaining mission by ``phases`` (mission phase specs) followed by ``then``
        (phases already built, e.g. one that waits for the operator) and start the first one now
        (run-time missions, e.g. uploaded over MAVLink); a failsafe in progress is dropped. Raises
        InputError for bad phases, AutopilotError before :meth:`reset`."""
        ctx = self._ctx
        if ctx is None:
            raise AutopilotError("replace_phases before reset")
        self.phases = [make_phase(p, ctx) for p in phases]
        self.phases.extend(then)
        self._phase_i = -1
        self._failsafe = False
        self._countdown = 0
        self._next_phase()

    @property
    def phase_index(self) -> int:
        """Index of the current phase in the phase list (after :meth:`replace_phases`: in the new list)."""
        return self._phase_i

    def step(self, obs: Observation) -> ActuatorCommand:
        """Commands for the next physics step."""
        st = self._status
        if st.status is not RUNNING:
            return self._off
        self.t_us = obs.t_us
        est = self.estimator
        est.update(obs)
        self.pos, self.vel, self.quat, self.omega = est.pos, est.vel, est.quat, est.omega
        self.est_ready = est.ready
        if obs.rangefinder is not None:
            self._range = obs.rangefinder  # fused at the position-loop rate
        return self._command(obs)

    def _command(self, obs: Observation) -> ActuatorCommand:
        """An open-loop phase's rotor speeds (rad/s) while it lasts, else the controllers' command."""
        ph = self._phase
        if isinstance(ph, OpenLoop):
            w, done = ph.command(obs.t_us)
            if not done:
                self._w_cmd = w
                return ActuatorCommand(w, self.flow, True)
            self._end_phase()
            if self._status.status is not RUNNING:
                return self._off
            self._countdown = 0
            if isinstance(self._phase, OpenLoop):
                return self._command(obs)
            # the controller takes over from the current state (in the air: the land detector too)
            if self.pos[2] - self.terrain(self.pos[0], self.pos[1]) - self.vehicle.frame.landing_gear_height_m > 0.2:
                self.land.set_flying()
            self.cascade.reset()
            self.cascade.set_yaw(quat_to_euler(self.quat)[2], immediate=True)
            self._sp = None
            if self._phase is not None:
                self._phase.start(self)
        return self._controller(obs)

    def _controller(self, obs: Observation) -> ActuatorCommand:
        """Sequencer (position-loop rate) + attitude/rate loops (every step)."""
        self._countdown -= 1
        if self._countdown <= 0:
            self._countdown = self.n_pos
            self._outer(obs)
            if self._status.status is not RUNNING:
                return self._off
            if isinstance(self._phase, OpenLoop):
                return self._command(obs)
        if not self.armed:
            if self._service is not None:  # the ground crew's turn (refill sorties)
                req, self._service = self._service, None
                return ActuatorCommand(self._off.rotor_speed_cmd, 0.0, False, req)
            return self._off
        q = self.quat
        if 1.0 - 2.0 * (q[0] * q[0] + q[1] * q[1]) < self.cos_lost:
            tilt = math.degrees(tilt_angle(q))
            detail = f"tilt {tilt:.0f} deg beyond {self.vehicle.control.lost_control_tilt_deg:g} deg"
            self.failsafe("lost_control", "disarm", detail)
            self._finish(RunStatus.LOST_CONTROL, detail)
            return self._off
        if self.idle:
            wi = self.vehicle.motor.w_min_armed
            self._w_cmd = (wi,) * self.vehicle.n_rotors
            return ActuatorCommand(self._w_cmd, self.flow, True)
        w = self.cascade.update_attitude(q, self.omega, self.dt)
        self._w_cmd = w
        return ActuatorCommand(w, self.flow, True)

    def status(self) -> AutopilotStatus:
        """Current mode/phase; ``extra`` has the position setpoint sp_x, sp_y, sp_z (ENU m)."""
        return self._status

    def drain_events(self) -> list[Event]:
        """Events since the last call."""
        ev, self._events = self._events, []
        return ev

    def close(self) -> None:
        """Nothing to release (idempotent)."""


    # ------------------------------------------------------------------ outer loop (position-loop rate)
    def _outer(self, obs: Observation) -> None:
        """Tank and battery levels, the senses (terrain, land detector, hover thrust), safety checks,
        the phase, then the position loop; the setpoint (ENU m) and mass estimate (kg) into the status."""
        dt = self.dt_pos
        v = self.vehicle
        level = obs.tank_level_l
        self.tank_empty = v.tank is not None and level <= 1e-6
        self.tank_level_l = level
        self.battery_soc = obs.battery_soc
        self._sense()
        if not self._safety_checks(dt):
            return
        if not self._advance_phase(dt):
            return
        c = self.cascade
        if self.armed and not self.idle:
            if self.airborne and self.ground_contact:
                c.ground_contact()  # PX4: flying but ground contact -> minimum thrust until landed
            else:
                c.update_position(self.pos, self.vel, self.mass, dt)
        ex = self._status.extra
        sp = self._sp
        if sp is None or not self.armed:
            ex["sp_x"] = ex["sp_y"] = ex["sp_z"] = _NAN
        else:
            ex["sp_x"], ex["sp_y"], ex["sp_z"] = sp
        ex["mass_est_kg"] = self.mass
        ex["sortie"] = float(self.sortie)

    def _sense(self) -> None:
        """The terrain under the vehicle, the land detector (ground contact, landed, take-off) and the
        hover thrust estimate, from the estimate, the rangefinder and the last commands."""
        ts = self.terrain_sense
        ld = self.land
        c = self.cascade
        pos, vel = self.pos, self.vel
        ts.update(self.t_us, self._range, pos, self.quat, vel, ld.landed)
        self._range = None
        self.height_terrain = ts.height_agl
        armed = self.armed
        hte = self.hte
        flying = armed and not self.idle
        ld.update(self.t_us, armed, pos[2], vel, self.omega, self.estimator.acc, c.thrust_sp / self.t_max, hte.hover_thrust,
                  hte.valid, c.vel_ff[2] if flying and self._sp is not None else _NAN,
                  dist_bottom=ts.dist_bottom, range_observable=ts.has_range)
        self.ground_contact = ld.ground_contact
        self.landed = ld.landed
        c.freeze_rate_i = ld.maybe_landed or ld.landed
        if not armed or ld.landed:
            self.airborne = False
        elif not self.airborne and self.height_terrain > 0.2:
            self.airborne = True  # take-off detected: not landed and the skids 0.2 m above the ground
        hte.update(self.t_us, armed, ld.landed, self.height_terrain, vel[2], math.sqrt(vel[0] * vel[0] + vel[1] * vel[1]),
                   self.estimator.acc[2], c.thrust_up / self.t_max)
        if hte.valid and hte.hover_thrust != self.hover_thrust:  # PX4 MPC_USE_HTE: fly on the estimate
            self.hover_thrust = hte.hover_thrust
            m = self.hover_thrust * self.t_max / G
            c.update_hover_mass(self.mass, m)
            self.mass = m
