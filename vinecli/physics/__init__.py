"""Physics models as plain Python objects (no PyBullet): motors, drag, wind, tank, sensors.

World frame ENU, body frame FLU, SI units; per-step code uses plain floats (design.md §8).
The simulation engine (``vinecli.sim``) applies these models to PyBullet bodies.

Modules: :mod:`~vinecli.physics.motor` (MotorBank), :mod:`~vinecli.physics.aero`
(wind_drag), :mod:`~vinecli.physics.wind` (make_wind) and :mod:`~vinecli.physics.dryden`,
:mod:`~vinecli.physics.tank` (Tank), :mod:`~vinecli.physics.sensors` (make_sensors),
:mod:`~vinecli.physics.magnetic` (earth_field_ned), :mod:`~vinecli.physics.atmosphere`.
Submodules are imported on use so importing the package stays cheap.
"""
