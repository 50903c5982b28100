"""Micro-benchmark of the per-step physics models (no PyBullet), µs per call.

Usage: ``python benchmarks/physics.py [--quick] [--vehicle x500-sprayer]``

Budget (docs/flight-models.md §6): the whole per-step physics for a 4-rotor vehicle (motor lag, rotor
wrench, wind, link drag, tank) should stay well under 20 µs; sensors are listed apart.
"""

from __future__ import annotations

import argparse
import timeit
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smoke run (few iterations)")
    ap.add_argument("--vehicle", default="x500-sprayer", help="vehicles/<name>.yaml")
    args = ap.parse_args()
    n = 20_000 if args.quick else 200_000
    repeat = 3 if args.quick else 7

    from vinecli.flight.aero import wind_drag
    from vinecli.flight.motor import MotorBank
    from vinecli.flight.sensors import make_sensors
    from vinecli.flight.tank import Tank
    from vinecli.flight.wind import make_wind
    from vinecli.frames import quat_from_euler, quat_rotate_inv
    from vinecli.geo import GeoOrigin
    from vinecli.specs import load_spec
    from vinecli.specs.vehicle import VehicleSpec
    from vinecli.specs.wind import ConstantWind, DrydenWind, SinusoidWind, SumWind, WindSpec
    from vinecli.types import RigidState

    v = load_spec(REPO / "vehicles" / f"{args.vehicle}.yaml", VehicleSpec)
    dt = 1 / 250
    bank = MotorBank(v.motor, v.rotors)
    w_h = bank.hover_speed(v.dry_mass() + v.liquid_mass(1.0))
    cmd = [w_h * (1.0 + 0.01 * i) for i in range(bank.n)]
    bank.reset(w_h)
    tank = Tank(v.tank, v.tank.capacity_l) if v.tank else None
    slosh_tank = Tank(v.tank.model_copy(update={"slosh": True}), v.tank.capacity_l) if v.tank else None
    q = quat_from_euler(0.05, -0.03, 0.7)
    vel, omega = (1.0, -0.5, 0.2), (0.1, 0.05, -0.2)
    winds = {
        "constant": make_wind(WindSpec(law=ConstantWind(velocity_enu=(2.0, 1.0, 0.0))), 0, dt),
        "sinusoid": make_wind(WindSpec(law=SinusoidWind(mean_mps=3.0, amplitude_mps=1.0)), 0, dt),
        "dryden+sinusoid": make_wind(
            WindSpec(law=SumWind(terms=[SinusoidWind(mean_mps=3.0, amplitude_mps=1.0), DrydenWind(intensity="light")])),
            0,
            dt,
        ),
    }
    coeffs = [d.coefficient(1.225) for d in v.drag.values()]
    clock = [0.0]

    def wind_step(w) -> None:  # noqa: ANN001
        clock[0] += dt
        w.velocity(clock[0], (1.0, 2.0, 3.0))

    def motor_update() -> None:
        bank.update(cmd, dt)

    def motor_wrench() -> None:
        bank.wrench(bank.apparent_air_body(q, vel, omega, (2.0, 1.0, 0.0)))

    def motor_wrench_com() -> None:
        bank.wrench_com(*quat_rotate_inv(q, (2.0 - vel[0], 1.0 - vel[1], -vel[2])), *omega)

    def drag_links() -> None:
        for c in coeffs:
            wind_drag(c, (1.0, 1.5, -0.2))

    def tank_step(t) -> None:  # noqa: ANN001
        t.update(0.0, dt)
        t.force_world((0.0, 0.0, -9.80665), (0.3, -0.2, 0.1))

    dry = make_wind(WindSpec(law=SumWind(terms=[SinusoidWind(mean_mps=3.0), DrydenWind(intensity="light")])), 0, dt)

    def full_step() -> None:
        clock[0] += dt
        wind = dry.velocity(clock[0], (1.0, 2.0, 3.0))
        bank.update(cmd, dt)
        bank.wrench_com(*quat_rotate_inv(q, (wind[0] - vel[0], wind[1] - vel[1], wind[2] - vel[2])), *omega)
        v_app = (wind[0] - vel[0], wind[1] - vel[1], wind[2] - vel[2])
        for c in coeffs:
            wind_drag(c, v_app)
        if tank is not None:
            tank.update(0.0, dt)
            tank.force_world((0.0, 0.0, -9.80665), (0.3, -0.2, 0.1))

    suite = make_sensors(v.sensors, GeoOrigin(46.07, 11.12, 200.0), 1)
    t_us = [0]

    def sensors_step() -> None:
        t_us[0] += 4000
        suite.sample_all(RigidState(t_us[0], (1.0, 2.0, 3.0), q, vel, omega, (0.1, 0.2, -0.1), False))

    cases = [
        (f"motor update ({bank.n} rotors)", motor_update),
        (f"rotor wrench, general: apparent_air_body + wrench ({bank.n} rotors)", motor_wrench),
        (f"rotor wrench, the loop's form: wrench_com ({bank.n} rotors)", motor_wrench_com),
        *[(f"wind {k}", (lambda w=w: wind_step(w))) for k, w in winds.items()],
        (f"wind drag ({len(coeffs)} links)", drag_links),
    ]
    if tank is not None:
        cases.append(("tank update + force", lambda: tank_step(tank)))
        cases.append(("tank update + force (slosh)", lambda: tank_step(slosh_tank)))
    cases += [
        ("FULL physics step (Dryden+sinusoid wind, motors, drag, tank)", full_step),
        ("sensors sample_all (IMU 250 Hz, baro, mag, GNSS)", sensors_step),
    ]
    print(
        f"vinecli physics micro-benchmark: vehicle {v.name}, {n} calls x best of {repeat}{' (quick)' if args.quick else ''}"
    )
    width = max(len(c[0]) for c in cases)
    for name, fn in cases:
        best = min(timeit.repeat(fn, number=n, repeat=repeat)) / n * 1e6
        print(f"  {name:<{width}}  {best:7.2f} µs")
    print("  budget: full physics step well under 20 µs (docs/flight-models.md §6: 40 µs is the whole loop at 100x real time)")


if __name__ == "__main__":
    main()
