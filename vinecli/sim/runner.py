"""THE simulation loop: one vehicle, one PyBullet client, fixed rate, integer-µs clock.

:func:`run_simulation` = :func:`vinecli.sim.setup.prepare_run` (world, mission, vehicle, rows, spawn,
URDF resolved once into a :class:`~vinecli.sim.setup.PreparedRun`) + :func:`simulate` (engine, vehicle
placed and settled, then THE loop, which unpacks the prepared run into locals once).

Per physics step k (t_us = k · dt_us, dt_us = round(1e6 / rate)):

1. read the base state once (position, attitude FLU -> ENU, linear and angular velocity);
   ground-truth acceleration ``a_k = (v_k - v_{k-1}) / dt`` (finite difference over the last
   step, includes contact forces), body rates ``ω_FLU = Rᵀ ω_world``;
2. sensors sample the truth (IMU/baro/mag/GNSS at their own rates, depth camera if enabled);
3. ``autopilot.step(obs)`` -> rotor speed commands, spray flow, armed;
4. motors follow the command over dt (first-order lag), wind ``W(t_k, p_k)``; forces:

   * rotors: thrust, rotor drag, reaction torque, rolling moment from the apparent air
     velocity at each rotor (``wind - (v + ω × r_i)``, body FLU) -> body wrench about the CoM;
   * wind drag per link j in ``vehicle.drag`` (``c_j = ½ ρ S C_D0``) at its centre of pressure
     r_j: ``F_j = c_j |V_app| V_app``, ``V_app = wind - (v + ω × r_j)``, torque ``r_j × F_j``;
   * tank: liquid mass drained by the flow command, force ``m (g - a_mount)`` at the mount r_t
     with ``a_mount = a_cm + α × r_t + ω × (ω × r_t)``, α the finite difference of ω. The liquid
     is not part of the PyBullet body, so ``a_cm`` is the acceleration of vehicle + liquid under
     this step's forces: ``a_cm = g + (F_ext + F_c) / (M + m)`` with F_ext the rotor and drag
     forces and F_c the ground-contact force of the last step, recovered from the finite
     difference ``F_c = M (a_k - g) - F_ext,k-1 - F_tank,k-1`` (M the rigid mass). At rest this
     gives the liquid weight, in free fall zero, in a steady climb the weight again, and at
     lift-off the inertial jump -- without the one-step lag (and ringing with ratio -m/M) of
     feeding the raw finite-difference acceleration back;

   all summed into ONE world-frame force at the CoM and ONE world-frame torque (two PyBullet
   calls; equivalent to per-link forces because the links are rigidly fixed);
5. record a row every ``1/mission.record_rate_hz`` (preallocated arrays);
6. ``stepSimulation``; termination: autopilot finished, hard impact (crash), max duration
   (TIMEOUT), ``should_stop()`` (INTERRUPTED).

Before t = 0 a vehicle starting on the ground is settled at rest (:meth:`Engine.settle_vehicle`,
motors off, liquid weight at the mount): home is that rest pose. Events detected from the truth:
``liftoff`` (no contact for 0.05 s with the rotors carrying at least half the weight -- a bounce or
a tumble with idle motors is none), ``touchdown`` (contact again for 0.05 s after a lift-off), ``tank_empty``, ``crash`` (contact with a vertical speed
above ``crash_speed_mps``). Plain floats throughout the loop (design.md §8).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from vinecli.autopilot.base import RUNNING, Autopilot, AutopilotContext, AutopilotStatus, RunStatus
from vinecli.errors import AutopilotError
from vinecli.frames import Vec3, quat_to_euler, tilt_angle
from vinecli.physics.battery import Battery
from vinecli.physics.tank import Tank
from vinecli.physics.wind import WindField
from vinecli.sim.recorder import Recorder, timeseries_columns
from vinecli.sim.setup import PreparedRun, prepare_run
from vinecli.specs.mission import MissionSpec, OpenLoopPhase
from vinecli.specs.vehicle import VehicleSpec
from vinecli.types import ActuatorCommand, Event, Observation, RigidState, ServiceRequest
from vinecli.world.engine import Engine
from vinecli.world.model import World

if TYPE_CHECKING:
    from vinecli.physics.deposition import DepositionConfig

__all__ = ["SimResult", "run_simulation", "simulate"]

log = logging.getLogger(__name__)

_DEBOUNCE_S = 0.05  # s of (no) contact before lift-off / touchdown is declared
_LIFTOFF_THRUST_FRAC = 0.5  # rotor thrust / weight when contact is lost, for that to count as a lift-off
_CONTACT_MARGIN_M = 0.6  # m: contacts are queried only when the skids are this close to the grid height
SPAWN_GAP_M = 0.0  # m between the skids and the terrain at spawn
_TOUCH_M = 1e-4  # m: a contact point closer than this counts as touching


@dataclass
class SimResult:
    """Outcome of :func:`run_simulation` (docs/architecture.md)."""

    status: RunStatus
    detail: str
    sim_time_s: float
    wall_time_s: float
    timeseries: dict[str, np.ndarray]
    events: list[Event]
    metrics: dict[str, float]
    terrain_preview: dict[str, np.ndarray]
    #: depth-camera point clouds (t_s, (N, 3) float32 world ENU m), empty when the camera is off
    point_clouds: list[tuple[float, np.ndarray]] = field(default_factory=list)
    #: where the spray landed (vinecli.sim.deposition.DepositionResult); None when nothing was sprayed or when off
    deposition: Any = None
    #: machine-dependent figures, not metrics: loop_wall_s, wall_per_step_us, cpu_per_step_us, real_time_factor
    timing: dict[str, float] = field(default_factory=dict)

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.sim_time_s / self.wall_time_s if self.wall_time_s > 0 else math.inf


def _bounds(world: World) -> tuple[float, float, float, float] | None:
    """The mapped terrain extent (xmin, ymin, xmax, ymax), ENU m, or None when unknown."""
    b = getattr(world.terrain, "bounds", None)
    if b is None or len(b) != 4:
        return None
    return (float(b[0]), float(b[1]), float(b[2]), float(b[3]))


def _first_commands(phase: OpenLoopPhase, n: int) -> list[float]:
    src = phase.rotor_speeds_rad_s if phase.rotor_speeds_rad_s is not None else phase.schedule[0][1]  # type: ignore[index]
    if isinstance(src, (int, float)):
        return [float(src)] * n
    return [float(w) for w in src]


def _serve(req: ServiceRequest, armed: bool, on_ground: bool, tank: Tank | None, battery: Battery | None,
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


def run_simulation(
    world: World,
    mission: MissionSpec,
    autopilot: Autopilot,
    *,
    seed: int,
    vehicle: VehicleSpec | None = None,
    on_progress: Callable[[float, float], None] | None = None,
    should_stop: Callable[[], bool] | None = None,
    end_on_crash: bool = True,
    crash_speed_mps: float = 3.0,
    deposition: bool | DepositionConfig = True,
) -> SimResult:
    """Fly ``mission`` with ``autopilot`` in ``world`` and return the recorded run
    (:func:`~vinecli.sim.setup.prepare_run`, then :func:`simulate`).

    Parameters
    ----------
    world : the built world (:func:`vinecli.world.load_world`).
    mission : mission spec; its overrides (vehicle, payload_kg, tank_fill_l, wind, geofence) and
        the ``initial_state`` of a first ``open_loop`` phase are applied by the set-up.
    autopilot : any :class:`~vinecli.autopilot.base.Autopilot`; reset here, closed by the caller.
    seed : seeds wind turbulence and sensor noise (same seed -> identical time series).
    vehicle : overrides the mission's/world's vehicle.
    on_progress : called about once per simulated second with (sim_time_s, max_duration_s).
    should_stop : polled every 0.1 s simulated; True ends the run as INTERRUPTED.
    end_on_crash : end the run with CRASHED on a hard impact (else only the event is logged).
    crash_speed_mps : vertical speed at first contact above which an impact is a crash, m/s.
    deposition : run the spray transport model (vehicles with a tank): ``SimResult.deposition``; a
        :class:`~vinecli.physics.deposition.DepositionConfig` sets its options (cell size, margin, ...).
    """
    wall0 = time.perf_counter()
    with prepare_run(world, mission, vehicle=vehicle, end_on_crash=end_on_crash, crash_speed_mps=crash_speed_mps,
                     deposition=deposition) as run:
        return simulate(run, autopilot, seed=seed, on_progress=on_progress, should_stop=should_stop, wall0=wall0)


@dataclass(frozen=True)
class _Plant:
    """What :func:`simulate` builds from a prepared run for one seed: the PyBullet engine with the vehicle
    body placed (settled at rest unless it starts airborne or moving), tank, battery and wind field."""

    engine: Engine
    body: int  # PyBullet body id of the vehicle
    tank: Tank | None
    battery: Battery | None
    wind: WindField
    home: Vec3  # CoM at rest at the start, m ENU (AutopilotContext.home_enu)
    settle_s: float  # simulated time the settling before t = 0 took, s


def simulate(
    run: PreparedRun,
    autopilot: Autopilot,
    *,
    seed: int,
    on_progress: Callable[[float, float], None] | None = None,
    should_stop: Callable[[], bool] | None = None,
    wall0: float | None = None,
) -> SimResult:
    """Fly a prepared run (:func:`~vinecli.sim.setup.prepare_run`) with ``autopilot`` and return the
    recorded run; ``seed``, ``on_progress``, ``should_stop`` as :func:`run_simulation`. ``wall0``: the
    ``time.perf_counter()`` the run's wall time counts from (default: now)."""
    from vinecli.frames import quat_rotate
    from vinecli.physics.battery import Battery
    from vinecli.physics.tank import Tank
    from vinecli.physics.wind import make_wind
    from vinecli.world.engine import terrain_engine

    if wall0 is None:
        wall0 = time.perf_counter()
    veh = run.vehicle
    tank = Tank(veh.tank, run.tank_fill_l) if veh.tank is not None else None
    battery = Battery(veh.battery) if veh.battery is not None else None
    wind = make_wind(run.wind, seed, run.dt_us * 1e-6)
    sp = run.spawn
    pos0, quat0 = sp.position_enu, sp.quat_xyzw

    with terrain_engine(run.world.terrain, rate_hz=run.physics_rate_hz, gravity=run.gravity) as engine:
        if not sp.airborne:
            # place the skids exactly on the loaded collision surface (the grid can differ from a
            # mesh by its max error): highest ray hit under the collision box + SPAWN_GAP_M
            bx, by, _bz = veh.frame.collision_box_m
            ground = engine.footprint_height(pos0[0], pos0[1], bx / 2.0, by / 2.0, quat_to_euler(quat0)[2])
            if ground is not None:
                pos0 = (pos0[0], pos0[1], ground + veh.frame.landing_gear_height_m + SPAWN_GAP_M)
        body = engine.load_vehicle(run.urdf, pos0, quat0)
        engine.reset_vehicle(pos0, quat0, sp.velocity_enu, quat_rotate(quat0, sp.omega_flu))
        settle_s = 0.0
        if sp.at_rest:
            # settle at rest BEFORE the clock starts: a vehicle on a slope or a ridge tilts/slides
            # here, so t = 0 is a true rest state (no contact flicker -> no spurious events)
            rest = engine.settle_vehicle(liquid_kg=tank.mass_kg if tank is not None else 0.0,
                                         mount_flu=tank.mount_m if tank is not None else (0.0, 0.0, 0.0))
            pos0, quat0, settle_s = rest.pos, rest.quat, rest.time_s
        home = sp.home_enu if sp.airborne and sp.home_enu is not None else pos0
        engine.client.performCollisionDetection()  # contacts are known at t = 0
        plant = _Plant(engine, body, tank, battery, wind, home, settle_s)
        return _loop(run, plant, autopilot, seed, on_progress, should_stop, wall0)


