"""Multicopter control building blocks of the built-in autopilot (no PyBullet, plain floats).

* :mod:`vinecli.control.pid` - scalar PID with anti-windup and a filtered derivative.
* :mod:`vinecli.control.allocation` - rotor mixer with PX4-style sequential desaturation.
* :mod:`vinecli.control.cascade` - position -> velocity -> attitude -> rate cascade.
"""
