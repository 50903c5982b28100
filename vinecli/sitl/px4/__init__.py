"""PX4 SITL in the loop: the simulator side of PX4's ``simulator_mavlink`` (:mod:`~vinecli.sitl.px4.backend`),
mission control over PX4's API link (:mod:`~vinecli.sitl.px4.mission_client`), the PX4 process vinecli starts
(:mod:`~vinecli.sitl.px4.process`), what PX4's own log says after a run (:mod:`~vinecli.sitl.px4.log_audit`) and
``vinecli px4 doctor`` (:mod:`~vinecli.sitl.px4.doctor`).

``backend`` and ``process`` have the same role as :mod:`vinecli.sitl.ardupilot`'s. May import what
:mod:`vinecli.sitl` may and the shared modules of :mod:`vinecli.sitl`; never :mod:`vinecli.sitl.ardupilot`.
"""