def _raiser(exc: AutopilotError) -> Callable[[Observation], ActuatorCommand]:
    """A step function that re-raises the backend's failure at the first step."""
    def step(_obs: Observation) -> ActuatorCommand:
        raise exc
    return step


def _loop(  # noqa: C901 - the loop is deliberately one flat function
    run: PreparedRun,
    plant: _Plant,
    autopilot: Autopilot,
    seed: int,
    on_progress: Callable[[float, float], None] | None,
    should_stop: Callable[[], bool] | None,
    wall0: float,
) -> SimResult:
    """THE loop (module doc) from t = 0 to the end of the run. Everything the steps read is unpacked into
    locals here, once: the per-step code touches no dataclass attribute of ``run`` or ``plant``."""
    from vinecli.physics.motor import MotorBank
    from vinecli.physics.sensors import make_sensors

    world = run.world
    mission = run.flight
    veh = run.vehicle
    engine = plant.engine
    body = plant.body
    tank = plant.tank
    battery = plant.battery
    wind = plant.wind
    home = plant.home
    g = run.gravity
    g_vec: Vec3 = (0.0, 0.0, -g)
    dt_us = run.dt_us
    dt = dt_us * 1e-6
    inv_dt = 1.0 / dt
    lgh = veh.frame.landing_gear_height_m
    rigid_mass = run.rigid_mass_kg
    mass0 = rigid_mass + (tank.mass_kg if tank is not None else 0.0)
    airborne_start = run.spawn.airborne
    n_rot = veh.n_rotors
    from vinecli.physics.pump import Pump

    pump = Pump(veh.sprayer.pump, veh.tank.nozzle_max_flow_lps if veh.tank is not None else 0.0)

    motors = MotorBank(veh.motor, list(veh.rotors))
    spin_up = run.spawn.spin_up
    if airborne_start and spin_up is not None:
        cmds = _first_commands(spin_up, n_rot)
        motors.reset(cmds)
    sensors = make_sensors(veh.sensors, world.origin, seed, g=g)

    camera = None
    cam_spec = veh.sensors.depth_camera
    if cam_spec.enabled:
        from vinecli.sim.camera import DepthCamera

        camera = DepthCamera(engine.client, cam_spec, rng=np.random.default_rng(np.random.SeedSequence(seed).spawn(8)[7]),
                             hide_body=body)
    point_clouds: list[tuple[float, np.ndarray]] = []
    emitter = None
    group_s = 0.04
    if run.deposition:
        from vinecli.physics.deposition import DepositionConfig, SprayEmitter

        emitter = SprayEmitter()
        group_s = (run.deposition_config or DepositionConfig()).group_s
    emit = emitter.emit if emitter is not None else None
    dep_every = max(1, int(round(group_s / (dt_us * 1e-6))))  # spraying steps summed per deposition record
    dep_vol = 0.0
    dep_n = 0
    cam_period_us = int(round(1e6 / cam_spec.rate_hz))
    next_cam_us = 0

    ctx = AutopilotContext(
        mission=mission,
        vehicle=veh,
        origin=world.origin,
        home_enu=home,
        physics_dt_us=dt_us,
        total_mass_kg=mass0,
        vine_rows_enu=run.rows,
        geofence=run.geofence,
        terrain_height=world.terrain_height,
        seed=seed,
        terrain_bounds=_bounds(world),
    )
    ap_step: Callable[[Observation], ActuatorCommand] = autopilot.step
    ap_status = autopilot.status
    ap_drain = autopilot.drain_events
    try:
        autopilot.reset(ctx)
    except AutopilotError as exc:  # e.g. PX4 never connected: the run ends at t = 0 with status error
        ap_step = _raiser(exc)
    idle_cmd = ActuatorCommand((0.0,) * n_rot, 0.0, False)

    # drag links: (c kg/m, r FLU)
    rho = world.air_density
    drag_all = [(d.coefficient(rho), float(d.position_m[0]), float(d.position_m[1]), float(d.position_m[2]))
                for d in veh.drag.values()]
    drag_c0 = sum(c_ for c_, x_, y_, z_ in drag_all if x_ == y_ == z_ == 0.0)
    drag_links = tuple(d for d in drag_all if d[1:] != (0.0, 0.0, 0.0))
    sqrt = math.sqrt
    if tank is not None:
        tmx, tmy, tmz = tank.mount_m
    else:
        tmx = tmy = tmz = 0.0
    gx, gy, gz = g_vec
    if battery is not None:  # electrical load = shaft / eta + avionics + pump (physics/battery.py)
        b_spec = battery.spec
        inv_eta = 1.0 / b_spec.motor_efficiency
        avionics_w = b_spec.avionics_w
        pump_w_per_lps = (b_spec.pump_w_at_max_flow / tank.spec.nozzle_max_flow_lps) if tank is not None else 0.0
    energy_j = 0.0

    columns = timeseries_columns(n_rot)
    rec_period_us = max(dt_us, int(round(1e6 / mission.record_rate_hz)))
    max_us = int(round(mission.max_duration_s * 1e6))
    rec = Recorder(columns, max_us // rec_period_us + 4)
    next_rec_us = 0

    # raw pybullet functions with the client id passed positionally: ~0.4 µs less per call than
    # BulletClient's keyword partials (5 calls per step)
    pb = engine.p
    cid = engine.client._client
    get_po = pb.getBasePositionAndOrientation
    get_v = pb.getBaseVelocity
    apply_f = pb.applyExternalForce
    apply_t = pb.applyExternalTorque
    contacts = pb.getContactPoints  # (bodyA, bodyB=-1, linkIndexA=-2, linkIndexB=-2, client)
    step_sim = pb.stepSimulation
    world_frame = pb.WORLD_FRAME
    # the terrain under the vehicle (= World.terrain_height, called here without its bound-method layer)
    grid = world.terrain.grid
    flat_z = world.terrain.flat_z

    events: list[Event] = []
    metrics: dict[str, float] = {
        "liftoff_s": math.nan,
        "touchdown_s": math.nan,
        "tank_empty_s": math.nan,
        "total_mass_start_kg": mass0,
        "rigid_mass_kg": rigid_mass,
        "liquid_start_kg": mass0 - rigid_mass,
        "hover_w_pred": veh.hover_speed(mass0, g),
        "physics_rate_hz": 1e6 / dt_us,
        "max_impact_speed_mps": 0.0,
        "spawn_settle_s": plant.settle_s,
        "spawn_tilt_rad": tilt_angle(get_po(body, cid)[1]),
    }
    debounce = max(1, int(round(_DEBOUNCE_S / dt)))
    airborne = airborne_start
    flip_count = 0
    flip_t_us = 0
    flip_thrust = False
    tank_was_empty = tank.empty if tank is not None else True
    impact_pending = True  # the next first contact is an impact to measure
    end_on_crash = run.end_on_crash
    crash_speed = run.crash_speed_mps
    progress_every = max(1, int(round(1.0 / dt)))
    stop_every = max(1, int(round(0.1 / dt)))

    status = RUNNING
    detail = ""
    gnss_lat = gnss_lon = gnss_alt = math.nan
    baro_alt = math.nan
    # PyBullet's state as floats (compiled, these are C doubles: the loop's arithmetic is unboxed)
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
    vpx: float
    vpy: float
    vpz: float
    opx: float
    opy: float
    opz: float
    vpx, vpy, vpz = get_v(body, cid)[0]
    opx, opy, opz = get_v(body, cid)[1]
    first_step = True
    airborne0 = airborne_start
    pex = pey = pez = ptx = pty = ptz = 0.0
    flow_cmd = 0.0
    k = 0
    wall_loop0 = time.perf_counter()
    cpu_loop0 = time.process_time()
    t_us = 0
    while True:
        t_us = k * dt_us
        t = t_us * 1e-6
        (px, py, pz), quat = get_po(body, cid)
        (vx, vy, vz), (ox, oy, oz) = get_v(body, cid)
        qx, qy, qz, qw = quat
        # rotation matrix body FLU -> world ENU (rows)
        xx, yy, zz = qx * qx, qy * qy, qz * qz
        xy, xz, yz = qx * qy, qx * qz, qy * qz
        wx_, wy_, wz_ = qw * qx, qw * qy, qw * qz
        r00, r01, r02 = 1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz_), 2.0 * (xz + wy_)
        r10, r11, r12 = 2.0 * (xy + wz_), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - wx_)
        r20, r21, r22 = 2.0 * (xz - wy_), 2.0 * (yz + wx_), 1.0 - 2.0 * (xx + yy)
        if first_step:
            ax = ay = az = 0.0
            alx = aly = alz = 0.0
        else:
            ax, ay, az = (vx - vpx) * inv_dt, (vy - vpy) * inv_dt, (vz - vpz) * inv_dt
            alx, aly, alz = (ox - opx) * inv_dt, (oy - opy) * inv_dt, (oz - opz) * inv_dt
        omega_body = (r00 * ox + r10 * oy + r20 * oz, r01 * ox + r11 * oy + r21 * oz, r02 * ox + r12 * oy + r22 * oz)
        tz_ = grid.height(px, py) if grid is not None else flat_z
        agl = pz - tz_ - lgh
        on_ground = False
        if agl < _CONTACT_MARGIN_M:
            # PyBullet also lists points within its contact threshold (a few mm apart): count only
            # points that carried a normal force in the last step or are closer than 0.1 mm
            for cp in contacts(body, -1, -2, -2, cid):
                if cp[9] > 0.0 or cp[8] <= _TOUCH_M:
                    on_ground = True
                    break

        # ---- events from the truth
        if on_ground != (not airborne):
            if flip_count == 0:
                flip_t_us = t_us
                # a lift-off needs the rotors to carry at least half the weight (thrust of the last
                # step); a vehicle tumbling or bouncing with idle motors does not "lift off"
                flip_thrust = motors.thrust_total >= _LIFTOFF_THRUST_FRAC * g * (
                    rigid_mass + (tank.mass_kg if tank is not None else 0.0))
            flip_count += 1
            if on_ground and impact_pending:
                impact_pending = False
                vimp = -vpz
                if vimp > metrics["max_impact_speed_mps"]:
                    metrics["max_impact_speed_mps"] = vimp
                if vimp > crash_speed:
                    events.append(Event(t_us, "crash", f"hard impact at {vimp:.2f} m/s vertical",
                                        {"impact_speed_mps": vimp}))
                    if end_on_crash and status is RUNNING:
                        status = RunStatus.CRASHED
                        detail = f"{RunStatus.CRASHED.message} (impact {vimp:.2f} m/s > {crash_speed:.1f} m/s)"
            if flip_count >= debounce and not on_ground and not (
                    flip_thrust or motors.thrust_total >= _LIFTOFF_THRUST_FRAC * g * (
                        rigid_mass + (tank.mass_kg if tank is not None else 0.0))):
                impact_pending = True  # off the ground without thrust (bounce, tumble): no lift-off event
            elif flip_count >= debounce:
                airborne = not on_ground
                flip_count = 0
                ts = flip_t_us * 1e-6
                if airborne:
                    impact_pending = True
                    events.append(Event(flip_t_us, "liftoff", f"lift-off at {ts:.3f} s", {"z_m": pz}))
                    if math.isnan(metrics["liftoff_s"]):
                        metrics["liftoff_s"] = ts
                else:
                    events.append(Event(flip_t_us, "touchdown", f"touchdown at {ts:.3f} s", {"z_m": pz}))
                    metrics["touchdown_s"] = ts
        else:
            flip_count = 0
            if not on_ground:
                impact_pending = True

        truth = RigidState(t_us, (px, py, pz), quat, (vx, vy, vz), omega_body, (ax, ay, az), on_ground)
        imu, baro, mag, gnss = sensors.sample_all(truth)
        if battery is not None:
            soc, volt = battery.soc, battery.voltage_v
        else:
            soc = volt = math.nan
        obs = Observation(t_us, truth, imu, baro, mag, gnss, tz_, tank.level_l if tank is not None else 0.0, soc, volt)
        try:
            cmd = ap_step(obs)
            st = ap_status()
        except AutopilotError as exc:  # the backend failed (PX4 gone, rejected arming...): keep the run so far
            cmd = idle_cmd
            st = AutopilotStatus(mode="error", phase_index=st.phase_index if k else 0, status=RunStatus.ERROR, detail=str(exc))
            events.append(Event(t_us, "autopilot_error", str(exc), {}))
        if cmd.service is not None:
            tank_was_empty = _serve(cmd.service, cmd.armed, on_ground, tank, battery, t_us, events, tank_was_empty)
        new_events = ap_drain()
        if new_events:
            for ev in new_events:
                if ev.kind == "failsafe":  # where the vehicle really was (the autopilot knows its estimate)
                    ev.data["position_enu"] = [px, py, pz]
            events.extend(new_events)
        if camera is not None and t_us >= next_cam_us:
            next_cam_us += cam_period_us
            point_clouds.append((t, camera.capture((px, py, pz), quat)))

        # ---- forces for the step t_k -> t_k+1 (interval means of the lagged speeds; motor.py)
        motors.update(cmd.rotor_speed_cmd, dt)
        wind_v = wind.velocity(t, (px, py, pz))
        wdx, wdy, wdz = wind_v
        # apparent air at each rotor, body FLU: R^T (wind - v) - ω_b × r_i
        ux, uy, uz = wdx - vx, wdy - vy, wdz - vz
        bax = r00 * ux + r10 * uy + r20 * uz
        bay = r01 * ux + r11 * uy + r21 * uz
        baz = r02 * ux + r12 * uy + r22 * uz
        obx, oby, obz = omega_body
        (fbx, fby, fbz), (tbx, tby, tbz) = motors.wrench_com(bax, bay, baz, obx, oby, obz)
        fx = r00 * fbx + r01 * fby + r02 * fbz
        fy = r10 * fbx + r11 * fby + r12 * fbz
        fz = r20 * fbx + r21 * fby + r22 * fbz
        tx = r00 * tbx + r01 * tby + r02 * tbz
        ty = r10 * tbx + r11 * tby + r12 * tbz
        tz = r20 * tbx + r21 * tby + r22 * tbz
        dgx = dgy = dgz = 0.0
        if drag_c0 > 0.0:  # links whose centre of pressure is the CoM: no lever arm
            ux, uy, uz = wdx - vx, wdy - vy, wdz - vz
            kd = drag_c0 * sqrt(ux * ux + uy * uy + uz * uz)
            dgx, dgy, dgz = kd * ux, kd * uy, kd * uz
        for cd, rbx, rby, rbz in drag_links:
            rx = r00 * rbx + r01 * rby + r02 * rbz
            ry = r10 * rbx + r11 * rby + r12 * rbz
            rz = r20 * rbx + r21 * rby + r22 * rbz
            # V_app = wind - (v + ω × r)
            ux = wdx - vx - (oy * rz - oz * ry)
            uy = wdy - vy - (oz * rx - ox * rz)
            uz = wdz - vz - (ox * ry - oy * rx)
            kd = cd * sqrt(ux * ux + uy * uy + uz * uz)
            f0, f1, f2 = kd * ux, kd * uy, kd * uz
            dgx += f0
            dgy += f1
            dgz += f2
            tx += ry * f2 - rz * f1
            ty += rz * f0 - rx * f2
            tz += rx * f1 - ry * f0
        fx += dgx
        fy += dgy
        fz += dgz
        if tank is not None:
            flow_cmd = cmd.spray_flow_lps
            tank.update(pump.update(flow_cmd, dt), dt)
            if emit is not None:  # deposition model: volume summed over <= 0.04 s, one record per group
                f_ = tank.flow_lps
                if f_ > 0.0:
                    dep_vol += f_ * dt
                    dep_n += 1
                if dep_n and (dep_n >= dep_every or f_ <= 0.0):
                    # state now; the volume left the nozzles on average (n - 1) / 2 steps earlier
                    emit((t, px, py, pz, qx, qy, qz, qw, vx, vy, vz, wdx, wdy, wdz, motors.thrust_total, dep_vol,
                          0.5 * (dep_n - 1) * dt))
                    dep_vol = 0.0
                    dep_n = 0
            # contact force of the last step from the finite-difference acceleration:
            # F_c = M (a - g) - F_ext,prev - F_tank,prev (M = rigid PyBullet mass)
            if first_step:
                if airborne0:
                    ccx = ccy = ccz = 0.0
                else:  # resting: the ground carries everything
                    m_all = rigid_mass + tank.mass_kg
                    ccx, ccy, ccz = -m_all * gx, -m_all * gy, -m_all * gz
            else:
                ccx = rigid_mass * (ax - gx) - pex - ptx
                ccy = rigid_mass * (ay - gy) - pey - pty
                ccz = rigid_mass * (az - gz) - pez - ptz
            pex, pey, pez = fx, fy, fz  # external forces of this step without the tank
            inv_m = 1.0 / (rigid_mass + tank.mass_kg)
            rx = r00 * tmx + r01 * tmy + r02 * tmz
            ry = r10 * tmx + r11 * tmy + r12 * tmz
            rz = r20 * tmx + r21 * tmy + r22 * tmz
            # a_mount = a_cm + α × r + ω × (ω × r), a_cm of vehicle + liquid under this step's forces
            cx, cy, cz = oy * rz - oz * ry, oz * rx - ox * rz, ox * ry - oy * rx
            amx = (fx + ccx) * inv_m + gx + (aly * rz - alz * ry) + (oy * cz - oz * cy)
            amy = (fy + ccy) * inv_m + gy + (alz * rx - alx * rz) + (oz * cx - ox * cz)
            amz = (fz + ccz) * inv_m + gz + (alx * ry - aly * rx) + (ox * cy - oy * cx)
            f0, f1, f2 = tank.force_world(g_vec, (amx, amy, amz))
            ptx, pty, ptz = f0, f1, f2
            fx += f0
            fy += f1
            fz += f2
            tx += ry * f2 - rz * f1
            ty += rz * f0 - rx * f2
            tz += rx * f1 - ry * f0
            if not tank_was_empty and tank.empty:
                tank_was_empty = True
                te = t + dt
                events.append(Event(t_us + dt_us, "tank_empty", f"tank empty at {te:.3f} s", {}))
                metrics["tank_empty_s"] = te

        if battery is not None:  # = physics.battery.electrical_power_w, multiplied out for the loop
            battery.update(motors.shaft_power * inv_eta + avionics_w
                     + (pump_w_per_lps * tank.flow_lps if tank is not None else 0.0), dt)
            energy_j += battery.power_drawn_w * dt

        # ---- termination (the state at t_k is recorded below, always for the last step)
        if status is RUNNING:
            if st.status is not RUNNING:
                status, detail = st.status, st.detail or st.status.message
            elif t_us >= max_us:
                status, detail = RunStatus.TIMEOUT, f"{RunStatus.TIMEOUT.message} ({mission.max_duration_s:g} s)"
            elif should_stop is not None and k % stop_every == 0 and should_stop():
                status, detail = RunStatus.INTERRUPTED, RunStatus.INTERRUPTED.message

        # ---- record
        if t_us >= next_rec_us or status is not RUNNING:
            next_rec_us += rec_period_us
            if baro is not None:
                baro_alt = baro.altitude_m
            if gnss is not None:
                gnss_lat, gnss_lon, gnss_alt = gnss.lat_deg, gnss.lon_deg, gnss.alt_m
            roll, pitch, yaw = quat_to_euler(quat)
            row = [t, px, py, pz, vx, vy, vz, ax, ay, az, qx, qy, qz, qw, roll, pitch, yaw, tilt_angle(quat),
                   omega_body[0], omega_body[1], omega_body[2]]
            w = motors.w_start  # the speeds at t_k (the row's time)
            wc = cmd.rotor_speed_cmd
            thr = motors.thrust
            for i in range(n_rot):
                row += (w[i], wc[i], thr[i])
            rd = motors.rotor_drag_body
            row += (motors.thrust_total, wdx, wdy, wdz, wdx - vx, wdy - vy, wdz - vz, dgx, dgy, dgz, rd[0], rd[1], rd[2])
            if tank is not None:
                tf, tgf, tif = tank.force, tank.gravity_force, tank.inertial_force
                row += (tank.level_l, tank.mass_kg, tank.flow_lps, flow_cmd, tf[0], tf[1], tf[2], tgf[2],
                        tif[0], tif[1], tif[2], rigid_mass + tank.mass_kg)
            else:
                row += (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, rigid_mass)
            ia, ig = imu.accel_flu, imu.gyro_flu
            ex = st.extra
            row += (ia[0], ia[1], ia[2], ig[0], ig[1], ig[2], baro_alt, gnss_lat, gnss_lon, gnss_alt,
                    tz_, agl, 1.0 if on_ground else 0.0,
                    ex.get("sp_x", math.nan), ex.get("sp_y", math.nan), ex.get("sp_z", math.nan),
                    float(st.phase_index), 1.0 if cmd.armed else 0.0)
            if battery is not None:
                row += (battery.soc_start, battery.voltage_v, battery.current_a, battery.power_drawn_w)
            else:
                row += (math.nan, math.nan, math.nan, math.nan)
            row.append(ex.get("sortie", math.nan))
            rec.append(row)

        if status is not RUNNING:
            break

        apply_f(body, -1, (fx, fy, fz), (px, py, pz), world_frame, cid)
        apply_t(body, -1, (tx, ty, tz), world_frame, cid)
        step_sim(cid)
        vpx, vpy, vpz, opx, opy, opz = vx, vy, vz, ox, oy, oz
        first_step = False
        k += 1
        if on_progress is not None and k % progress_every == 0:
            on_progress(k * dt_us * 1e-6, mission.max_duration_s)

    wall_end = time.perf_counter()
    cpu_end = time.process_time()
    sim_time = t_us * 1e-6
    metrics["steps"] = float(k)
    timing = {
        "loop_wall_s": wall_end - wall_loop0,
        "wall_per_step_us": (wall_end - wall_loop0) / max(k, 1) * 1e6,
        "cpu_per_step_us": (cpu_end - cpu_loop0) / max(k, 1) * 1e6,  # process CPU time (robust to load)
        "real_time_factor": sim_time / (wall_end - wall_loop0) if wall_end > wall_loop0 else math.inf,
    }
    metrics["final_mass_kg"] = rigid_mass + (tank.mass_kg if tank is not None else 0.0)
    metrics["energy_wh"] = energy_j / 3600.0 if battery is not None else math.nan
    metrics["battery_soc_end"] = battery.soc if battery is not None else math.nan
    # backend counters (PX4: px4_stalls, px4_lockstep_steps...) into the run's metrics
    metrics.update({name: float(v) for name, v in ap_status().extra.items() if name.startswith("px4_")})
    events.append(Event(t_us, "status", detail, {"status": status.value}))
    dep = None
    if emitter is not None and dep_n:  # the last group of a run that ended spraying
        emitter.emit((t, px, py, pz, qx, qy, qz, qw, vx, vy, vz, wdx, wdy, wdz, motors.thrust_total, dep_vol,
                      0.5 * (dep_n - 1) * dt))
    if emitter is not None and emitter.rows:  # the sprayer was used
        from vinecli.sim.deposition import deposit

        cpu_dep0 = time.process_time()
        dep = deposit(emitter, world, veh, run.wind, seed, run.deposition_config)
        timing["deposition_transport_s"] = dep.transport_s
        timing["deposition_transport_cpu_s"] = time.process_time() - cpu_dep0
        metrics["deposition_records"] = float(len(emitter.rows))
    events.sort(key=lambda e: e.t_us)
    log.info("run ended at %.3f s: %s (%s); %.1f µs/step", sim_time, status.value, detail, timing["wall_per_step_us"])
    return SimResult(
        status=status,
        detail=detail,
        sim_time_s=sim_time,
        wall_time_s=wall_end - wall0,
        timeseries=rec.columns_dict(),
        events=events,
        metrics=metrics,
        terrain_preview=world.terrain_preview(129),
        point_clouds=point_clouds,
        deposition=dep,
        timing=timing,
    )
