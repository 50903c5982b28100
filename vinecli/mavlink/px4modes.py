"""PX4 flight modes and the MAVLink numbers vinecli uses (docs/firmware-protocols.md §3, §4).

PX4 custom_mode = (main_mode << 16) | (sub_mode << 24). Main: 1 MANUAL, 2 ALTCTL, 3 POSCTL,
4 AUTO, 5 ACRO, 6 OFFBOARD, 7 STABILIZED; AUTO sub: 1 READY, 2 TAKEOFF, 3 LOITER (Hold),
4 MISSION, 5 RTL, 6 LAND, 8 FOLLOW_TARGET.
"""

from __future__ import annotations

MAIN_MANUAL, MAIN_ALTCTL, MAIN_POSCTL, MAIN_AUTO, MAIN_ACRO, MAIN_OFFBOARD, MAIN_STABILIZED = 1, 2, 3, 4, 5, 6, 7
SUB_READY, SUB_TAKEOFF, SUB_LOITER, SUB_MISSION, SUB_RTL, SUB_LAND = 1, 2, 3, 4, 5, 6

#: vinecli mode name -> (main, sub)
MODES: dict[str, tuple[int, int]] = {
    "manual": (MAIN_MANUAL, 0),
    "altctl": (MAIN_ALTCTL, 0),
    "position": (MAIN_POSCTL, 0),
    "ready": (MAIN_AUTO, SUB_READY),
    "takeoff": (MAIN_AUTO, SUB_TAKEOFF),
    "hold": (MAIN_AUTO, SUB_LOITER),
    "mission": (MAIN_AUTO, SUB_MISSION),
    "rtl": (MAIN_AUTO, SUB_RTL),
    "land": (MAIN_AUTO, SUB_LAND),
    "offboard": (MAIN_OFFBOARD, 0),
    "stabilized": (MAIN_STABILIZED, 0),
}

# MAVLink constants (common.xml)
MAV_TYPE_QUADROTOR = 2
MAV_TYPE_GCS = 6
MAV_AUTOPILOT_GENERIC = 0
MAV_AUTOPILOT_PX4 = 12
MAV_AUTOPILOT_INVALID = 8
MODE_FLAG_CUSTOM = 1
MODE_FLAG_SAFETY_ARMED = 128
MAV_STATE_STANDBY, MAV_STATE_ACTIVE = 3, 4
HIL_ACTUATOR_CONTROLS_FLAGS_LOCKSTEP = 1
#: HIL_SENSOR fields_updated: accel 7 | gyro 56 | mag 448 | baro (512|2048|4096)
FIELDS_ACCEL, FIELDS_GYRO, FIELDS_MAG, FIELDS_BARO, FIELDS_ALL = 7, 56, 448, 6656, 7167
SENSOR_PREARM_CHECK = 0x10000000
SENSORS_BASIC = 1 | 2 | 4 | 8 | 32  # gyro, accel, mag, abs pressure, GPS

MAV_RESULT_ACCEPTED, MAV_RESULT_TEMP_REJECTED, MAV_RESULT_DENIED, MAV_RESULT_UNSUPPORTED, MAV_RESULT_FAILED = 0, 1, 2, 3, 4
MAV_RESULT_NAMES = {0: "ACCEPTED", 1: "TEMPORARILY_REJECTED", 2: "DENIED", 3: "UNSUPPORTED", 4: "FAILED", 5: "IN_PROGRESS", 6: "CANCELLED"}
MAV_MISSION_ACCEPTED, MAV_MISSION_ERROR, MAV_MISSION_UNSUPPORTED_FRAME, MAV_MISSION_UNSUPPORTED = 0, 1, 2, 3
MAV_MISSION_INVALID_SEQUENCE = 13
MAV_MISSION_TYPE_MISSION, MAV_MISSION_TYPE_FENCE, MAV_MISSION_TYPE_RALLY = 0, 1, 2
MISSION_STATE_NOT_STARTED, MISSION_STATE_ACTIVE, MISSION_STATE_PAUSED, MISSION_STATE_COMPLETE = 2, 3, 4, 5
LANDED_UNDEFINED, LANDED_ON_GROUND, LANDED_IN_AIR, LANDED_TAKEOFF, LANDED_LANDING = 0, 1, 2, 3, 4

MAV_FRAME_GLOBAL, MAV_FRAME_MISSION, MAV_FRAME_GLOBAL_RELATIVE_ALT = 0, 2, 3
MAV_FRAME_GLOBAL_INT, MAV_FRAME_GLOBAL_RELATIVE_ALT_INT = 5, 6

CMD_NAV_WAYPOINT = 16
CMD_NAV_LOITER_TIME = 19
CMD_NAV_RETURN_TO_LAUNCH = 20
CMD_NAV_LAND = 21
CMD_NAV_TAKEOFF = 22
CMD_NAV_DELAY = 93
CMD_CONDITION_DELAY = 112
CMD_DO_SET_MODE = 176
CMD_DO_CHANGE_SPEED = 178
CMD_DO_SET_HOME = 179
CMD_DO_SET_SERVO = 183
CMD_DO_SET_ACTUATOR = 187
CMD_DO_REPOSITION = 192
CMD_DO_SPRAYER = 216
CMD_DO_SET_MISSION_CURRENT = 224
CMD_MISSION_START = 300
CMD_COMPONENT_ARM_DISARM = 400
CMD_SET_MESSAGE_INTERVAL = 511
CMD_REQUEST_MESSAGE = 512
CMD_REQUEST_PROTOCOL_VERSION = 519
CMD_REQUEST_AUTOPILOT_CAPABILITIES = 520
CMD_NAV_FENCE_RETURN_POINT = 5000
CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION = 5001
CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION = 5002
CMD_NAV_FENCE_CIRCLE_INCLUSION = 5003
CMD_NAV_FENCE_CIRCLE_EXCLUSION = 5004
CMD_NAV_RALLY_POINT = 5100
ARM_FORCE_MAGIC = 21196

#: GF_ACTION values (PX4 geofence_params.c)
GF_ACTION = {"none": 0, "warn": 1, "hold": 2, "rtl": 3, "terminate": 4, "land": 5}


def custom_mode(main: int, sub: int = 0) -> int:
    """PX4 custom_mode word from main and sub mode."""
    return (main << 16) | (sub << 24)


def decode_custom_mode(cm: int) -> tuple[int, int]:
    """(main, sub) from a PX4 custom_mode word."""
    return (cm >> 16) & 0xFF, (cm >> 24) & 0xFF


def mode_name(main: int, sub: int) -> str:
    """vinecli name of a PX4 (main, sub) mode, 'unknown(main/sub)' otherwise."""
    for name, ms in MODES.items():
        if ms == (main, sub):
            return name
    if main == MAIN_AUTO and sub == 0:
        return "mission"
    return f"unknown({main}/{sub})"


def mode_word(name: str) -> int:
    """custom_mode word of a vinecli mode name."""
    main, sub = MODES[name]
    return custom_mode(main, sub)
