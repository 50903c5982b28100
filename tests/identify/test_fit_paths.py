"""What the fit does with less: a log without battery current fits the rest and says what it could not."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from tests.flightlog.synthetic_log import synthetic_log
from vinecli.flightlog.ulog_write import write_ulog
from vinecli.identify.fit import fit_flight_log


def test_a_log_without_current_fits_without_a_power_model(tmp_path: Path) -> None:
    log = synthetic_log()
    assert log.battery is not None
    log = replace(log, battery=replace(log.battery, current_a=np.full_like(log.battery.current_a, np.nan)))
    r = fit_flight_log(write_ulog(log, tmp_path / "nocurrent.ulg"), replay=False)
    rep = r.report
    assert rep["energy"] is None and "avionics_w" not in rep["parameters"]
    assert rep["parameters"]["pack_resistance_ohm"]["source"] == "base"
    assert rep["cells"] == 4 and rep["parameters"]["ocv_start_v"]["source"] == "fit"
    assert any("no battery current" in x for x in rep["fixed_from_base"])
    assert 0.0 < rep["hover_throttle"] < 1.0
