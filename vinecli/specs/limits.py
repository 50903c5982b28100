"""Upper bounds for numbers in specs, so absurd values are a load error (exit 2), not an overflow later.

Every spec model already refuses NaN and ±inf (:class:`vinecli.specs.StrictModel`); these bounds
catch finite but meaningless magnitudes (``max_duration_s: 1e12`` would size arrays of petabytes,
a 1e12 m/s wind overflows the physics). They are generous: a day of flight, 100 km, 100 m/s.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from vinecli.constants import MAX_SEED

#: longest duration, timeout or period, s (one day)
MAX_DURATION_S = 86_400.0
#: highest sample or loop rate, Hz
MAX_RATE_HZ = 10_000.0
#: largest speed (flight or wind), m/s
MAX_SPEED_MPS = 100.0
#: largest distance or coordinate, m
MAX_DISTANCE_M = 100_000.0
#: highest a vehicle may be sent above the ground (takeoff, goto, waypoint, spray, return heights, the
#: geofence ceiling), m: altitudes of tens of kilometres are refused at load, not failed in the physics
MAX_HEIGHT_M = 10_000.0
#: geodetic origins lie between the Dead Sea shore and the highest summits, m above mean sea level
MIN_ORIGIN_ALT_M, MAX_ORIGIN_ALT_M = -500.0, 9_000.0
#: largest image side, px
MAX_IMAGE_PX = 4096

#: a seed (run, root or replicate seed, wind seed offset)
SeedInt = Annotated[int, Field(ge=0, le=MAX_SEED)]
#: a coordinate or signed distance, m
Coord = Annotated[float, Field(ge=-MAX_DISTANCE_M, le=MAX_DISTANCE_M)]
#: a height above the ground, m (may be negative: below home)
Height = Annotated[float, Field(ge=-MAX_HEIGHT_M, le=MAX_HEIGHT_M)]
#: a signed speed component (wind, velocity), m/s
Speed = Annotated[float, Field(ge=-MAX_SPEED_MPS, le=MAX_SPEED_MPS)]
Vec2Coord = tuple[Coord, Coord]
Vec3Coord = tuple[Coord, Coord, Coord]
#: x east, y north (m ENU), height above the ground (m)
WaypointEnu = tuple[Coord, Coord, Height]
Vec3Speed = tuple[Speed, Speed, Speed]
