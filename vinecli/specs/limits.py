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

# sizes of inputs (an attack pass found that a 10^6-vertex fence built a 72 MB world.json and flew at 0.2x real
# time, a 10^6-item .plan needed 2.1 GB): far above any real field, refused at read with the limit and the real figure (exit 2)
#: most vertices of one fence or zone polygon (a boundary walked with a GNSS at 1 point/s for 2 h: 7,200)
MAX_FENCE_VERTICES = 10_000
#: most vertices of all rows together (2,000 rows of 50 vertices)
MAX_ROW_VERTICES = 100_000
#: most pixels of a DSM (a 63,000 px square: 40 ha at 1 cm, 25 km² at 8 cm); every pixel is read at least once,
#: and a compressed GeoTIFF of 300,000 x 300,000 empty pixels is 11 MB
MAX_DSM_PX = 4_000_000_000
#: most mission items in a .plan (a survey of 400 rows of 10 items each: 4,000)
MAX_PLAN_ITEMS = 10_000
#: largest .plan file, bytes (a 10,000-item plan as QGroundControl writes it is about 8 MB)
MAX_PLAN_BYTES = 16 << 20
#: largest GIS file (rows, fence, zones), bytes
MAX_GIS_BYTES = 64 << 20
#: most features in one GIS layer
MAX_GIS_FEATURES = 10_000
#: longest continuous stretch of a flight log's clock, s (a multicopter's flight lasts minutes; PX4 and ArduPilot log
#: while armed)
MAX_LOG_SPAN_S = 6 * 3600.0
#: largest flight logs read, bytes: what keeps ``vehicle fit`` within 1.5 GB (measured: a ULog's topics take about 3x
#: their file size in memory, a DataFlash log's messages about 8x; an hour of a multicopter's log is tens of MB)
MAX_ULOG_BYTES = 256 << 20
MAX_DATAFLASH_BYTES = 128 << 20



def over_limit(what: str, count: int, limit: int, hint: str = "") -> str | None:
    """The refusal of ``count`` ``what`` above ``limit`` ("1,000,000 fence vertices: at most 10,000 (hint)"), or
    None when within it."""
    if count <= limit:
        return None
    return f"{count:,} {what}: at most {limit:,}" + (f" ({hint})" if hint else "")


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
