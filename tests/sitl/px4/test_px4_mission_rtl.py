"""The mission's closing NAV_RETURN_TO_LAUNCH is PX4's own RTL mode, not a failsafe: recognised however PX4
reports the items before it (seen in a three-way run: PX4 reported item 27 of 29, a DO item after the last
waypoint, never item 26, and MISSION_CURRENT still said 26 when the mode changed)."""

from __future__ import annotations

from types import SimpleNamespace

from vinecli.mavlink import px4modes as M
from vinecli.mavlink.mission_items import MissionItem
from vinecli.sitl.px4.mission_client import Px4MissionClient

WP, DO = M.CMD_NAV_WAYPOINT, M.CMD_DO_SET_ACTUATOR


def _client(commands: list[int], reached: set[int], current: int) -> Px4MissionClient:
    c = object.__new__(Px4MissionClient)  # the state _at_rtl_item reads, without a PX4 link
    c.plan = SimpleNamespace(items=[MissionItem(command=cmd) for cmd in commands])
    c.reached, c.current_seq = reached, current
    return c


def test_rtl_after_a_reported_do_item_is_the_missions_own_ending() -> None:
    items = [WP, WP, DO, WP, DO, M.CMD_NAV_RETURN_TO_LAUNCH]  # 3 = last waypoint, 4 = sprayer off, 5 = RTL
    assert _client(items, {0, 1, 2, 4}, current=3)._at_rtl_item()  # 3 never reported, 4 was
    assert _client(items, {0, 1, 2, 3}, current=3)._at_rtl_item()
    assert _client(items, set(), current=5)._at_rtl_item()


def test_rtl_before_the_last_waypoint_is_a_failsafe() -> None:
    items = [WP, WP, DO, WP, DO, M.CMD_NAV_RETURN_TO_LAUNCH]
    assert not _client(items, {0, 1, 2}, current=3)._at_rtl_item()
    assert not _client([WP, WP, WP], {0, 1, 2}, current=2)._at_rtl_item()  # no closing RTL at all


def _flying(items: list[int], reached: set[int], current: int) -> Px4MissionClient:
    """A client in flight in Mission mode (the state _check_mode and _judge_rtl read and write)."""
    import threading

    from vinecli.sitl.px4.mission_client import RTL_REPORT_GRACE_US

    c = _client(items, reached, current)
    c.started = c.in_mission = True
    c.finished, c.rtl_item, c.armed, c.mission_state = None, False, True, 0
    c.landed_state, c.mode_name, c.sim_time_us = M.LANDED_IN_AIR, "mission", 50 * RTL_REPORT_GRACE_US
    c.warnings, c._events, c._lock, c._rtl_pending = [], [], threading.Lock(), None
    return c


def _switch(c: Px4MissionClient, mode: str) -> None:
    c.mode_name = mode
    c._check_mode(mode)


def test_the_report_of_the_last_waypoint_arriving_after_the_switch_to_rtl_is_not_a_failsafe() -> None:
    """PX4's HEARTBEAT with the new mode may come before its MISSION_ITEM_REACHED / MISSION_CURRENT (seen in a
    three-way run): the switch is judged when the reports arrive, within the grace, not at once."""
    from vinecli.sitl.px4.mission_client import RTL_REPORT_GRACE_US

    items = [WP, WP, DO, WP, DO, M.CMD_NAV_RETURN_TO_LAUNCH]
    c = _flying(items, {0, 1, 2}, current=3)
    _switch(c, "rtl")
    assert c.finished is None and not c.rtl_item  # not judged yet
    c.sim_time_us += RTL_REPORT_GRACE_US // 2
    c.reached.add(3)  # the report arrives
    c._judge_rtl()
    assert c.finished is None and c.rtl_item and [k for k, *_ in c._events] == ["mission_rtl"]


def test_an_rtl_without_the_reports_within_the_grace_is_a_failsafe_with_the_warning_of_its_switch() -> None:
    import time

    from vinecli.sitl.px4.mission_client import RTL_REPORT_GRACE_US

    items = [WP, WP, DO, WP, DO, M.CMD_NAV_RETURN_TO_LAUNCH]
    c = _flying(items, {0, 1, 2}, current=3)
    c.warnings.append((time.monotonic(), "Low battery level! Returning"))
    _switch(c, "rtl")
    c.warnings.clear()  # expired by the time the grace is over (its wall-clock window): the switch's cause stays
    c.sim_time_us += RTL_REPORT_GRACE_US - 1
    c._judge_rtl()
    assert c.finished is None
    c.sim_time_us += 1
    c._judge_rtl()
    assert c.finished is not None and c.finished[0].value == "failsafe" and not c.rtl_item
    assert "Low battery level" in c.finished[1]
