"""Flight dynamics as plain models (no PyBullet, no MAVLink): the vehicle and the air it flies in, per physics step.

* :mod:`~vinecli.flight.motor` (``MotorBank``: rotor lag, thrust, rotor drag, torques), :mod:`~vinecli.flight.aero`
  (drag on the links), :mod:`~vinecli.flight.battery` (cells, load, sag), :mod:`~vinecli.flight.tank` (the liquid's
  push, sloshing), :mod:`~vinecli.flight.pump` (the sprayer's pump).
* :mod:`~vinecli.flight.wind` (``make_wind``) and :mod:`~vinecli.flight.dryden` (turbulence);
  :mod:`~vinecli.flight.atmosphere` (ISA), :mod:`~vinecli.flight.magnetic` (the Earth's field).
* :mod:`~vinecli.flight.sensors` (IMU, barometer, magnetometer, GNSS) and :mod:`~vinecli.flight.rangefinder`.

World frame ENU, body frame FLU, SI units; per-step code uses plain floats (docs/flight-models.md §6) and most of it
is compiled with the kernel (vinecli/native.py). The simulator (:mod:`vinecli.sim`) applies these models to
PyBullet bodies. May import the ground floor (constants, errors, frames, geo, inputs, outputs, types, ...) and :mod:`vinecli.specs`. Submodules are imported on use.
"""
