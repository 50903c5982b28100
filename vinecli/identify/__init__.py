"""Vehicle identification from flight logs: fit a vehicle to a log, replay a log through a vehicle.

:mod:`~vinecli.identify.fit` (``vinecli vehicle fit``), :mod:`~vinecli.identify.vehicle_io` (outputs and
``vinecli vehicle replay``); the fits: :mod:`~vinecli.identify.thrust`, :mod:`~vinecli.identify.drag`,
:mod:`~vinecli.identify.battery_fit`, :mod:`~vinecli.identify.power`, each parameter with its uncertainty
(:mod:`~vinecli.identify.fitted_params`), gathered in :mod:`~vinecli.identify.fit_result`; the replay:
:mod:`~vinecli.identify.replay_model` (vinecli's flight models on a rigid body) and :mod:`~vinecli.identify.replay`.

Logs are read by :mod:`vinecli.flightlog`. May import the ground floor (constants, errors, frames, geo, inputs, outputs, types, ...), :mod:`vinecli.specs` and floor 2 (:mod:`vinecli.flight`,
:mod:`vinecli.flightlog`, :mod:`vinecli.vehicle`); no PyBullet. ``defaults.py`` holds the command line's defaults,
as in :mod:`vinecli.terrain`. Submodules are imported on use.
"""
