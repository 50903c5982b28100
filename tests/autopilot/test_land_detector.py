"""The land detector against scripted signal sequences, with PX4's timings (MulticopterLandDetector,
LNDMC_TRIG_TIME 1 s: ground contact, maybe landed and landed each after 1/3 s of their conditions;
three times that while a rangefinder has no valid distance) and thresholds (LNDMC_Z_VEL_MAX 0.25 m/s,
LNDMC_XY_VEL_MAX 1.5 m/s, LNDMC_ROT_MAX 20 deg/s, low thrust 30 % / 60 % of the way to hover,
minimum thrust 10 %, free fall below 2 m/s² for 0.3 s)."""

from __future__ import annotations

import math

import pytest

from vinecli.autopilot.land_detector import Hysteresis, LandDetector

DT_US = 20_000  # the position-loop rate, 50 Hz
THR_MIN, HOVER = 0.12, 0.5
STAGE_US = 1_000_000 // 3  # LNDMC_TRIG_TIME / 3
NAN = math.nan


def detector() -> LandDetector:
    return LandDetector(THR_MIN, HOVER)


def run(ld: LandDetector, t0_us: int, seconds: float, *, armed: bool = True, vel: tuple[float, float, float] = (0.0, 0.0, 0.0),
        omega: tuple[float, float, float] = (0.0, 0.0, 0.0), acc: tuple[float, float, float] = (0.0, 0.0, 0.0),
        thrust: float = HOVER, hover: float = HOVER, hover_valid: bool = False, vz_sp: float = NAN,
        thrust_after_contact: float | None = None, z0: float = 0.0, **kw: object) -> tuple[int, dict[str, int | None]]:
    """Feed constant signals for ``seconds`` (the altitude from ``z0`` moves with ``vel``); when the
    detector reports ground contact the thrust drops to ``thrust_after_contact`` (the position
    controller's minimum thrust, as PX4). Returns the end time and the first time each state was seen true."""
    first: dict[str, int | None] = {"ground_contact": None, "maybe_landed": None, "landed": None, "freefall": None}
    t = t0_us
    for _ in range(int(round(seconds * 1e6 / DT_US))):
        t += DT_US
        thr = thrust_after_contact if thrust_after_contact is not None and ld.ground_contact else thrust
        z = z0 + vel[2] * (t - t0_us) * 1e-6
        ld.update(t, armed, z, vel, omega, acc, thr, hover, hover_valid, vz_sp, **kw)  # type: ignore[arg-type]
        for k in first:
            if first[k] is None and getattr(ld, k):
                first[k] = t
    return t, first


def fly(ld: LandDetector, seconds: float = 1.0) -> int:
    """Armed and flying a descent: not landed, no ground contact."""
    t, _ = run(ld, 0, seconds, vel=(0.0, 0.0, -0.7), thrust=0.45, vz_sp=-0.7, z0=0.7 * seconds)  # down to z = 0
    assert not ld.ground_contact and not ld.maybe_landed and not ld.landed
    return t


def test_hysteresis_turns_true_after_the_time_and_false_at_once() -> None:
    h = Hysteresis(False, from_false_us=300_000)
    h.set_state_and_update(True, 1_000_000)
    h.update(1_299_999)
    assert not h.state
    h.update(1_300_000)
    assert h.state
    h.set_state_and_update(False, 1_300_001)
    assert not h.state
    # a request that lapses restarts the clock
    h.set_state_and_update(True, 2_000_000)
    h.set_state_and_update(False, 2_200_000)
    h.set_state_and_update(True, 2_250_000)
    h.update(2_500_000)
    assert not h.state
    h.update(2_550_000)
    assert h.state


def test_touchdown_sequence_takes_px4s_one_second() -> None:
    """Touchdown at t0: the descent stops, the thrust falls below the low-thrust level; ground contact
    after 1/3 s, then (the controller at its minimum thrust) maybe landed and landed 1/3 s apart."""
    ld = detector()
    t0 = fly(ld)
    _, first = run(ld, t0, 2.0, vel=(0.0, 0.0, 0.0), thrust=0.2, vz_sp=-0.7, thrust_after_contact=THR_MIN)
    gc, ml, la = first["ground_contact"], first["maybe_landed"], first["landed"]
    assert gc is not None and ml is not None and la is not None
    step = DT_US
    # each stage needs its conditions for 1/3 s, seen at the 50 Hz updates
    assert STAGE_US <= gc - t0 - step < STAGE_US + step
    assert STAGE_US <= ml - gc - step < STAGE_US + step
    assert STAGE_US <= la - ml < STAGE_US + step
    assert la - t0 == pytest.approx(1.0e6, abs=3 * step)


def test_ground_contact_needs_a_commanded_descent_while_flying() -> None:
    ld = detector()
    t0 = fly(ld)
    _, first = run(ld, t0, 3.0, thrust=0.2, vz_sp=0.0)  # holding altitude: low thrust, no motion
    assert first["ground_contact"] is None and not ld.landed
    # the descent must be at least 1.1 LNDMC_Z_VEL_MAX
    _, first = run(ld, t0 + 3_000_000, 2.0, thrust=0.2, vz_sp=-0.26)
    assert first["ground_contact"] is None
    _, first = run(ld, t0 + 5_000_000, 2.0, thrust=0.2, vz_sp=-0.28)
    assert first["ground_contact"] is not None


