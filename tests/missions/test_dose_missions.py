"""Missions dosed per canopy segment or by a prescription map: the spec takes exactly one dose, the run set-up
turns it into the segment rates over the world's canopy segments (vinecli.sim.dose_setup), a bad map in a
mission is refused with exit 2 naming the file."""

from __future__ import annotations

from pathlib import Path

import pytest
from pydantic import ValidationError

from vinecli.errors import InputError
from vinecli.sim.dose_setup import resolve_dose_phases
from vinecli.specs.mission import MissionSpec, SprayPhase
from vinecli.world import build_world, load_world
from vinecli.world.canopy_files import load_canopy_segments

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def block(tmp_path_factory: pytest.TempPathFactory):
    """The flat vineyard block with hedges of growth stage 75 (given, not measured: uniform segments)."""
    d = tmp_path_factory.mktemp("w")
    spec = (REPO / "worlds" / "vineyard-block.yaml").read_text(encoding="utf-8") + "canopy: {bbch: 75}\n"
    (d / "block.yaml").write_text(spec, encoding="utf-8")
    out = d / "block"
    build_world(d / "block.yaml", out)
    return load_world(out)


def _mission(**dose: object) -> MissionSpec:
    return MissionSpec(name="m", phases=[{"type": "takeoff", "altitude_agl_m": 3.0},
                                         {"type": "spray", "rows": [0, 2], "height_agl_m": 2.0, **dose},
                                         {"type": "land"}])


def test_exactly_one_dose() -> None:
    with pytest.raises(ValidationError, match="exactly one"):
        SprayPhase(rate_lpha=100.0, lwa_dose_l=200.0)
    with pytest.raises(ValidationError, match="exactly one"):
        SprayPhase()
    assert SprayPhase(lwa_dose_l=200.0).segment_dose and not SprayPhase(rate_lpha=1.0).segment_dose


def test_world_build_writes_segments(block) -> None:
    segs = load_canopy_segments(block.dir)
    assert segs is not None and segs.source == "hedges"
    assert (block.dir / "canopy_segments.gpkg").is_file() and (block.dir / "canopy_segments.tif").is_file()
    assert block.canopy["segments"]["segments"] == len(segs.segments)


def test_lwa_dose_resolved_on_the_world_canopy(block) -> None:
    segs = load_canopy_segments(block.dir)
    g = segs.for_row(0)[0]
    flown, rates = resolve_dose_phases(_mission(lwa_dose_l=250.0), block)
    r = rates[1]
    assert {s.row for s in r.segments} == {0, 1}  # rows 0 and 2 of the world, renumbered as the phase's
    assert r.segments[0].rate_lpha == pytest.approx(250.0 * g.lwa_m2pha() / 10_000.0)
    assert flown.phases[1].rate_lpha == pytest.approx(r.summary()["rate_mean_lpha"])
    assert flown.phases[1].lwa_dose_l is None


def test_bad_map_in_a_mission(block, tmp_path: Path) -> None:
    bad = tmp_path / "TASKDATA.XML"
    bad.write_text("<ISO11783_TaskData VersionMajor=\"4\"><TSK", encoding="utf-8")
    with pytest.raises(InputError, match="broken ISO-XML") as err:
        resolve_dose_phases(_mission(prescription={"path": str(bad)}), block)
    assert "TASKDATA.XML" in str(err.value.path)


def test_plan_rows_mission_carries_the_dose(block, tmp_path: Path) -> None:
    """``plan rows --mission`` writes the dose, not the flow of one rate: a canopy dose over the world's own rows
    (which a run finds the canopy of), a rate, a prescription map (its path absolute); a DSM source cannot carry a
    canopy dose into a run: exit 2, one line, nothing written."""
    import hashlib

    from typer.testing import CliRunner

    from tests.canopy_fixtures import write_truth_dsm
    from vinecli.cli.app import app
    from vinecli.missions.spec_io import load_mission

    runner = CliRunner()
    n = len(block.vine_rows_enu)
    for opts, want in ((["--dose-lwa", "200"], {"lwa_dose_l": 200.0, "rows": list(range(n))}),
                       (["--rate", "120"], {"rate_lpha": 120.0})):
        out = tmp_path / f"{opts[0][2:]}.plan"
        r = runner.invoke(app, ["plan", "rows", str(block.dir), "--out", str(out), *opts, "--mission",
                                str(out.with_suffix(".yaml"))])
        assert r.exit_code == 0, r.output
        ph = load_mission(out.with_suffix(".yaml"), check_vehicle=False).phases[1]
        assert ph.flow_lps is None and all(getattr(ph, k) == v for k, v in want.items())
    flown, rates = resolve_dose_phases(load_mission(tmp_path / "dose-lwa.yaml", check_vehicle=False), block)
    assert {g.row for g in rates[1].segments} == set(range(n)) and flown.phases[1].rate_lpha > 0
    dsm = write_truth_dsm(tmp_path / "vineyard.tif")
    before = hashlib.sha256(dsm.read_bytes()).hexdigest()
    r = runner.invoke(app, ["plan", "rows", str(dsm), "--out", str(tmp_path / "d.plan"), "--dose-lwa", "200",
                            "--mission", str(tmp_path / "d.yaml")])
    assert r.exit_code == 2 and len(r.output.strip().splitlines()) == 1 and "canopy segments" in r.output
    assert not (tmp_path / "d.plan").exists() and not (tmp_path / "d.yaml").exists()
    assert hashlib.sha256(dsm.read_bytes()).hexdigest() == before
