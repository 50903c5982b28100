"""vinecli: simulation pipeline for precision-agriculture spraying drones.

DSM / point cloud -> terrain -> world -> missions (PyBullet, built-in autopilot or PX4 SITL) -> report.
"""

__version__ = "0.1.0"
