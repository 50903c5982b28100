"""MAVLink plumbing shared by the PX4 SITL backend, the PX4 mission client and the vehicle endpoint of the
built-in autopilot (:mod:`vinecli.autopilot.mavlink_vehicle`): protocol only, no autopilot, no PyBullet.

* :mod:`vinecli.mavlink.link` - MAVLink 2 over TCP (server/client) and UDP with a reader thread feeding a
  stateful pymavlink parser (TCP is a byte stream: never one message per ``recv``);
  :mod:`vinecli.mavlink.gcs_link` - the ``--mavlink`` addresses a ground station connects to.
* :mod:`vinecli.mavlink.px4modes` - PX4 custom modes (main/sub) and MAVLink constants.
* :mod:`vinecli.mavlink.mission_items` - MISSION_ITEM_INT on the wire (the phase <-> item converter is
  :mod:`vinecli.phase_items`); :mod:`vinecli.mavlink.px4params` - the PX4 parameters a mission sets.
* :mod:`vinecli.mavlink.vehicle` - the vehicle side of MAVLink (heartbeat, telemetry, commands, mission and
  parameter protocols) in front of any controller (docs/firmware-protocols.md §3).

May import the ground floor (constants, errors, frames, geo, inputs, outputs, types, ...) and :mod:`vinecli.specs`.
"""
