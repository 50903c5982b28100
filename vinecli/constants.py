"""Physical constants and fixed ranges shared by every floor (SI)."""

#: standard gravity, m/s² (ISO 80000-3; worlds may set their own ``gravity_mps2``)
STANDARD_GRAVITY = 9.80665

#: the seed range: run seeds, root and replicate seeds, wind seed offsets are integers in [0, MAX_SEED]
#: (outside it seeds would fold onto each other in the generators and two runs collide)
MAX_SEED = 2**32 - 1
