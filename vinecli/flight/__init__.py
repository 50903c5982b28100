"""Physics models as plain Python objects (no PyBullet): motors, drag, wind, tank, sensors.

World frame ENU, body frame FLU, SI units; per-step code uses plain floats (design.md §8).
The simulation engine (``vinecli.sim``) applies these models to PyBullet bodies.

Modules: :mod:`~vinecli.flight.motor` (MotorBank), :mod:`~vinecli.flight.aero`
(wind_drag), :mod:`~vinecli.flight.wind` (make_wind) and :mod:`~vinecli.flight.dryden`,
:mod:`~vinecli.flight.tank` (Tank), :mod:`~vinecli.flight.sensors` (make_sensors),
:mod:`~vinecli.flight.magnetic` (earth_field_ned), :mod:`~vinecli.flight.atmosphere`.
Submodules are imported on use so importing the package stays cheap.
"""
