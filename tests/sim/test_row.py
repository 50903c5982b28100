"""THE time-series row (vinecli/sim/row.py): the row lists its fields in the schema's order, and every recorded column
holds its declared source. A real flight (the sample world; the sprayer with tank, slosh, pump and battery, its liquid
heavier than water; turbulence and a vertical gust; a touch-down and a lift-off) is stepped here one physics step at a
time; after each step the sources of every column are evaluated on what the loop
flew (the autopilot's observation and command, the physics laws' state, the terrain) and compared bit for bit with the
row the loop recorded: a value written to another column fails, and the columns are checked to differ from each other
over the flight, so that no swap of two could pass unseen."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from vinecli.autopilot.base import AutopilotContext, AutopilotStatus
from vinecli.frames import quat_to_euler, tilt_angle
from vinecli.sim.row import COLUMNS, ROTOR_COLUMNS, ROTORS_AFTER, Row, column_units, timeseries_columns
from vinecli.types import ActuatorCommand, Event, Observation

ROTOR_FIELDS = {c.name.replace("{n}", ""): c for c in ROTOR_COLUMNS}
#: columns equal by definition, whatever the flight (a swap of the two changes no value): the liquid's force on the
#: frame is its weight plus its inertial push, and its weight has no horizontal part
SAME_BY_DEFINITION = {("tank_force_enu_x_n", "tank_force_inertial_enu_x_n"),
                      ("tank_force_enu_y_n", "tank_force_inertial_enu_y_n")}


def test_the_row_lists_its_fields_in_the_columns_order() -> None:
    for n in (4, 6):
        names = timeseries_columns(n)
        row = Row(n)
        for k, name in enumerate(names):
            if not name[len("rotor"):len("rotor") + 1].isdigit():
                setattr(row, name, float(k))
        at = {name: float(k) for k, name in enumerate(names)}
        row.rotor_w_radps = tuple(at[f"rotor{i + 1}_w_radps"] for i in range(n))
        row.rotor_cmd_radps = tuple(at[f"rotor{i + 1}_cmd_radps"] for i in range(n))
        row.rotor_thrust_n = [at[f"rotor{i + 1}_thrust_n"] for i in range(n)]
        assert row.values() == [float(k) for k in range(len(names))]
        assert list(column_units(n)) == names and len(set(names)) == len(names)
    assert timeseries_columns(4)[21:24] == ["rotor1_w_radps", "rotor1_cmd_radps", "rotor1_thrust_n"]
    assert timeseries_columns(4)[20] == ROTORS_AFTER


def test_the_row_has_a_field_per_column_and_no_other() -> None:
    row = Row(4)
    fields = {a for a in dir(row) if not a.startswith("_") and not callable(getattr(row, a))} - {"n_rotors"}
    assert fields == {c.name for c in COLUMNS} | set(ROTOR_FIELDS)


class Probe:
    """An autopilot that flies distinct rotor speeds, spray flow and arming per step and reports a set point, phase
    and sortie that change every step; it keeps what it saw and said (the row's sources)."""

    name = "row-probe"

    def __init__(self, n: int) -> None:
        self.n = n
        self.k = 0
        self.obs: Observation | None = None
        self.cmd: ActuatorCommand | None = None

    def reset(self, ctx: AutopilotContext) -> None:
        pass

    def step(self, obs: Observation) -> ActuatorCommand:
        self.obs, self.k = obs, self.k + 1
        t = obs.t_us * 1e-6
        self.cmd = ActuatorCommand(tuple(560.0 + 9.0 * i + 40.0 * math.sin(7.0 * t + i) for i in range(self.n)),
                                   0.02 + 0.01 * math.sin(5.0 * t), self.k % 3 != 0)
        return self.cmd

    def status(self) -> AutopilotStatus:
        t = self.obs.t_us * 1e-6 if self.obs is not None else 0.0
        return AutopilotStatus("probe", self.k % 5, extra={"sp_x": 10.0 + t, "sp_y": -20.0 + 2.0 * t,
                                                           "sp_z": 3.0 - t, "sortie": float(self.k % 7)})

    def drain_events(self) -> list[Event]:
        return []

    def close(self) -> None:
        pass


def _expected(col_source: str, ns: dict[str, Any], i: int | None = None) -> float:
    return float(eval(col_source, {}, {**ns, "i": i}))  # noqa: S307 - the schema's own expressions


def expected_row(ns: dict[str, Any], n: int) -> dict[str, float]:
    """Every column's source evaluated on what the loop flew at one step (``ns``, the names of sim/row.py's doc)."""
    out = {}
    k = [c.name for c in COLUMNS].index(ROTORS_AFTER) + 1
    for c in COLUMNS[:k]:
        out[c.name] = _expected(c.source, ns)
    for i in range(n):
        for c in ROTOR_COLUMNS:
            out[c.name.format(n=i + 1)] = _expected(c.source, ns, i)
    for c in COLUMNS[k:]:
        out[c.name] = _expected(c.source, ns)
    return out


def mismatches(recorded: dict[str, float], expected: dict[str, float]) -> set[str]:
    """Columns whose recorded value is not their source's, bit for bit (NaN equal to NaN)."""
    return {c for c, v in expected.items()
            if np.float64(recorded[c]).tobytes() != np.float64(v).tobytes() and not (math.isnan(v) and math.isnan(recorded[c]))}


@pytest.fixture(scope="module")
def probe_flight(sample_world_dir: Path) -> tuple[dict[str, np.ndarray], list[dict[str, float]]]:
    """(the recorded columns, the sources of every row) of 0.6 s of a real flight (module doc)."""
    from vinecli.flight.battery import Battery
    from vinecli.flight.tank import Tank
    from vinecli.flight.wind import make_wind
    from vinecli.sim.loop import Flight, Plant
    from vinecli.sim.setup import prepare_run
    from vinecli.specs.mission import MissionSpec
    from vinecli.vehicle import load_vehicle
    from vinecli.world import load_world
    from vinecli.world.engine import terrain_engine

    world = load_world(sample_world_dir)
    sprayer = load_vehicle("x500-sprayer")
    assert sprayer.tank is not None
    sprayer = sprayer.model_copy(update={"tank": sprayer.tank.model_copy(update={"liquid_density_kgm3": 1100.0,
                                                                                  "slosh": True})})
    spec = MissionSpec.model_validate({
        "name": "row", "max_duration_s": 0.6, "record_rate_hz": 250.0,
        "wind": {"law": {"type": "sum", "terms": [
            {"type": "dryden", "intensity": "moderate", "mean_mps": 3.0, "heading_deg": 30.0, "altitude_m": 3.0},
            {"type": "gust", "peak_mps": 2.0, "start_s": 0.0, "duration_s": 1.0, "heading_deg": 120.0,
             "vertical_mps": 0.7}]}},
        "phases": [{"type": "open_loop", "duration_s": 0.6, "rotor_speeds_rad_s": 0.0}]})
    gear = None
    sources: list[dict[str, float]] = []
    with prepare_run(world, spec, vehicle=sprayer) as run, \
            terrain_engine(run.world.terrain, rate_hz=run.physics_rate_hz, gravity=run.gravity) as engine:
        veh = run.vehicle
        gear = veh.frame.landing_gear_height_m
        sp = run.spawn
        pos0 = (sp.position_enu[0], sp.position_enu[1], sp.position_enu[2] + 0.12)  # just above the ground, falling
        quat0 = (0.02, -0.03, 0.3, math.sqrt(1.0 - 0.02**2 - 0.03**2 - 0.3**2))
        engine.load_vehicle(run.urdf, pos0, quat0)
        engine.reset_vehicle(pos0, quat0, (1.2, -0.7, -1.0), (0.3, -0.2, 0.5))
        assert veh.tank is not None and veh.battery is not None
        tank, battery = Tank(veh.tank, run.tank_fill_l), Battery(veh.battery)
        probe = Probe(veh.n_rotors)
        flight = Flight(run, Plant(engine, engine.vehicle, tank, battery, make_wind(run.wind, 3, run.dt_us * 1e-6),
                                   pos0, 0.0), probe, 3, None, None)
        baro = gnss = (math.nan,)
        running = True
        while running:
            running = flight.step()
            obs, truth = probe.obs, probe.obs.truth  # type: ignore[union-attr]
            if obs.baro is not None:  # type: ignore[union-attr]
                baro = (obs.baro.altitude_m,)  # type: ignore[union-attr]
            if obs.gnss is not None:  # type: ignore[union-attr]
                gnss = (obs.gnss.lat_deg, obs.gnss.lon_deg, obs.gnss.alt_m)  # type: ignore[union-attr]
            terrain_z = world.terrain_height(truth.pos[0], truth.pos[1])
            ns = {"t": truth.t_us * 1e-6, "truth": truth, "euler": quat_to_euler(truth.quat),
                  "tilt": tilt_angle(truth.quat), "cmd": probe.cmd, "status": flight.st, "imu": obs.imu,  # type: ignore[union-attr]
                  "baro_alt": baro[0], "gnss": gnss if len(gnss) == 3 else (math.nan,) * 3, "terrain_z": terrain_z,
                  "agl": truth.pos[2] - terrain_z - gear, "physics": flight.physics, "motors": flight.physics.motors,
                  "tank": tank, "battery": battery, "nan": math.nan}
            sources.append(expected_row(ns, veh.n_rotors))
        recorded = flight.rec.columns_dict()
    return recorded, sources


def test_every_recorded_column_is_its_source(probe_flight: tuple[dict[str, np.ndarray], list[dict[str, float]]]) -> None:
    recorded, sources = probe_flight
    assert len(sources) == len(recorded["t_s"]) == 151  # 0.6 s at 250 Hz, every step recorded, the last one too
    assert list(recorded) == list(sources[0])
    bad = {}
    for k, expected in enumerate(sources):
        wrong = mismatches({c: float(v[k]) for c, v in recorded.items()}, expected)
        if wrong:
            bad[k] = sorted(wrong)
    assert not bad, f"columns not holding their source (row: columns): {dict(list(bad.items())[:5])}"


def test_no_two_columns_could_be_swapped_unseen(probe_flight: tuple[dict[str, np.ndarray], list[dict[str, float]]]
                                                ) -> None:
    """Every two columns differ in some row of the probe flight, so the source check sees any swap of two."""
    recorded, _ = probe_flight
    names = list(recorded)
    same = [(a, b) for i, a in enumerate(names) for b in names[i + 1:]
            if np.array_equal(recorded[a], recorded[b], equal_nan=True) and (a, b) not in SAME_BY_DEFINITION]
    assert not same, f"columns equal over the whole probe flight (a swap would pass): {same}"


def test_a_swap_of_two_values_is_caught(probe_flight: tuple[dict[str, np.ndarray], list[dict[str, float]]]) -> None:
    """What the source check reports when a writer puts two values in each other's columns (a real row, swapped)."""
    recorded, sources = probe_flight
    row = {c: float(v[40]) for c, v in recorded.items()}
    assert not mismatches(row, sources[40])
    for a, b in (("terrain_z_m", "height_agl_m"), ("roll_rad", "pitch_rad"), ("rotor2_w_radps", "rotor2_cmd_radps"),
                 ("tank_flow_lps", "tank_flow_cmd_lps"), ("battery_voltage_v", "battery_current_a")):
        swapped = {**row, a: row[b], b: row[a]}
        assert mismatches(swapped, sources[40]) == {a, b}


def test_the_parquet_writer_keeps_the_schemas_order(tmp_path: Path) -> None:
    """timeseries.parquet's columns come in the schema's order whatever order they are handed in; undeclared last."""
    import pyarrow.parquet as pq

    from vinecli.runs import rundir

    names = timeseries_columns(6)
    rundir.write_timeseries(tmp_path / "t.parquet", {c: np.arange(3.0) for c in ["extra", *names[::-1]]})
    assert pq.read_schema(tmp_path / "t.parquet").names == [*names, "extra"]
