"""Segment rates flown by real ArduCopter SITL (../shared/ardupilot; skips without it), as
pipelines/dose-ardupilot.yaml flies them: DO_SPRAYER on and off in the mission, SPRAY_PUMP_RATE set by vinecli's
ground station (PARAM_SET) as ArduPilot's own position report reaches each rate piece, AC_Sprayer scaling the pump
with ground speed at 3 Hz. The three-zone GeoPackage and the ISO-XML grid: every rate change is sent once, each zone
gets its rate within 10 %, the as-applied log, checks, maps and the TimeLog come out, and the run states how
ArduPilot followed the map and what it cannot do."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from tests.repo_paths import REPO

pytestmark = [pytest.mark.ardupilot, pytest.mark.timeout(2400)]


@pytest.fixture(scope="module")
def ap_dose(ardupilot_bin: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from vinecli.batch import run_batch

    out = tmp_path_factory.mktemp("dose-ardupilot")
    run_batch(REPO / "pipelines" / "dose-ardupilot.yaml", out, workers=2, ardupilot_bin=ardupilot_bin)
    return out


def _summary(out: Path, case: str) -> dict[str, Any]:
    return json.loads((out / case / "summary.json").read_text())


def _events(out: Path, case: str) -> list[dict[str, Any]]:
    return [json.loads(x) for x in (out / case / "events.jsonl").read_text().splitlines()]


@pytest.mark.parametrize("case", ["dose-zones", "dose-grid"])
def test_the_ground_station_sets_the_pump_rate_per_piece(ap_dose: Path, case: str) -> None:
    s = _summary(ap_dose, case)
    a = s["as_applied"]
    assert s["status"] == "completed" and s["autopilot"] == "ardupilot" and s["metrics"]["ardupilot_stalls"] == 0
    f = a["follows"]
    assert f["autopilot"] == "ardupilot" and "SPRAY_PUMP_RATE" in f["method"] and any("3 Hz" in x for x in f["limits"])
    sets = [e["data"] for e in _events(ap_dose, case) if e["kind"] == "pump_rate_set"]
    assert [d["change"] for d in sets] == list(range(len(sets))) and len(sets) >= 4  # every change once, in order
    rates = [d["rate_lpha"] for d in sets]
    assert all(r != q for r, q in zip(rates[:-1], rates[1:], strict=True))
    parm = (ap_dose / case / "firmware" / "vinecli.parm").read_text()
    assert "SPRAY_ENABLE 1\n" in parm  # the pump rate in the file is the mean; the schedule sets each piece's
    assert all(abs(z["pump_error"]) <= 0.10 for z in a["zones"])
    assert a["in_band_fraction"] >= 0.6 and a["gaps"]["sprayed"] == 0
    for name in ("as_applied.json", "as_applied.gpkg", "as_applied.tif", "dose_map/overlays.json"):
        assert (ap_dose / case / name).is_file()


def test_the_isoxml_input_gets_a_timelog(ap_dose: Path) -> None:
    folder = ap_dose / "dose-grid" / "as_applied_taskdata"
    assert (folder / "TASKDATA.XML").is_file() and (folder / "TLG00001.BIN").stat().st_size > 0
