"""Upper bounds for numbers in specs, so absurd values are a load error (exit 2), not an overflow later.

Every spec model already refuses NaN and ±inf (:class:`vinecli.specs.StrictModel`); these bounds
catch finite but meaningless magnitudes (``max_duration_s: 1e12`` would size arrays of petabytes,
a 1e12 m/s wind overflows the physics). They are generous: a day of flight, 100 km, 100 m/s.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

#: longest duration, timeout or period, s (one day)
MAX_DURATION_S = 86_400.0
#: highest sample or loop rate, Hz
MAX_RATE_HZ = 10_000.0
#: largest speed (flight or wind), m/s
MAX_SPEED_MPS = 100.0
#: largest distance, coordinate or altitude, m
MAX_DISTANCE_M = 100_000.0
#: largest image side, px
MAX_IMAGE_PX = 4096

#: a coordinate or signed distance, m
Coord = Annotated[float, Field(ge=-MAX_DISTANCE_M, le=MAX_DISTANCE_M)]
#: a signed speed component (wind, velocity), m/s
Speed = Annotated[float, Field(ge=-MAX_SPEED_MPS, le=MAX_SPEED_MPS)]
Vec2Coord = tuple[Coord, Coord]
Vec3Coord = tuple[Coord, Coord, Coord]
Vec3Speed = tuple[Speed, Speed, Speed]
