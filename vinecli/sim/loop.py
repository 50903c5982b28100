"""THE loop (sim/runner.py module doc): :class:`Flight` is set up once per run from a prepared run and its
plant, then :meth:`Flight.step` advances it one physics step at a time until the run ends.

Everything the steps read is taken out of the run's dataclasses once, in the set-up: a step touches plain
floats and compiled objects (the physics laws, :class:`~vinecli.sim.vehicle_physics.VehiclePhysics`, the
sensors, the ground events), never a pydantic model or a dataclass of the run (docs/flight-models.md §6).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, final

import numpy as np

from vinecli.autopilot.base import RUNNING, Autopilot, AutopilotStatus, RunStatus
from vinecli.errors import AutopilotError, FirmwareUnreachable
from vinecli.flight.aero import body_drag
from vinecli.flight.battery import Battery, ElectricalLoad
from vinecli.flight.motor import MotorBank
from vinecli.flight.pump import Pump
from vinecli.flight.sensors import make_sensors
from vinecli.flight.tank import Tank, TankCoupling
from vinecli.flight.wind import WindField
from vinecli.frames import BodyFrame, Vec3, tilt_angle
from vinecli.sim.autopilot_inputs import autopilot_context, world_rangefinder
from vinecli.sim.ground_events import CONTACT_MARGIN_M, DEBOUNCE_S, LIFTOFF_THRUST_FRAC, GroundEvents, touching
from vinecli.sim.recorder import Recorder
from vinecli.sim.row import Row, timeseries_columns
from vinecli.sim.setup import PreparedRun
from vinecli.sim.spray_groups import SprayGroups
from vinecli.sim.vehicle_physics import VehiclePhysics
from vinecli.specs.mission import OpenLoopPhase
from vinecli.types import (
    ActuatorCommand,
    BaroSample,
    Event,
    GnssSample,
    ImuSample,
    MagSample,
    Observation,
    RigidState,
    ServiceRequest,
)
from vinecli.world.engine import Engine

if TYPE_CHECKING:
    from vinecli.sim.camera import DepthCamera
    from vinecli.spray.deposition import SprayEmitter

__all__ = ["Flight", "Plant", "fly", "serve_ground_request", "vehicle_physics"]

NAN = math.nan
Samples = tuple[ImuSample, BaroSample | None, MagSample | None, GnssSample | None]


@dataclass(frozen=True)
class Plant:
    """What :func:`vinecli.sim.runner.simulate` builds from a prepared run for one seed: the PyBullet engine
    with the vehicle body placed (settled at rest unless it starts airborne or moving), tank, battery, wind."""

    engine: Engine
    body: int  # PyBullet body id of the vehicle
    tank: Tank | None
    battery: Battery | None
    wind: WindField
    home: Vec3  # CoM at rest at the start, m ENU (AutopilotContext.home_enu)
    settle_s: float  # simulated time the settling before t = 0 took, s


def _first_commands(phase: OpenLoopPhase, n: int) -> list[float]:
    src = phase.rotor_speeds_rad_s if phase.rotor_speeds_rad_s is not None else phase.schedule[0][1]  # type: ignore[index]
    if isinstance(src, (int, float)):
        return [float(src)] * n
    return [float(w) for w in src]


def _raiser(exc: AutopilotError) -> Callable[[Observation], ActuatorCommand]:
    """A step function that re-raises the backend's failure at the first step."""
    def step(_obs: Observation) -> ActuatorCommand:
        raise exc
    return step


