"""Derived metrics for the thesis' chapter 5 experiments, computed from a run's time series.

Each metric is ``fn(data: RunData, window: (t0, t1) | None) -> float`` and is used in checks
as ``quantity: metric:<name>`` (the check's window is passed in; ``None`` = the metric's
default window, documented per metric). A metric that cannot be computed (no lift-off, no
samples in the window) returns NaN, which fails the check with a message.

Sign conventions: world ENU, z up. The tank force on the frame is ``m (g_vec - a)`` with
``g_vec = (0, 0, -g)``, so at rest ``tank_force_enu_z_n = -m g`` (downwards).

The registry and shared helpers are in :mod:`~vinecli.missions.metrics.base`; the metrics by family:
:mod:`~vinecli.missions.metrics.takeoff` (§5.1), :mod:`~vinecli.missions.metrics.spraying` (§5.2),
:mod:`~vinecli.missions.metrics.wind` (§5.3), :mod:`~vinecli.missions.metrics.job` (refill jobs and the
deposition model's). Importing this package registers all of them in :data:`METRICS`. The family modules are
named after what they measure, so ``wind.py`` or ``job.py`` repeat other packages' names on purpose. May import
what :mod:`vinecli.missions` may, and the rest of it.
"""

from vinecli.missions.metrics import job, spraying, takeoff, wind  # noqa: F401 - each family registers its metrics
from vinecli.missions.metrics.base import METRICS, Metric, Window, airborne_mask, metric
from vinecli.missions.metrics.wind import dominant_period, horizontal_aero_force_enu, predicted_tilt_rad

__all__ = ["METRICS", "Metric", "Window", "airborne_mask", "dominant_period", "horizontal_aero_force_enu", "metric",
           "predicted_tilt_rad"]
