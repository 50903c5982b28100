"""Firmware in the loop (SITL): vinecli as the simulator side of real autopilot firmware, as PX4's Gazebo bridge.

One package per firmware, :mod:`vinecli.sitl.px4` and :mod:`vinecli.sitl.ardupilot`, with the same role under
the same name in each (``backend``, ``process``, ``params``: the names repeat on purpose), and what every
firmware bridge shares written once here: :mod:`~vinecli.sitl.process` (process supervision),
:mod:`~vinecli.sitl.params` (a run's firmware parameters), :mod:`~vinecli.sitl.polled_link` (a MAVLink link read
in lockstep), :mod:`~vinecli.sitl.inbox`, :mod:`~vinecli.sitl.mission_upload`, :mod:`~vinecli.sitl.converter`,
:mod:`~vinecli.sitl.identity`, :mod:`~vinecli.sitl.record`, :mod:`~vinecli.sitl.takeoff` (the cannot-take-off
watch) and :mod:`~vinecli.sitl.options` (the run's autopilot options and the one factory of a run's backend).

The protocols: docs/firmware-protocols.md. May import every floor below it (autopilot: the backend interface;
:mod:`vinecli.mavlink`; the flight models a firmware reads: atmosphere, magnetic field, battery, pump); no
PyBullet. Light to import.
"""
