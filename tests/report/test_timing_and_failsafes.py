"""summary.json ``timing`` and ``failsafes`` as the report reads them (older runs: top-level timing keys)."""

from __future__ import annotations

from vinecli.report.junit import check_message
from vinecli.report.loader import Run


def run(summary: dict) -> Run:
    return Run(case="c", run_id="c", dir=None, summary={"mission": "m", "status": "timeout", **summary})


def test_timing_section_first_then_the_old_top_level_keys() -> None:
    new = run({"timing": {"wall_time_s": 2.0, "real_time_factor": 40.0, "wall_per_step_us": 35.0},
               "metrics": {"hpos_error_max_m": 0.3}})
    assert new.timing == {"wall_time_s": 2.0, "real_time_factor": 40.0, "wall_per_step_us": 35.0}
    old = run({"wall_time_s": 3.0, "real_time_factor": 20.0,
               "metrics": {"hpos_error_max_m": 0.3, "wall_per_step_us": 50.0, "real_time_factor": 21.0}})
    assert old.timing == {"wall_time_s": 3.0, "real_time_factor": 20.0}
    assert old.metrics() == {"hpos_error_max_m": 0.3}  # timing figures are not metrics (no baseline regressions)


def test_failsafe_text_and_junit_message() -> None:
    r = run({"failsafes": [{"t_s": 10.0637, "cause": "geofence", "action": "hold", "position_enu": [9.1, 0.0, 2.0]},
                           {"t_s": 31.5, "cause": "low_battery", "action": "rtl"}]})
    assert r.failsafe_text == ("geofence breach at 10.06 s → hold; sprayer off; "
                               "low battery at 31.50 s → rtl; sprayer off")
    c = {"name": "completed", "value": "timeout", "op": "==", "bound": "completed"}
    assert check_message(c, r.failsafe_text).endswith("; failsafe: geofence breach at 10.06 s → hold; sprayer off; "
                                                      "low battery at 31.50 s → rtl; sprayer off")
    assert run({}).failsafe_text == "" and run({"failsafes": "junk"}).failsafes == []