@pytest.mark.parametrize(("signals", "blocks"), [
    ({"vel": (0.0, 0.0, -0.26)}, "ground_contact"),  # still descending (|vz| >= 0.25 m/s)
    ({"vel": (1.2, 1.0, 0.0)}, "ground_contact"),  # moving horizontally (> 1.5 m/s)
    ({"thrust": 0.36}, "ground_contact"),  # above 30 % of the way from minimum to hover thrust
    ({"omega": (0.3, 0.2, 0.0)}, "maybe_landed"),  # rolling/pitching faster than 20 deg/s
    ({"dist_bottom": 1.5, "range_observable": True}, "ground_contact"),  # a rangefinder says 1.5 m up
])
def test_each_condition_blocks_its_state(signals: dict[str, object], blocks: str) -> None:
    ld = detector()
    t0 = fly(ld)
    args: dict[str, object] = {"vel": (0.0, 0.0, 0.0), "thrust": 0.2, "vz_sp": -0.7, "thrust_after_contact": THR_MIN}
    args.update(signals)
    _, first = run(ld, t0, 3.0, **args)  # type: ignore[arg-type]
    assert first[blocks] is None
    assert first["landed"] is None
    if blocks == "maybe_landed":
        assert first["ground_contact"] is not None  # the earlier stage still passes


def test_no_ground_contact_while_the_altitude_climbed_in_the_last_second() -> None:
    """A bounce: 0.3 m up within the last second (more than LNDMC_Z_VEL_MAX x 1 s) is no contact even
    with the estimated speed below the threshold; once the window has passed, contact."""
    ld = detector()
    t0 = fly(ld)
    t = t0
    for k in range(25):  # 0.5 s rising 0.6 m/s while the velocity estimate lags (reads 0)
        t += DT_US
        ld.update(t, True, 0.012 * (k + 1), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.2, HOVER, False, -0.7)
    assert ld.climbing
    _, first = run(ld, t, 2.0, thrust=0.2, vz_sp=-0.7, z0=0.3)
    gc = first["ground_contact"]
    assert gc is not None and 1_000_000 - 5 * DT_US <= gc - t0 <= 1_000_000 + STAGE_US + 2 * DT_US


def test_a_valid_hover_thrust_estimate_relaxes_the_low_thrust_level() -> None:
    """Thrust at half the way from minimum to hover: low only with a valid estimate (60 % vs 30 %)."""
    thrust = THR_MIN + 0.5 * (HOVER - THR_MIN)
    ld = detector()
    t0 = fly(ld)
    _, first = run(ld, t0, 2.0, thrust=thrust, vz_sp=-0.7)
    assert first["ground_contact"] is None
    ld = detector()
    t0 = fly(ld)
    _, first = run(ld, t0, 2.0, thrust=thrust, vz_sp=-0.7, hover_valid=True)
    assert first["ground_contact"] is not None
    # the estimate replaces the nominal hover thrust: a lower hover thrust lowers the levels
    ld = detector()
    t0 = fly(ld)
    _, first = run(ld, t0, 2.0, thrust=thrust, vz_sp=-0.7, hover=0.3, hover_valid=True)
    assert first["ground_contact"] is None


def test_a_rangefinder_without_a_valid_distance_triples_the_times() -> None:
    ld = detector()
    t0 = fly(ld)
    _, first = run(ld, t0, 4.0, thrust=0.2, vz_sp=-0.7, thrust_after_contact=THR_MIN, dist_bottom=NAN, range_observable=True)
    la = first["landed"]
    assert la is not None and la - t0 == pytest.approx(3.0e6, abs=3 * DT_US)
    # with a valid distance under 1 m: the normal times
    ld = detector()
    t0 = fly(ld)
    _, first = run(ld, t0, 4.0, thrust=0.2, vz_sp=-0.7, thrust_after_contact=THR_MIN, dist_bottom=0.1, range_observable=True)
    la = first["landed"]
    assert la is not None and la - t0 == pytest.approx(1.0e6, abs=3 * DT_US)


def test_takeoff_clears_landed_as_soon_as_the_thrust_rises() -> None:
    """Armed on the ground at idle thrust: landed. The first update above 10 % of the way to hover
    ends maybe-landed and landed at once (no hysteresis in that direction)."""
    ld = detector()
    t, _ = run(ld, 0, 1.0, thrust=0.0)
    assert ld.landed and ld.maybe_landed
    threshold = THR_MIN + 0.1 * (HOVER - THR_MIN)
    ld.update(t + DT_US, True, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), threshold - 1e-3, HOVER, False, NAN)
    assert ld.landed
    ld.update(t + 2 * DT_US, True, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), threshold + 1e-3, HOVER, False, NAN)
    assert not ld.landed and not ld.maybe_landed


def test_free_fall_after_300_ms_and_it_blocks_maybe_landed() -> None:
    ld = detector()
    t0 = fly(ld)
    # specific force 1.5 m/s²: falling (acceleration -8.3 m/s² world up)
    _, first = run(ld, t0, 1.0, vel=(0.0, 0.0, 0.0), acc=(0.0, 0.0, -8.3), thrust=THR_MIN, vz_sp=-0.7)
    ff = first["freefall"]
    assert ff is not None and 300_000 <= ff - t0 < 300_000 + 2 * DT_US
    assert first["maybe_landed"] is None


def test_disarmed_everything_is_true() -> None:
    ld = detector()
    fly(ld)
    _, first = run(ld, 1_000_000, 1.0, armed=False, vel=(0.0, 0.0, -0.7), thrust=0.0)
    assert ld.ground_contact and ld.maybe_landed and ld.landed
    assert first["landed"] is not None


def test_set_flying_starts_in_the_air() -> None:
    ld = detector()
    ld.set_flying()
    assert not ld.ground_contact and not ld.maybe_landed and not ld.landed
    # hovering at hover thrust: stays flying
    run(ld, 0, 2.0, thrust=HOVER, vz_sp=0.0)
    assert not ld.landed