def serve_ground_request(req: ServiceRequest, armed: bool, on_ground: bool, tank: Tank | None, battery: Battery | None,
           t_us: int, events: list[Event], tank_was_empty: bool) -> bool:
    """The ground crew refills the tank / swaps the battery of a landed, disarmed vehicle (events
    ``refill``, ``battery_swap``); a request in the air is refused (event ``service_refused``).
    Returns the new 'tank was empty' flag of the tank_empty event detector."""
    if armed or not on_ground:
        events.append(Event(t_us, "service_refused", "ground service refused: the vehicle is not landed and disarmed", {}))
        return tank_was_empty
    if tank is not None:
        before = tank.level_l
        tank.refill(req.fill_l)
        events.append(Event(t_us, "refill", f"tank refilled {before:.3f} -> {tank.level_l:.3f} L",
                            {"before_l": before, "level_l": tank.level_l}))
        tank_was_empty = tank.empty
    if req.swap_battery and battery is not None:
        soc = battery.soc
        battery.reset(battery.spec.initial_soc)
        events.append(Event(t_us, "battery_swap", f"battery swapped at {soc * 100:.1f} % state of charge",
                            {"soc_before": soc, "soc": battery.soc}))
    return tank_was_empty


def vehicle_physics(run: PreparedRun, plant: Plant, motors: MotorBank) -> VehiclePhysics:
    """The physics laws of the run's vehicle, composed (:class:`~vinecli.sim.vehicle_physics.VehiclePhysics`)."""
    veh, tank, battery = run.vehicle, plant.tank, plant.battery
    coupling = TankCoupling(tank, run.rigid_mass_kg, (0.0, 0.0, -run.gravity), run.spawn.airborne) if tank else None
    load = ElectricalLoad(battery.spec, tank.spec.nozzle_max_flow_lps if tank is not None else None) if battery else None
    pump = Pump(veh.sprayer.pump, tank.spec.nozzle_max_flow_lps) if tank is not None else None
    return VehiclePhysics(motors, plant.wind, body_drag(veh.drag, run.world.air_density), tank, coupling, battery, load,
                          run.rigid_mass_kg, pump)


