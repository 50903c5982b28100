"""Simulation: PyBullet engine adapter, the one simulation loop, and its data types."""
