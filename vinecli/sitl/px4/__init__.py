"""PX4 SITL in the loop: the simulator side of PX4's ``simulator_mavlink`` (:mod:`.backend`), mission
control over PX4's API link (:mod:`.mission`), the PX4 process vinecli starts (:mod:`.process`) and
``vinecli px4 doctor`` (:mod:`.doctor`)."""
