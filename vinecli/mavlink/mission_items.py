"""MAVLink mission items on the wire: :class:`MissionItem` (one MISSION_ITEM_INT), ENU <-> degE7, and
which items a vehicle endpoint accepts (:func:`check_item`).

The conversion between mission phases and items is :mod:`vinecli.phase_items` (one converter for every
firmware). x/y are degE7 of WGS84 lat/lon of the world point through the world's georeference
(:meth:`GeoOrigin.enu_to_geodetic_fast`: the tangent plane, or a world's CRS grid, docs/architecture.md "Frames").
"""

from __future__ import annotations

from dataclasses import dataclass

from vinecli.geo import GeoOrigin
from vinecli.mavlink import px4modes as M


@dataclass
class MissionItem:
    """One MISSION_ITEM_INT (without seq/target): x, y degE7 ints (or int params), z float. An item of a plan file
    (a QGroundControl ``.plan``) carries x, y as float degrees instead (:func:`item_xy` with ``degrees``); those are
    never encoded for the wire."""

    command: int
    frame: int = M.MAV_FRAME_MISSION
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    x: float = 0
    y: float = 0
    z: float = 0.0
    autocontinue: int = 1
    mission_type: int = M.MAV_MISSION_TYPE_MISSION
    phase_index: int = -1  # mission phase this item comes from (vinecli side), -1 unknown

    @classmethod
    def from_msg(cls, msg: object) -> MissionItem:
        """From a pymavlink MISSION_ITEM_INT (or legacy MISSION_ITEM: x/y floats in degrees)."""
        x, y = msg.x, msg.y  # type: ignore[attr-defined]
        if msg.get_type() == "MISSION_ITEM" and msg.frame in (0, 3, 10):  # type: ignore[attr-defined]
            x, y = round(x * 1e7), round(y * 1e7)
        return cls(
            command=msg.command, frame=msg.frame,  # type: ignore[attr-defined]
            param1=msg.param1, param2=msg.param2, param3=msg.param3, param4=msg.param4,  # type: ignore[attr-defined]
            x=int(x), y=int(y), z=float(msg.z), autocontinue=msg.autocontinue,  # type: ignore[attr-defined]
            mission_type=getattr(msg, "mission_type", 0),
        )

    def encode(self, mav: object, seq: int, target_system: int, target_component: int, current: int = 0) -> object:
        """A pymavlink MISSION_ITEM_INT message for this item."""
        return mav.mission_item_int_encode(  # type: ignore[attr-defined]
            target_system, target_component, seq, self.frame, self.command, current, self.autocontinue,
            self.param1, self.param2, self.param3, self.param4, self.x, self.y, self.z, self.mission_type,
        )

# ---------------------------------------------------------------- geometry helpers
def enu_to_degE7(origin: GeoOrigin, x: float, y: float) -> tuple[int, int]:
    """ENU (m) -> (lat degE7, lon degE7)."""
    lat, lon, _ = origin.enu_to_geodetic_fast(x, y, 0.0)
    return round(lat * 1e7), round(lon * 1e7)


def degE7_to_enu(origin: GeoOrigin, lat_e7: float, lon_e7: float) -> tuple[float, float]:
    """(lat degE7, lon degE7) -> ENU (x, y) m, inverse of :func:`enu_to_degE7`."""
    e, n, _ = origin.geodetic_to_enu_fast(lat_e7 * 1e-7, lon_e7 * 1e-7, origin.alt)
    return (e, n)


def item_xy(origin: GeoOrigin, x: float, y: float, *, degrees: bool = False) -> tuple[float, float]:
    """World ENU (x, y) m -> an item's (x, y): MAVLink's (lat, lon) degE7 ints (:func:`enu_to_degE7`), or with
    ``degrees`` a plan file's float (lat, lon) degrees through the world's georeference exactly
    (:meth:`GeoOrigin.enu_to_geodetic`: the tangent plane, or a CRS world's grid)."""
    if not degrees:
        return enu_to_degE7(origin, x, y)
    lat, lon, _ = origin.enu_to_geodetic(x, y, 0.0)
    return lat, lon


def item_enu(origin: GeoOrigin, ix: float, iy: float, *, degrees: bool = False) -> tuple[float, float]:
    """An item's (x, y) -> world ENU (x, y) m, the inverse of :func:`item_xy`."""
    if not degrees:
        return degE7_to_enu(origin, ix, iy)
    e, n, _ = origin.geodetic_to_enu(ix, iy, origin.alt)
    return e, n


# ---------------------------------------------------------------- what an endpoint accepts
#: commands :func:`vinecli.phase_items.items_to_phases` understands (others are answered MAV_MISSION_UNSUPPORTED)
SUPPORTED_MISSION_COMMANDS = frozenset({
    M.CMD_NAV_WAYPOINT, M.CMD_NAV_LOITER_TIME, M.CMD_NAV_RETURN_TO_LAUNCH, M.CMD_NAV_LAND, M.CMD_NAV_TAKEOFF,
    M.CMD_NAV_DELAY, M.CMD_CONDITION_DELAY, M.CMD_DO_CHANGE_SPEED, M.CMD_DO_SET_ACTUATOR, M.CMD_DO_SET_SERVO, M.CMD_DO_SPRAYER,
})
GLOBAL_FRAMES = frozenset({0, 3, 5, 6})


def check_item(it: MissionItem) -> int:
    """MAV_MISSION_RESULT for one uploaded item (0 accepted, 3 unsupported command, 2 bad frame)."""
    if it.command not in SUPPORTED_MISSION_COMMANDS:
        return M.MAV_MISSION_UNSUPPORTED
    nav_pos = it.command in (M.CMD_NAV_WAYPOINT, M.CMD_NAV_LOITER_TIME, M.CMD_NAV_TAKEOFF)
    if nav_pos and it.frame not in GLOBAL_FRAMES:
        return M.MAV_MISSION_UNSUPPORTED_FRAME
    return M.MAV_MISSION_ACCEPTED


