"""The ArduPilot mission of a run: the phases through the shared phase -> mission-item converter
(:func:`vinecli.phase_items.phases_to_items`), in ArduCopter's terms.

* Coordinates: ArduPilot turns the JSON position (metres from ``--home``) into latitude and longitude
  with its own spherical offset (``Location::offset``: 1e-7 deg = 0.0111319 m of latitude, longitude
  scaled by the cosine of the latitude), not vinecli's WGS84 tangent plane (0.15 % apart at 46 deg N:
  15 cm over a 100 m field). Waypoints and fence vertices are placed with ArduPilot's offset from the
  same home (:class:`ArdupilotFrame`), so the firmware flies to the ENU points vinecli planned.
* Item 0 is ArduPilot's home slot (it overwrites it when it arms); the converter's items follow.
* The sprayer: the converter switches it with MAV_CMD_DO_SPRAYER (216) (:data:`vinecli.phase_items.DO_SPRAYER`),
  the pump rate goes to AC_Sprayer's parameters (:func:`~vinecli.sitl.ardupilot.params.sprayer_params`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from vinecli.autopilot.base import AutopilotContext
from vinecli.errors import SpecError
from vinecli.frames import grid_to_true_enu, true_enu_to_grid
from vinecli.mavlink import px4modes as M
from vinecli.mavlink.mission_items import MissionItem
from vinecli.phase_items import DO_SPRAYER, phases_to_items
from vinecli.sitl.ardupilot.params import SprayerSetting, mission_settings
from vinecli.sitl.ardupilot.pump_rates import PumpRateSchedule, lead_time_s
from vinecli.sitl.converter import converter_inputs, pump_max_flow_lps
from vinecli.specs.mission import MissionSpec, SprayerPhase, SprayPhase, WaypointsPhase

#: ArduPilot's LOCATION_SCALING_FACTOR_INV: 1e-7 degrees per metre of latitude (AP_Common/Location.h)
LOCATION_SCALING_FACTOR_INV = 89.83204953368922


@dataclass(frozen=True)
class ArdupilotFrame:
    """ENU metres <-> ArduPilot's latitude/longitude about the home it was started with. Has the
    ``enu_to_geodetic_fast`` and ``convergence_rad`` of :class:`~vinecli.geo.GeoOrigin`, so the shared converter
    uses it."""

    home_enu: tuple[float, float, float]
    lat_e7: int
    lng_e7: int
    alt_m: float  # home altitude AMSL
    convergence_rad: float = 0.0  # the world's grid against true north (:attr:`GeoOrigin.convergence_rad`)

    def offset_e7(self, e: float, n: float) -> tuple[int, int]:
        """ArduPilot's ``Location::offset_latlng`` of home by the world point's (n, e) metres from the home point,
        turned to true north (as the JSON positions the backend sends)."""
        de, dn, _ = grid_to_true_enu((e - self.home_enu[0], n - self.home_enu[1], 0.0), self.convergence_rad)
        dlat = int(dn * LOCATION_SCALING_FACTOR_INV)
        scale = max(0.01, min(1.0, math.cos((self.lat_e7 + dlat / 2) * 1e-7 * math.pi / 180.0)))
        dlng = int((de * LOCATION_SCALING_FACTOR_INV) / scale)
        return self.lat_e7 + dlat, self.lng_e7 + dlng

    def enu_to_geodetic_fast(self, e: float, n: float, u: float) -> tuple[float, float, float]:
        lat, lng = self.offset_e7(e, n)
        return lat * 1e-7, lng * 1e-7, self.alt_m + u - self.home_enu[2]

    def e7_to_world(self, lat_e7: int, lng_e7: int) -> tuple[float, float]:
        """The world point (ENU m) ArduPilot means by ``lat_e7``, ``lng_e7`` (the inverse of :meth:`offset_e7`)."""
        dlat, dlng = lat_e7 - self.lat_e7, lng_e7 - self.lng_e7
        scale = max(0.01, min(1.0, math.cos((self.lat_e7 + dlat / 2) * 1e-7 * math.pi / 180.0)))
        de, dn, _ = true_enu_to_grid((dlng * scale / LOCATION_SCALING_FACTOR_INV, dlat / LOCATION_SCALING_FACTOR_INV,
                                      0.0), self.convergence_rad)
        return self.home_enu[0] + de, self.home_enu[1] + dn

    def ned_velocity_to_world(self, vn: float, ve: float) -> tuple[float, float]:
        """A horizontal velocity from true north and east (m/s) in the world's axes."""
        vx, vy, _ = true_enu_to_grid((ve, vn, 0.0), self.convergence_rad)
        return vx, vy


