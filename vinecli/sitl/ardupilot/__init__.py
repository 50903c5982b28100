"""ArduCopter SITL in the loop: vinecli is the physics of ArduPilot's JSON backend, in lockstep
(:mod:`~vinecli.sitl.ardupilot.backend`), with the JSON protocol (:mod:`~vinecli.sitl.ardupilot.json_link`), the
run's parameters (:mod:`~vinecli.sitl.ardupilot.params`), the mission in ArduPilot's terms
(:mod:`~vinecli.sitl.ardupilot.mission_plan`), the ground-station conversation in simulated time
(:mod:`~vinecli.sitl.ardupilot.client`) and the ArduPilot process vinecli starts (:mod:`~vinecli.sitl.ardupilot.process`).

``backend``, ``process`` and ``params`` have the same role as :mod:`vinecli.sitl.px4`'s and :mod:`vinecli.sitl`'s.
May import what :mod:`vinecli.sitl` may and the shared modules of :mod:`vinecli.sitl`; never :mod:`vinecli.sitl.px4`.
"""
