"""The mission phases the built-in autopilot flies, one :class:`~vinecli.autopilot.phases.phase.Phase` each.

* :mod:`~vinecli.autopilot.phases.phase`: what a phase is and what it may ask of the autopilot
  (:class:`~vinecli.autopilot.phases.phase.PhaseHost`).
* :mod:`~vinecli.autopilot.phases.from_spec`: a mission's phase specs -> runnable phases (``make_phase``).
* :mod:`~vinecli.autopilot.phases.flight`: take-off, hold, loiter, goto, waypoints, sprayer, land, RTL,
  open loop.
* :mod:`~vinecli.autopilot.phases.spray`: the spray phase (section control, refill sorties) and
  :mod:`~vinecli.autopilot.phases.sorties`: its ground operations.

Compiled with the kernel (vinecli/native.py). May import what :mod:`vinecli.autopilot` may.
The converter between phases and MAVLink mission items is :mod:`vinecli.phase_items`.
"""
