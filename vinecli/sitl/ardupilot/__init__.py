"""ArduCopter SITL in the loop: vinecli is the physics of ArduPilot's JSON backend, in lockstep
(:mod:`.backend`), with the JSON protocol (:mod:`.json_link`), the run's parameters (:mod:`.params`), the
mission in ArduPilot's terms (:mod:`.plan`), the ground-station conversation in simulated time
(:mod:`.client`) and the ArduPilot process vinecli starts (:mod:`.process`)."""
