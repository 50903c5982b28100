"""Vehicle identification from flight logs: fit a vehicle to a log, replay a log through a vehicle.

:mod:`~vinecli.identify.fit` (``vinecli vehicle fit``), :mod:`~vinecli.identify.vehicle_io` (outputs and
``vinecli vehicle replay``); the fits: :mod:`~vinecli.identify.thrust`, :mod:`~vinecli.identify.drag`,
:mod:`~vinecli.identify.battery_fit`, :mod:`~vinecli.identify.power`; the replay:
:mod:`~vinecli.identify.replay_model` (vinecli's physics on a rigid body) and :mod:`~vinecli.identify.replay`.
Logs are read by :mod:`vinecli.flightlog`. Submodules are imported on use.
"""
