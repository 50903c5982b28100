"""THE converter between mission phases and MAVLink mission items (MISSION_ITEM_INT), for every firmware.

* :func:`phases_to_items` (:mod:`~vinecli.phase_items.to_items`): a mission as the items a ground station
  uploads, the sprayer switched with the command the caller chose (:data:`DO_SET_ACTUATOR` for PX4,
  :data:`DO_SPRAYER` or :func:`do_set_servo` for ArduPilot; :mod:`~vinecli.phase_items.sprayer_command`),
  spray phases as THE spray plan (:mod:`~vinecli.phase_items.spray_legs`);
* :func:`items_to_phases` (:mod:`~vinecli.phase_items.to_phases`): items back to phases the built-in
  autopilot flies (the MAVLink vehicle endpoint, an uploaded or imported mission).

Positions are MAVLink's degE7 ints, or float degrees for a plan file (``PlanContext.degrees``,
``items_to_phases(degrees=True)``: QGroundControl ``.plan`` export and import, :mod:`vinecli.missions.qgc_export`,
:mod:`vinecli.missions.qgc_import`), both through the world's georeference. Firmware parameters (PX4:
:mod:`vinecli.mavlink.px4params`) and the transport (upload, the .plan JSON) are the callers'.
The wire type is :class:`vinecli.mavlink.mission_items.MissionItem`; the runnable phases of the built-in
autopilot are :mod:`vinecli.autopilot.phases`.

May import the ground floor (constants, errors, frames, geo, inputs, outputs, types, ...), :mod:`vinecli.specs`, :mod:`vinecli.mavlink` and :mod:`vinecli.rows` (the spray plan).
"""

from vinecli.phase_items.sprayer_command import (
           DO_SET_ACTUATOR,
           DO_SPRAYER,
           SprayerCommand,
           do_set_servo,
           sprayer_fraction,
)
from vinecli.phase_items.to_items import ItemPlan, PlanContext, fence_items, phases_to_items, sortie_to_items
from vinecli.phase_items.to_phases import items_to_phases

__all__ = ["DO_SET_ACTUATOR", "DO_SPRAYER", "ItemPlan", "PlanContext", "SprayerCommand", "do_set_servo", "fence_items",
           "items_to_phases", "phases_to_items", "sortie_to_items", "sprayer_fraction"]
