"""Firmware in the loop: vinecli as the simulator side of real autopilot firmware (as PX4's Gazebo bridge).

One package per firmware (:mod:`vinecli.sitl.px4`), and what every firmware bridge shares written once
here (:mod:`vinecli.sitl.process` process supervision, :mod:`vinecli.sitl.takeoff` the cannot-take-off
watch, :mod:`vinecli.sitl.options` the run's autopilot options and the one factory of a run's backend).
The built-in autopilot and the backend interface are :mod:`vinecli.autopilot`. Light to import.
"""
