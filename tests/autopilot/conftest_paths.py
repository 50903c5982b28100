"""Paths shared by the autopilot tests."""

from __future__ import annotations

from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
VEHICLES = REPO / "vehicles"
