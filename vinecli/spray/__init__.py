"""Spray science as plain models (numpy, no PyBullet, no MAVLink): droplets, the rotor wake, where the
liquid lands, the canopy it meets, drift and the budget of where every litre went. World ENU, SI units.

* :mod:`~vinecli.spray.droplets`, :mod:`~vinecli.spray.evaporation`: size classes, settling, drying.
* :mod:`~vinecli.spray.downwash`, :mod:`~vinecli.spray.outwash`: the rotor wake and what it blows sideways.
* :mod:`~vinecli.spray.deposition` (transport), :mod:`~vinecli.spray.deposit_grid` (rasterising),
  :mod:`~vinecli.spray.swath` (a pass's expected pattern and effective swath).
* :mod:`~vinecli.spray.canopy`, :mod:`~vinecli.spray.interception`, :mod:`~vinecli.spray.collectors`:
  the hedges, what their leaves catch, collectors in them.
* :mod:`~vinecli.spray.drift`, :mod:`~vinecli.spray.budget`: drift beyond the field, the five volumes.
* :mod:`~vinecli.spray.spray_trial`, :mod:`~vinecli.spray.published_trials`: the model against field trials.

May import: the ground floor (constants, frames, ...), :mod:`vinecli.specs` and :mod:`vinecli.flight`
(the wind's height profile); nothing above. docs/deposition.md and docs/budget.md describe the models.
"""
