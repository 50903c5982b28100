"""PX4 v1.15 can lose one lockstep answer by itself: its sender thread waits in ``px4_lockstep_wait_for_components()``
for a component report that was lost, and only a clock that moves brings the next one, while vinecli waits for the
answer (seen on a loaded machine: the ci-px4 batch's spray-rows and gust cases ended "PX4 stopped answering ... 30 s"
with PX4 printing "poll timeout"). The lockstep sends the next step after 2 s of wall time and the flight goes on;
a PX4 that answers nothing more still ends the run at ``hang_timeout_s``, naming the last exchange. Real sockets, the
fake PX4 peer (``lost_wakeup_at_s``: the one answer it leaves out), vinecli's lockstep as ``run mission`` uses it (no
step timeout)."""

from __future__ import annotations

import pytest

from tests.sitl.px4.test_px4_link_garbage import fly_against_fake
from vinecli.autopilot.base import RunStatus
from vinecli.sitl.px4.lockstep import RECOVER_S

pytestmark = pytest.mark.timeout(240)


def test_an_answer_px4_loses_is_recovered_and_the_flight_goes_on(world, ports):
    res, fake, took = fly_against_fake(world, ports, lost_wakeup_at_s=4.0)
    assert fake.lost_answer_t is not None  # the fake left one HIL_SENSOR unanswered, in flight
    assert res.status is RunStatus.COMPLETED, (res.status, res.detail)
    assert res.metrics["px4_lockstep_recoveries"] == 1
    assert res.metrics["px4_stalls"] == 0 and res.metrics["px4_resyncs"] == 0  # not a stall: no check fails for it
    recovered = [e for e in res.events if e.kind == "px4_lockstep_recovery"]
    assert len(recovered) == 1 and recovered[0].data["t_usec"] == fake.lost_answer_t, recovered
    assert f"within {RECOVER_S:g} s of wall time" in recovered[0].message
    assert fake.violations == []  # the next HIL_SENSOR came one step later, as every other one
    assert took < 60, f"{took:.0f} s: the run waited on the lost answer"


def test_a_px4_that_answers_nothing_more_still_ends_the_run_at_the_hang_limit(world, ports):
    res, _fake, took = fly_against_fake(world, ports, hang_timeout_s=5.0, silent_after_s=3.0)
    assert res.status is RunStatus.ERROR
    assert "no HIL_ACTUATOR_CONTROLS for 5 s of wall time (hung)" in res.detail, res.detail
    # the last exchange: which HIL_SENSOR went unanswered, PX4's last answer one step before the first of them
    assert "PX4's last answer" in res.detail and "recoveries" in res.detail
    assert 1 <= res.metrics["px4_lockstep_recoveries"] <= 5.0 / RECOVER_S
    assert res.metrics["px4_stalls"] == 0
    assert took < 60