def home_frame(ctx: AutopilotContext) -> ArdupilotFrame:
    """ArduPilot's home: the vehicle's resting point (CoM) at the spawn, in WGS84 degE7 and m AMSL."""
    hx, hy, hz = ctx.home_enu
    lat, lon, alt = ctx.origin.enu_to_geodetic(hx, hy, hz)
    return ArdupilotFrame((hx, hy, hz), round(lat * 1e7), round(lon * 1e7), round(alt, 3), ctx.origin.convergence_rad)


@dataclass
class ArdupilotPlan:
    """Everything uploaded to ArduPilot for one mission."""

    items: list[MissionItem]  # item 0: home
    fence: list[MissionItem] = field(default_factory=list)
    params: dict[str, int | float] = field(default_factory=dict)
    phase_of_item: list[int] = field(default_factory=list)
    sprayer: SprayerSetting | None = None
    #: segment rates: the SPRAY_PUMP_RATE changes the ground station sends in flight (None: one rate)
    pump_rates: PumpRateSchedule | None = None
    frame: ArdupilotFrame | None = None
    rate_paths: dict[int, tuple[object, object]] = field(default_factory=dict)  # the converter's (plan, RatePath)

    @property
    def lands(self) -> bool:
        return self.items[-1].command in (M.CMD_NAV_LAND, M.CMD_NAV_RETURN_TO_LAUNCH)


def sprayer_setting(mission: MissionSpec) -> SprayerSetting | None:
    """The pump's flow at its ground speed asked by the mission's spray phases (None: it never sprays).
    AC_Sprayer has one rate per flight: phases asking different litres per metre are refused."""
    found: list[SprayerSetting] = []
    for ph in mission.phases:
        if isinstance(ph, (SprayPhase, WaypointsPhase)) and ph.flow_lps:
            found.append(SprayerSetting(float(ph.flow_lps), float(ph.speed_mps)))
    per_m = {round(s.flow_lps / s.speed_mps, 9) for s in found}
    if len(per_m) > 1:
        raise SpecError(f"mission {mission.name!r}: ArduPilot's sprayer has one pump rate per flight (litres per "
                        "metre), the spray phases ask for several")
    if not found and any(isinstance(ph, SprayerPhase) and ph.flow_lps > 0 for ph in mission.phases):
        raise SpecError(f"mission {mission.name!r}: ArduPilot's sprayer follows ground speed; give the flow in a "
                        "spray or waypoints phase with its speed")
    return found[0] if found else None


def plan_for(ctx: AutopilotContext, frame: ArdupilotFrame) -> ArdupilotPlan:
    """The ArduPilot plan (items, fence, mission parameters) for ``ctx.mission`` (SpecError if it cannot fly it)."""
    # ArduPilot's latitude/longitude convention (module docstring); the sprayer switched by DO_SPRAYER
    mission, pc = converter_inputs(ctx, frame, firmware="ArduPilot")
    conv = phases_to_items(mission, pc, sprayer=DO_SPRAYER)
    items = [MissionItem(M.CMD_NAV_WAYPOINT, M.MAV_FRAME_GLOBAL, x=frame.lat_e7, y=frame.lng_e7, z=frame.alt_m)]
    for it in conv.items:
        if it.command == M.CMD_NAV_LOITER_TIME and math.isnan(it.param4):
            it.param4 = 0.0  # ArduPilot's "exit at the loiter centre" flag (NaN: MISSION_ACK INVALID_PARAM4)
        items.append(it)
    return ArdupilotPlan(items=items, fence=conv.fence, params=mission_settings(mission),
                         phase_of_item=[-1, *conv.phase_of_item], sprayer=sprayer_setting(mission),
                         pump_rates=_pump_rates(ctx, conv.rate_paths), frame=frame, rate_paths=conv.rate_paths)


def _pump_rates(ctx: AutopilotContext, rate_paths: dict[int, tuple[object, object]]) -> PumpRateSchedule | None:
    """The SPRAY_PUMP_RATE changes of the mission's first dosed spray phase (:mod:`.pump_rates`), None without."""
    if not rate_paths:
        return None
    _, rp = rate_paths[min(rate_paths)]
    v = ctx.vehicle
    return PumpRateSchedule.from_path(rp.points, rp.flows, rp.rates, pump_max_flow_lps(v),  # type: ignore[attr-defined]
                                      lead_time_s(v.sprayer.pump.tau_up_s))


__all__ = ["ArdupilotFrame", "ArdupilotPlan", "home_frame", "plan_for", "sprayer_setting"]
