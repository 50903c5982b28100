"""THE run set-up (vinecli/sim/setup.py): a world, a mission and a vehicle resolved once into a PreparedRun,
the same for the library entry (run_simulation) and `run mission` (run_mission)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from sim_helpers import OpenLoop, mission

import vinecli.missions.spec_io as spec_io
import vinecli.sim.setup as setup
import vinecli.vehicle as vehicle_pkg
from vinecli.errors import SpecError
from vinecli.sim.runner import run_simulation, simulate
from vinecli.sim.setup import PreparedRun, RunOverrides, prepare_run
from vinecli.vehicle import load_vehicle
from vinecli.world.model import rest_position


def test_the_worlds_vehicle_flies_from_the_worlds_spawn_and_urdf(flat_world: Any) -> None:
    m = mission(tank_fill_l=1.0, phases=[{"type": "takeoff", "altitude_agl_m": 2.0},
                                         {"type": "spray", "rows": [[[0.0, 0.0], [10.0, 0.0]]], "height_agl_m": 2.0,
                                          "speed_mps": 2.0, "rate_lpha": 100.0}])
    with prepare_run(flat_world, m) as run:
        assert run.urdf == flat_world.urdf and run.vehicle == flat_world.vehicle
        assert run.spawn.position_enu == flat_world.spawn_enu and run.spawn.at_rest and run.spawn.home_enu is None
        assert run.dt_us == 4000 and run.tank_fill_l == 1.0 and run.deposition
        assert run.wind == flat_world.wind and run.geofence == flat_world.geofence
        # the rate stays in the mission (run directory, checks); the autopilot flies its flow
        assert run.mission.phases[1].flow_lps is None and run.flight.phases[1].flow_lps > 0.0
        with pytest.raises(AttributeError):
            run.dt_us = 1  # type: ignore[misc]  # frozen


def test_another_vehicle_rests_at_the_spawn_and_gets_its_own_urdf_once(flat_world: Any,
                                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[tuple[float, float]] = []

    def counted(terrain: Any, veh: Any, x: float, y: float) -> Any:
        calls.append((x, y))
        return rest_position(terrain, veh, x, y)

    monkeypatch.setattr(setup, "rest_position", counted)
    x500 = load_vehicle("x500")
    with prepare_run(flat_world, mission(payload_kg=0.5), vehicle=x500) as run:
        assert calls == [flat_world.spawn_enu[:2]]
        assert run.spawn.position_enu == rest_position(flat_world.terrain, run.vehicle, *flat_world.spawn_enu[:2])
        assert run.vehicle.payload.mass_kg == 0.5 and run.vehicle.name == "x500"
        assert run.urdf != flat_world.urdf and run.urdf.is_file()
        urdf = run.urdf
    assert not urdf.exists()  # the temporary URDF goes with the prepared run


def test_an_airborne_start_computes_its_rest_position_once(flat_world: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[tuple[float, float]] = []

    def counted(terrain: Any, veh: Any, x: float, y: float) -> Any:
        calls.append((x, y))
        return rest_position(terrain, veh, x, y)

    monkeypatch.setattr(setup, "rest_position", counted)
    ph = {"type": "open_loop", "duration_s": 1.0, "rotor_speeds_rad_s": 500.0,
          "initial_state": {"position_enu": [3.0, 4.0, 5.0], "rpy_deg": [0.0, 0.0, 90.0]}}
    with prepare_run(flat_world, mission([ph], max_duration_s=1.0), vehicle=load_vehicle("x500")) as run:
        sp = run.spawn
        assert calls == [(3.0, 4.0)]  # the rest position below is both the start height's base and home
        assert sp.airborne and not sp.at_rest and sp.spin_up is run.flight.phases[0]
        assert sp.home_enu is not None and sp.position_enu == (3.0, 4.0, sp.home_enu[2] + 5.0)


def test_a_tank_the_vehicle_cannot_take_is_refused_before_the_engine(flat_world: Any) -> None:
    with pytest.raises(SpecError, match="exceeds the tank capacity"):
        prepare_run(flat_world, mission(tank_fill_l=1e3))
    with pytest.raises(SpecError, match="has none"):
        prepare_run(flat_world, mission(tank_fill_l=1.0), vehicle=load_vehicle("x500"))
    with pytest.raises(SpecError, match="record rate"):
        prepare_run(flat_world, mission(), overrides=RunOverrides(record_rate_hz=0.0))


def test_one_prepared_run_flies_any_seed_like_run_simulation(flat_world: Any) -> None:
    m = mission(max_duration_s=0.3)
    with prepare_run(flat_world, m) as run:
        a = simulate(run, OpenLoop(lambda o: [300.0] * 4), seed=4)
        b = simulate(run, OpenLoop(lambda o: [300.0] * 4), seed=4)
    c = run_simulation(flat_world, m, OpenLoop(lambda o: [300.0] * 4), seed=4)
    for r in (b, c):
        assert r.timeseries.keys() == a.timeseries.keys()
        assert all(np.array_equal(r.timeseries[k], a.timeseries[k], equal_nan=True) for k in a.timeseries)
        assert r.metrics.keys() == a.metrics.keys()
        assert all(np.array_equal(r.metrics[k], a.metrics[k], equal_nan=True) for k in a.metrics)


def test_run_mission_reads_the_file_and_loads_the_vehicle_once(flat_world_dir: Path, tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    from vinecli.runs import RunRequest, run_mission

    reads: list[Path] = []
    loads: list[str] = []
    read_yaml, load = spec_io.read_yaml, vehicle_pkg.load_vehicle
    monkeypatch.setattr(spec_io, "read_yaml", lambda p: reads.append(Path(p)) or read_yaml(p))
    monkeypatch.setattr(vehicle_pkg, "load_vehicle", lambda n: loads.append(str(n)) or load(n))
    prepared: list[PreparedRun] = []
    real_prepare = setup.prepare_run
    monkeypatch.setattr(setup, "prepare_run", lambda *a, **k: prepared.append(real_prepare(*a, **k)) or prepared[-1])
    m = tmp_path / "m.yaml"
    m.write_text(yaml.safe_dump({"name": "x5", "vehicle": "x500", "max_duration_s": 0.2, "phases": [
        {"type": "open_loop", "duration_s": 0.2, "rotor_speeds_rad_s": 0.0}]}))
    s = run_mission(RunRequest(m, flat_world_dir, tmp_path / "runs", record_rate=25.0, truth=True))
    assert s.status == "completed"
    assert reads == [m] and loads == ["x500"]
    (run,) = prepared
    assert run.vehicle.name == "x500" and run.mission.record_rate_hz == 25.0 and run.mission.truth
    assert not run.urdf.exists()  # its temporary URDF was removed after the run
