"""Setpoint generation along polylines: speed limits, corners, lead limit, terrain following."""

from __future__ import annotations

import math

import pytest

from vinecli.control.path import PathFollower

DT = 0.02


def follow(path: PathFollower, seconds: float, *, perfect: bool = True, stuck_at: tuple[float, float, float] | None = None):
    """Drive the carrot with a vehicle that sits on it (perfect tracking) or is stuck."""
    out = []
    pos = path.sp
    for _ in range(int(seconds / DT)):
        sp, vff, done = path.update(DT, stuck_at if stuck_at is not None else pos)
        out.append((sp, vff, done, path.flow))
        if perfect:
            pos = sp
        if done:
            break
    return out


def test_straight_line_cruise_and_stop() -> None:
    p = PathFollower([(0.0, 0.0, 5.0), (20.0, 0.0, 5.0)], 3.0, accel=1.5)
    out = follow(p, 30.0)
    assert out[-1][2] and out[-1][0] == pytest.approx((20.0, 0.0, 5.0))
    speeds = [math.hypot(v[0], v[1]) for _, v, _, _ in out]
    assert max(speeds) == pytest.approx(3.0, abs=1e-6)
    assert speeds[-1] < 0.2  # decelerated into the end point
    assert all(b - a <= 1.5 * DT + 1e-9 for a, b in zip(speeds, speeds[1:], strict=False))  # acceleration limit


def test_vertical_speed_is_capped_per_segment() -> None:
    p = PathFollower([(0.0, 0.0, 0.0), (0.0, 0.0, 10.0), (30.0, 0.0, 10.0), (30.0, 0.0, 2.0)], 5.0, accel=2.0,
                     max_up=3.0, max_down=1.5)
    out = follow(p, 40.0)
    assert out[-1][2]
    assert max(v[2] for _, v, _, _ in out) <= 3.0 + 1e-6
    assert min(v[2] for _, v, _, _ in out) >= -1.5 - 1e-6
    assert max(abs(v[0]) for _, v, _, _ in out) == pytest.approx(5.0, abs=1e-6)


def test_corners_are_taken_slowly() -> None:
    p = PathFollower([(0.0, 0.0, 2.0), (10.0, 0.0, 2.0), (10.0, 1.0, 2.0), (0.0, 1.0, 2.0)], 2.0, corner_speed=0.3)
    out = follow(p, 40.0)
    near_corner = [math.hypot(v[0], v[1]) for sp, v, _, _ in out if math.dist(sp[:2], (10.0, 0.0)) < 0.05]
    assert near_corner and max(near_corner) < 0.6
    assert max(math.hypot(v[0], v[1]) for _, v, _, _ in out) == pytest.approx(2.0, abs=1e-6)


def test_carrot_waits_for_a_lagging_vehicle() -> None:
    p = PathFollower([(0.0, 0.0, 2.0), (50.0, 0.0, 2.0)], 5.0, max_lead_m=2.5)
    out = follow(p, 10.0, perfect=False, stuck_at=(0.0, 0.0, 2.0))
    # it brakes (at twice the acceleration) once 2.5 m ahead and then stays put
    v_at_lead = math.sqrt(2 * 1.5 * 2.5)
    assert 2.5 < out[-1][0][0] <= 2.5 + v_at_lead**2 / (2 * 3.0) + 0.1
    assert out[-1][0] == out[-100][0]
    assert not any(done for _, _, done, _ in out)


def test_flow_per_segment() -> None:
    p = PathFollower([(0.0, 0.0, 2.0), (5.0, 0.0, 2.0), (5.0, 2.0, 2.0), (0.0, 2.0, 2.0)], 2.0, flows=[0.1, 0.0, 0.1])
    out = follow(p, 30.0)
    for sp, _, done, flow in out:
        if done:
            assert flow == 0.0
        elif 0.3 < sp[0] < 4.7:
            assert flow == 0.1
        elif sp[0] == pytest.approx(5.0) and 0.1 < sp[1] < 1.9:
            assert flow == 0.0


