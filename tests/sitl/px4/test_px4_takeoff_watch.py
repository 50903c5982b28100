"""TakeoffWatch: the PX4 backend's cannot_take_off rule on hand-made traces."""

from __future__ import annotations

from vinecli.sitl.takeoff import TakeoffWatch

DT_US = 4000


def run(watch: TakeoffWatch, seconds: float, z_of_t, u: float, armed: bool = True, t0_us: int = 0) -> tuple[str, float]:
    t_us = t0_us
    while t_us < t0_us + seconds * 1e6:
        t = (t_us - t0_us) * 1e-6
        why = watch.update(t_us, DT_US * 1e-6, armed, z_of_t(t), 0.0, [u] * 4)
        if why:
            return why, t
        t_us += DT_US
    return "", seconds


def test_saturated_on_the_ground_for_the_vehicle_time():
    why, t = run(TakeoffWatch(2.0, None), 10.0, lambda t: 0.2, 0.95)
    assert "saturated" in why and abs(t - 2.0) < 0.01


def test_trying_below_saturation_without_lifting_off():
    why, t = run(TakeoffWatch(2.0, 20.0), 30.0, lambda t: 0.2, 0.8)
    assert "without lifting off" in why and abs(t - 6.0) < 0.01


def test_idling_on_the_ground_the_takeoff_timeout_decides():
    why, t = run(TakeoffWatch(2.0, 20.0), 30.0, lambda t: 0.2, 0.3)
    assert "no lift-off" in why and 20.0 < t < 20.1


def test_a_climb_or_a_disarmed_vehicle_is_fine():
    assert run(TakeoffWatch(2.0, 20.0), 30.0, lambda t: 0.2 + 0.5 * t, 0.95)[0] == ""  # full thrust, climbing
    assert run(TakeoffWatch(2.0, 20.0), 30.0, lambda t: 0.2, 1.0, armed=False)[0] == ""


def test_boot_parameters_script_is_validated():
    import pytest

    from vinecli.errors import InputError
    from vinecli.sitl.px4.process import boot_params_script

    text = boot_params_script({"EKF2_HGT_REF": 0, "NAV_MC_ALT_RAD": 0.2})
    assert "param set EKF2_HGT_REF 0\n" in text and "param set NAV_MC_ALT_RAD 0.2\n" in text
    assert boot_params_script({}) == ""
    for bad in ({"X; rm -rf /": 1}, {"NAV_MC_ALT_RAD": float("nan")}, {"lower": 1}):
        with pytest.raises(InputError):
            boot_params_script(bad)
