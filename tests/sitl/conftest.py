"""Fixtures of the firmware tests: the real PX4 v1.15 SITL (``px4_bin``, ``real_px4``; tests/sitl/px4/
real_px4.py) and the real ArduCopter SITL (``ardupilot_bin``; tests/sitl/ardupilot/real_ardupilot.py), from
``../shared`` or ``PX4_SITL_BIN`` / ``ARDUPILOT_SITL_BIN``; tests using them skip, with the reason, only when
neither exists."""

from tests.sitl.ardupilot.real_ardupilot import ardupilot_bin  # noqa: F401 - fixture
from tests.sitl.px4.real_px4 import px4_bin, real_px4  # noqa: F401 - fixtures
