"""THE simulation loop: one vehicle, one PyBullet client, fixed rate, integer-µs clock.

:func:`run_simulation` = :func:`vinecli.sim.setup.prepare_run` (world, mission, vehicle, rows, spawn,
URDF resolved once into a :class:`~vinecli.sim.setup.PreparedRun`) + :func:`simulate` (engine, vehicle
placed and settled, then THE loop: :class:`vinecli.sim.loop.Flight`, set up once from the prepared run, stepped
until the run ends; :func:`vinecli.sim.result.assemble_result` makes the :class:`~vinecli.sim.result.SimResult`).

Per physics step k (t_us = k · dt_us, dt_us = round(1e6 / rate)):

1. read the base state once (position, attitude FLU -> ENU, linear and angular velocity);
   ground-truth acceleration ``a_k = (v_k - v_{k-1}) / dt`` (finite difference over the last
   step, includes contact forces), body rates ``ω_FLU = Rᵀ ω_world``;
2. sensors sample the truth (IMU/baro/mag/GNSS at their own rates, depth camera if enabled);
3. ``autopilot.step(obs)`` -> rotor speed commands, spray flow, armed;
4. motors follow the command over dt (first-order lag), wind ``W(t_k, p_k)``; forces, each law in
   ``flight/`` composed by :class:`vinecli.sim.vehicle_physics.VehiclePhysics`:

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
motors off, liquid weight at the mount): home is that rest pose. Events detected from the truth
(:mod:`vinecli.sim.ground_events`): ``liftoff`` (no contact for 0.05 s with the rotors carrying at least
half the weight -- a bounce or a tumble with idle motors is none), ``touchdown`` (contact again for 0.05 s
after a lift-off), ``crash`` (contact with a vertical speed above ``crash_speed_mps``); and ``tank_empty``.
Plain floats throughout the loop (docs/flight-models.md §6).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING

from vinecli.autopilot.base import Autopilot
from vinecli.flight.battery import Battery
from vinecli.flight.tank import Tank
from vinecli.flight.wind import make_wind
from vinecli.frames import quat_rotate, quat_to_euler
from vinecli.sim.loop import Flight, Plant, fly
from vinecli.sim.result import SimResult, assemble_result
from vinecli.sim.setup import PreparedRun, prepare_run
from vinecli.specs.mission import MissionSpec
from vinecli.specs.vehicle import VehicleSpec
from vinecli.world.model import World

if TYPE_CHECKING:
    from vinecli.spray.deposition import DepositionConfig

__all__ = ["SimResult", "run_simulation", "simulate"]

SPAWN_GAP_M = 0.0  # m between the skids and the terrain at spawn


# parameters: the library's one-call run: keyword-only options with their defaults, handed to prepare_run and
# simulate as they are
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
        :class:`~vinecli.spray.deposition.DepositionConfig` sets its options (cell size, margin, ...).
    """
    wall0 = time.perf_counter()
    with prepare_run(world, mission, vehicle=vehicle, end_on_crash=end_on_crash, crash_speed_mps=crash_speed_mps,
                     deposition=deposition) as run:
        return simulate(run, autopilot, seed=seed, on_progress=on_progress, should_stop=should_stop, wall0=wall0)


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
        flight = Flight(run, Plant(engine, body, tank, battery, wind, home, settle_s), autopilot, seed, on_progress,
                        should_stop)
        wall_loop0 = time.perf_counter()
        cpu_loop0 = time.process_time()
        fly(flight)
        return assemble_result(flight, run, seed, wall0, wall_loop0, cpu_loop0)
