"""What a fit computed: the one object the outputs, figures and pages read."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vinecli.flightlog.flight_log import FlightLog
from vinecli.identify.base_vehicle import BaseVehicle
from vinecli.identify.battery_fit import BatteryFit
from vinecli.identify.drag import DragFit
from vinecli.identify.fitted_vehicle import FittedVehicle
from vinecli.identify.power import PowerFit
from vinecli.identify.replay import ReplayResult
from vinecli.identify.samples import FlightSamples
from vinecli.identify.thrust import ThrustFit

__all__ = ["FitResult"]


@dataclass(frozen=True)
class FitResult:
    """Everything a fit computed (module docstring); ``vehicle_yaml`` is what ``vehicle.yaml`` holds."""

    log: FlightLog
    samples: FlightSamples
    base: BaseVehicle
    thrust: ThrustFit
    drag: DragFit
    battery: BatteryFit | None
    power: PowerFit | None
    vehicle: FittedVehicle
    vehicle_yaml: dict[str, Any]
    replay: ReplayResult | None
    report: dict[str, Any]
