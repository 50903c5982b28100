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
