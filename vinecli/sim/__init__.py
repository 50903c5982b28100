"""The simulator: THE loop over a world in PyBullet, what it records, and what it hands the spray models.

* :mod:`~vinecli.sim.runner` (``run_simulation``), :mod:`~vinecli.sim.setup` (a run's inputs resolved once),
  :mod:`~vinecli.sim.loop` (``Flight``: one physics step), :mod:`~vinecli.sim.vehicle_physics` (the flight models
  composed per step), :mod:`~vinecli.sim.ground_events`, :mod:`~vinecli.sim.recorder` (the time series),
  :mod:`~vinecli.sim.result` (``SimResult``).
* :mod:`~vinecli.sim.spray_groups` and :mod:`~vinecli.sim.spray_deposit`: the sprayed volume handed to the spray
  transport (:mod:`vinecli.spray`) and rasterised.
* :mod:`~vinecli.sim.camera`, :mod:`~vinecli.sim.perfect_estimator`, :mod:`~vinecli.sim.autopilot_inputs`,
  :mod:`~vinecli.sim.memory` (what a run may hold).

Most of the loop is compiled with the kernel (vinecli/native.py). May import every floor below it (the world,
the autopilots, the models); never missions, runs or anything above.
"""