@final
class Flight:
    """One run of THE loop (module doc): ``step()`` until it returns False, then the outcome is in
    ``status``, ``detail``, ``events``, ``metrics``, the recorder ``rec`` and the parts it flew."""

    def __init__(self, run: PreparedRun, plant: Plant, autopilot: Autopilot, seed: int,
                 on_progress: Callable[[float, float], None] | None, should_stop: Callable[[], bool] | None) -> None:
        world, veh, engine = run.world, run.vehicle, plant.engine
        self.dt_us = run.dt_us
        self.dt = self.dt_us * 1e-6
        self.inv_dt = 1.0 / self.dt
        self.g = run.gravity
        self.lgh = veh.frame.landing_gear_height_m
        self.rigid_mass = run.rigid_mass_kg
        self.tank, self.battery, self.body = plant.tank, plant.battery, plant.body
        motors = MotorBank(veh.motor, list(veh.rotors))
        if run.spawn.airborne and run.spawn.spin_up is not None:
            motors.reset(_first_commands(run.spawn.spin_up, veh.n_rotors))
        self.sensors = make_sensors(veh.sensors, world.origin, seed, g=self.g)
        self._start_camera(engine, run, seed)
        self._start_sprayer(run)
        self.physics = vehicle_physics(run, plant, motors)
        self._start_autopilot(run, plant, autopilot, seed, should_stop)
        self.rec_period_us = max(self.dt_us, int(round(1e6 / run.flight.record_rate_hz)))
        self.max_duration_s = run.flight.max_duration_s
        self.max_us = int(round(self.max_duration_s * 1e6))
        self.rec = Recorder(timeseries_columns(veh.n_rotors), self.max_us // self.rec_period_us + 4)
        self.row = Row(veh.n_rotors)
        # raw pybullet functions with the client id passed positionally: ~0.4 µs less per call than
        # BulletClient's keyword partials (5 calls per step)
        pb = engine.p
        self.cid: int = engine.client._client
        self.get_po: Callable[..., Any] = pb.getBasePositionAndOrientation
        self.get_v: Callable[..., Any] = pb.getBaseVelocity
        self.apply_f: Callable[..., Any] = pb.applyExternalForce
        self.apply_t: Callable[..., Any] = pb.applyExternalTorque
        self.contacts: Callable[..., Any] = pb.getContactPoints  # (bodyA, bodyB=-1, linkIndexA=-2, linkIndexB=-2, client)
        self.step_sim: Callable[..., Any] = pb.stepSimulation
        self.world_frame: int = pb.WORLD_FRAME
        # the terrain under the vehicle (= World.terrain_height, called here without its bound-method layer)
        self.grid, self.flat_z = world.terrain.grid, world.terrain.flat_z
        mass0 = self.physics.mass_kg()
        self.events: list[Event] = []
        self.metrics: dict[str, float] = {
            "liftoff_s": NAN, "touchdown_s": NAN, "tank_empty_s": NAN, "total_mass_start_kg": mass0,
            "rigid_mass_kg": self.rigid_mass, "liquid_start_kg": mass0 - self.rigid_mass,
            "hover_w_pred": veh.hover_speed(mass0, self.g), "physics_rate_hz": 1e6 / self.dt_us, "max_impact_speed_mps": 0.0,
            "spawn_settle_s": plant.settle_s, "spawn_tilt_rad": tilt_angle(self.get_po(self.body, self.cid)[1]),
        }
        self.ground = GroundEvents(max(1, int(round(DEBOUNCE_S / self.dt))), run.spawn.airborne, run.crash_speed_mps,
                                   self.events, self.metrics)
        self.end_on_crash = run.end_on_crash
        self.on_progress, self.should_stop = on_progress, should_stop
        self.progress_every = max(1, int(round(1.0 / self.dt)))
        self.stop_every = max(1, int(round(0.1 / self.dt)))
        self.frame = BodyFrame()
        self.status: RunStatus = RUNNING
        self.detail = ""
        self.st = AutopilotStatus(mode="", phase_index=0)
        self.tank_was_empty = self.tank.empty if self.tank is not None else True
        self.gnss: tuple[float, float, float] = (NAN, NAN, NAN)
        self.baro_alt = NAN
        self.v_prev: Vec3 = self.get_v(self.body, self.cid)[0]
        self.omega_prev: Vec3 = self.get_v(self.body, self.cid)[1]
        self.first = True
        self.k = self.t_us = self.next_rec_us = 0

    def _start_camera(self, engine: Engine, run: PreparedRun, seed: int) -> None:
        cam_spec = run.vehicle.sensors.depth_camera
        self.camera: DepthCamera | None = None
        if cam_spec.enabled:
            from vinecli.sim.camera import DepthCamera

            rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(8)[7])
            self.camera = DepthCamera(engine.client, cam_spec, rng=rng, hide_body=self.body)
        self.point_clouds: list[tuple[float, np.ndarray]] = []
        self.cam_period_us = int(round(1e6 / cam_spec.rate_hz))
        self.next_cam_us = 0

    def _start_sprayer(self, run: PreparedRun) -> None:
        """The spray records for the transport model (run.deposition), grouped (sim/spray_groups.py)."""
        self.emitter: SprayEmitter | None = None
        self.groups: SprayGroups | None = None
        if run.deposition:
            from vinecli.spray.deposition import DepositionConfig, SprayEmitter

            self.emitter = SprayEmitter()
            group_s = (run.deposition_config or DepositionConfig()).group_s
            if self.tank is not None:  # spraying steps summed per deposition record
                self.groups = SprayGroups(self.emitter.emit, max(1, int(round(group_s / (self.dt_us * 1e-6)))), self.dt)

    def _start_autopilot(self, run: PreparedRun, plant: Plant, autopilot: Autopilot, seed: int,
                         should_stop: Callable[[], bool] | None) -> None:
        world = run.world
        ctx = autopilot_context(run, plant.home, self.dt_us, seed, should_stop)
        rangefinder = world_rangefinder(world, run, seed)
        self.rf_sample = rangefinder.sample if rangefinder is not None else None
        self.ap_step: Callable[[Observation], ActuatorCommand] = autopilot.step
        self.ap_status: Callable[[], AutopilotStatus] = autopilot.status
        self.ap_drain: Callable[[], list[Event]] = autopilot.drain_events
        try:
            autopilot.reset(ctx)
        except FirmwareUnreachable:  # an external firmware that is not there: no run to write (exit 2)
            raise
        except AutopilotError as exc:  # e.g. the PX4 vinecli started died at boot: the run ends at t = 0, status error
            self.ap_step = _raiser(exc)
        self.idle_cmd = ActuatorCommand((0.0,) * run.vehicle.n_rotors, 0.0, False)

    def _observe(self, truth: RigidState) -> tuple[ActuatorCommand, Samples]:
        """Sensors sample the truth (the rangefinder the world's terrain), the autopilot flies on what they give:
        (command, samples)."""
        samples = self.sensors.sample_all(truth)
        imu, baro, mag, gnss = samples
        tank, battery = self.tank, self.battery
        soc, volt, amps = (battery.soc, battery.voltage_v, battery.current_a) if battery is not None else (NAN, NAN, NAN)
        rng = self.rf_sample(truth.t_us, truth.pos, truth.quat) if self.rf_sample is not None else None
        obs = Observation(truth.t_us, truth, imu, baro, mag, gnss, rng, tank.level_l if tank is not None else 0.0,
                          soc, volt, amps)
        try:
            cmd = self.ap_step(obs)
            self.st = self.ap_status()
        except AutopilotError as exc:  # the backend failed (PX4 gone, rejected arming...): keep the run so far
            cmd = self.idle_cmd
            self.st = AutopilotStatus(mode="error", phase_index=self.st.phase_index if self.k else 0,
                                      status=RunStatus.ERROR, detail=str(exc))
            self.events.append(Event(truth.t_us, "autopilot_error", str(exc), {}))
        return cmd, samples

    def step(self) -> bool:
        """One physics step t_k -> t_k+1 (sim/runner.py module doc, steps 1-6); False once the run has ended
        (the state at t_k recorded, nothing applied)."""
        # PyBullet's state as floats (compiled, these are C doubles: the step's arithmetic is unboxed)
        px: float
        py: float
        pz: float
        qx: float
        qy: float
        qz: float
        qw: float
        vx: float
        vy: float
        vz: float
        ox: float
        oy: float
        oz: float
        t_us = self.k * self.dt_us
        self.t_us = t_us
        t = t_us * 1e-6
        body, cid = self.body, self.cid
        (px, py, pz), quat = self.get_po(body, cid)
        (vx, vy, vz), (ox, oy, oz) = self.get_v(body, cid)
        qx, qy, qz, qw = quat
        frame = self.frame
        frame.set(qx, qy, qz, qw)
        vpx, vpy, vpz = self.v_prev
        if self.first:
            acc = alpha = (0.0, 0.0, 0.0)
        else:
            opx, opy, opz = self.omega_prev
            inv_dt = self.inv_dt
            acc = ((vx - vpx) * inv_dt, (vy - vpy) * inv_dt, (vz - vpz) * inv_dt)
            alpha = ((ox - opx) * inv_dt, (oy - opy) * inv_dt, (oz - opz) * inv_dt)
        omega_body = frame.to_body(ox, oy, oz)
        grid = self.grid
        tz_ = grid.height(px, py) if grid is not None else self.flat_z
        agl = pz - tz_ - self.lgh
        on_ground = agl < CONTACT_MARGIN_M and touching(self.contacts, body, cid)
        physics = self.physics
        lifting = physics.motors.thrust_total >= LIFTOFF_THRUST_FRAC * self.g * physics.mass_kg()
        if self.ground.update(on_ground, t_us, vpz, pz, lifting) and self.end_on_crash and self.status is RUNNING:
            self.status = RunStatus.CRASHED
            self.detail = (f"{RunStatus.CRASHED.message} (impact {self.ground.impact_mps:.2f} m/s > "
                           f"{self.ground.crash_speed:.1f} m/s)")
        pos, vel = (px, py, pz), (vx, vy, vz)
        truth = RigidState(t_us, pos, quat, vel, omega_body, acc, on_ground)
        cmd, (imu, baro, _mag, gnss) = self._observe(truth)
        events, tank = self.events, self.tank
        if cmd.service is not None:
            self.tank_was_empty = serve_ground_request(cmd.service, cmd.armed, on_ground, tank, self.battery, t_us, events,
                                         self.tank_was_empty)
        new_events = self.ap_drain()
        if new_events:
            for ev in new_events:
                if ev.kind == "failsafe":  # where the vehicle really was (the autopilot knows its estimate)
                    ev.data["position_enu"] = [px, py, pz]
            events.extend(new_events)
        if self.camera is not None and t_us >= self.next_cam_us:
            self.next_cam_us += self.cam_period_us
            self.point_clouds.append((t, self.camera.capture(pos, quat)))

        # ---- forces for the step t_k -> t_k+1 (interval means of the lagged speeds; motor.py)
        force, torque = physics.step(frame, t, pos, vel, (ox, oy, oz), omega_body, acc, alpha, cmd, self.dt)
        if tank is not None:
            if self.groups is not None:  # deposition model: volume summed over <= 0.04 s, one record per group
                self.groups.add(tank.flow_lps, t, pos, quat, vel, physics.wind, physics.motors.thrust_total)
            if not self.tank_was_empty and tank.empty:
                self.tank_was_empty = True
                te = t + self.dt
                events.append(Event(t_us + self.dt_us, "tank_empty", f"tank empty at {te:.3f} s", {}))
                self.metrics["tank_empty_s"] = te

        # ---- termination (the state at t_k is recorded below, always for the last step)
        st = self.st
        if self.status is RUNNING:
            if st.status is not RUNNING:
                self.status, self.detail = st.status, st.detail or st.status.message
            elif t_us >= self.max_us:
                self.status, self.detail = RunStatus.TIMEOUT, f"{RunStatus.TIMEOUT.message} ({self.max_duration_s:g} s)"
            elif self.should_stop is not None and self.k % self.stop_every == 0 and self.should_stop():
                self.status, self.detail = RunStatus.INTERRUPTED, RunStatus.INTERRUPTED.message
        running = self.status is RUNNING
        if t_us >= self.next_rec_us or not running:
            self.next_rec_us += self.rec_period_us
            if baro is not None:
                self.baro_alt = baro.altitude_m
            if gnss is not None:
                self.gnss = (gnss.lat_deg, gnss.lon_deg, gnss.alt_m)
            self._record(truth, cmd, imu, terrain_z=tz_, agl=agl)
        if not running:
            return False
        self.apply_f(body, -1, force, pos, self.world_frame, cid)
        self.apply_t(body, -1, torque, self.world_frame, cid)
        self.step_sim(cid)
        self.v_prev, self.omega_prev = vel, (ox, oy, oz)
        self.first = False
        self.k += 1
        if self.on_progress is not None and self.k % self.progress_every == 0:
            self.on_progress(self.k * self.dt_us * 1e-6, self.max_duration_s)
        return True

    def _record(self, truth: RigidState, cmd: ActuatorCommand, imu: ImuSample, terrain_z: float, agl: float) -> None:
        """One time-series row (sim/row.py) of the state ``truth``, flown with ``cmd``."""
        row = self.row
        row.set_truth(truth)
        self.physics.record(row, cmd, truth.vel)
        row.set_sensors(imu, self.baro_alt, self.gnss)
        row.set_ground(terrain_z=terrain_z, agl=agl, on_ground=truth.on_ground)
        row.set_autopilot(self.st, cmd.armed)
        self.rec.append(row.values())


def fly(flight: Flight) -> None:
    """Step ``flight`` until its run ends."""
    while flight.step():
        pass
