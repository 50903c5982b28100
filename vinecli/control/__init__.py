"""Multicopter control building blocks of the built-in autopilot (plain floats, no PyBullet).

* :mod:`~vinecli.control.pid`: scalar PID with anti-windup and a filtered derivative.
* :mod:`~vinecli.control.allocation`: rotor mixer with PX4-style sequential desaturation.
* :mod:`~vinecli.control.cascade`: position -> velocity -> attitude -> rate cascade.
* :mod:`~vinecli.control.path`: path following; :mod:`~vinecli.control.sprayer`: the speed-scaled sprayer flow.

May import the ground floor (constants, errors, frames, geo, inputs, outputs, types, ...) and :mod:`vinecli.specs`.
"""
