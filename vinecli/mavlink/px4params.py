"""The PX4 parameters a mission sets (beside its items, :func:`vinecli.phase_items.phases_to_items`).

* take-off: ``MIS_TAKEOFF_ALT``; ``NAV_MC_ALT_RAD`` = the phase's altitude tolerance (PX4 accepts an item's
  altitude within it, default 0.8 m); with a climb speed, ``MPC_TKO_SPEED`` = ``MPC_Z_V_AUTO_UP`` = it and
  ``MPC_TKO_RAMP_T`` = 1 s (PX4's 3 s ramp leaves no steady climb in 8 m);
* land: ``MPC_LAND_SPEED``; RTL: ``RTL_RETURN_ALT``;
* geofence: ``GF_ACTION``, ``GF_MAX_HOR_DIST``, ``GF_MAX_VER_DIST`` (its polygon is fence items).
"""

from __future__ import annotations

import math

from vinecli.mavlink import px4modes as M
from vinecli.specs.mission import GeofenceSpec, LandPhase, MissionSpec, RtlPhase, TakeoffPhase

__all__ = ["fence_params", "mission_params"]


def mission_params(mission: MissionSpec) -> dict[str, float | int]:
    """PX4 parameters of ``mission``'s phases and geofence (module doc); name -> value (int = INT32)."""
    params: dict[str, float | int] = {}
    for ph in mission.phases:
        if isinstance(ph, TakeoffPhase):
            params["MIS_TAKEOFF_ALT"] = float(ph.altitude_agl_m)
            params["NAV_MC_ALT_RAD"] = min(float(params.get("NAV_MC_ALT_RAD", math.inf)), float(ph.tolerance_m))
            if ph.climb_speed_mps is not None:
                params["MPC_TKO_SPEED"] = params["MPC_Z_V_AUTO_UP"] = float(ph.climb_speed_mps)
                params["MPC_TKO_RAMP_T"] = 1.0
        elif isinstance(ph, LandPhase):
            params["MPC_LAND_SPEED"] = float(ph.descent_speed_mps)
        elif isinstance(ph, RtlPhase):
            params["RTL_RETURN_ALT"] = float(ph.return_altitude_agl_m)
    params.update(fence_params(mission.geofence))
    return params


def fence_params(fence: GeofenceSpec | None) -> dict[str, float | int]:
    """PX4's GF_* parameters of a geofence (none without one)."""
    if fence is None:
        return {}
    params: dict[str, float | int] = {"GF_ACTION": M.GF_ACTION[fence.action]}
    if fence.max_horizontal_distance_m is not None:
        params["GF_MAX_HOR_DIST"] = float(fence.max_horizontal_distance_m)
    if fence.max_altitude_agl_m is not None:
        params["GF_MAX_VER_DIST"] = float(fence.max_altitude_agl_m)
    return params
