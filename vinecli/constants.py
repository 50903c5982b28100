"""Physical constants shared by every floor (SI)."""

#: standard gravity, m/s² (ISO 80000-3; worlds may set their own ``gravity_mps2``)
STANDARD_GRAVITY = 9.80665