def test_rough_terrain_is_smoothed() -> None:
    # a DSM-like surface: 0.4 m crop ridges every 0.9 m on a 2 % slope
    def terrain(x: float, y: float) -> float:
        return 0.02 * x + 0.2 * (1.0 + math.sin(2.0 * math.pi * y / 0.9))

    p = PathFollower([(0.0, 0.0, 1.5), (0.0, 30.0, 1.5)], 2.0, terrain=terrain, max_vz=1.5)
    out = follow(p, 30.0)
    assert out[-1][2]
    vz = [v[2] for _, v, _, _ in out]
    assert max(abs(v) for v in vz) < 0.6  # the ridges are not chased
    assert all(a == 0.0 for a in (p.aff[2],))
    mid = [sp[2] for sp, _, _, _ in out[len(out) // 4: 3 * len(out) // 4]]
    assert sum(mid) / len(mid) == pytest.approx(1.5 + 0.2, abs=0.1)  # mean terrain + height


def test_terrain_step_is_climbed_before_it_is_reached() -> None:
    """A 3 m terrain step (building edge) at y = 20: the carrot looks ahead and is already well
    above the step top when it gets there (low-pass alone climbs only after the edge)."""
    def terrain(x: float, y: float) -> float:
        return 3.0 if y >= 20.0 else 0.0

    p = PathFollower([(0.0, 0.0, 2.0), (0.0, 40.0, 2.0)], 2.0, terrain=terrain, max_vz=1.5)
    assert p.lookahead == pytest.approx(2.0 * 2.0 + 2.0 * 2.0 / (2 * 1.5))  # v·2 s + braking distance
    out = follow(p, 40.0)
    at_edge = [sp[2] for sp, _, _, _ in out if 19.5 <= sp[1] < 20.0]
    assert at_edge and min(at_edge) >= 3.0 + 1.3  # ≥ 1.3 m above the step top before reaching it
    clear = [sp[2] - terrain(sp[0], sp[1] + dy) for sp, _, _, _ in out for dy in (0.0, 0.3)]
    assert min(clear) >= 1.3  # also 0.3 m ahead of the carrot (the airframe)
    vz = [v[2] for _, v, _, _ in out]
    assert max(vz) <= 1.5 + 1e-6  # rate-limited climb
    early = [sp[2] for sp, _, _, _ in out if sp[1] < 20.0 - p.lookahead - 0.5]
    assert max(early) == pytest.approx(2.0, abs=0.05)  # no climb before the step is in view
    assert out[-1][0][2] == pytest.approx(5.0, abs=0.05)  # and the set height above the step top


@pytest.mark.parametrize("flow", [0.0, 0.01])
def test_speeds_up_gently_with_the_sections_open(flow: float) -> None:
    """From rest on a pass (a run-in the fence left no room for): up to the sprayer's minimum speed at the path's
    acceleration, then at ``spray_accel`` while the sections are open (the pitch of a harder one tilts the nozzles:
    the dip where it ends); with the sections closed at the path's acceleration throughout."""
    p = PathFollower([(0.0, 0.0, 2.0), (40.0, 0.0, 2.0)], 3.0, accel=1.5, flows=[flow], spray_accel=0.25,
                     spray_accel_above=1.0)
    out = follow(p, 8.0)
    speeds = [math.hypot(v[0], v[1]) for _, v, _, _ in out]
    rises = [(a, (b - a) / DT) for a, b in zip(speeds, speeds[1:], strict=False) if b > a]
    slow = [r for v, r in rises if v < 1.0 - 1.5 * DT]
    fast = [r for v, r in rises if v >= 1.0]
    assert max(slow) == pytest.approx(1.5)
    assert max(fast) == pytest.approx(0.25 if flow > 0 else 1.5)
    assert speeds[int(5.0 / DT)] == pytest.approx(min(3.0, 1.0 + 0.25 * (5.0 - 1.0 / 1.5)) if flow else 3.0, abs=0.05)
