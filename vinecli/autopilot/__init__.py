"""Autopilots behind one interface (:class:`vinecli.autopilot.base.Autopilot`): the built-in one and what it is made of.

* :mod:`~vinecli.autopilot.base`: the backend interface (an :class:`~vinecli.types.Observation` in, an
  :class:`~vinecli.types.ActuatorCommand` out, per physics step); :mod:`~vinecli.autopilot.registry`: backends by name.
* :mod:`~vinecli.autopilot.builtin`: the built-in autopilot, with :mod:`~vinecli.autopilot.supervisor` (modes,
  failsafes), :mod:`~vinecli.autopilot.estimator` (its state estimate), :mod:`~vinecli.autopilot.land_detector`,
  :mod:`~vinecli.autopilot.hover_thrust`, :mod:`~vinecli.autopilot.geofence`, :mod:`~vinecli.autopilot.terrain`
  (what it knows of the ground), :mod:`~vinecli.autopilot.preflight` and the mission phases it flies
  (:mod:`vinecli.autopilot.phases`).
* :mod:`~vinecli.autopilot.mavlink_vehicle`: the built-in autopilot behind a MAVLink vehicle endpoint.

Backends never touch PyBullet. May import the ground floor (constants, errors, frames, geo, inputs, outputs, types, ...), :mod:`vinecli.specs`, the plain models and tools of floor 2
(:mod:`vinecli.flight`, :mod:`vinecli.control`, :mod:`vinecli.terrain`, :mod:`vinecli.mavlink`, ...) and floor 3
(:mod:`vinecli.rows`, :mod:`vinecli.phase_items`); not the world, the simulator or the firmware bridges above it.
"""
