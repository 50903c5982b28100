"""Fixtures of the ArduPilot tests: the real ArduCopter SITL (tests/ardupilot/real_ardupilot.py)."""

from tests.ardupilot.real_ardupilot import ardupilot_bin  # noqa: F401 - fixture
