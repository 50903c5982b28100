"""Missions: loading mission files, checks and derived metrics, QGroundControl plans, spray patterns."""
