"""The sprayer of a vehicle (``sprayer:`` in ``vehicles/*.yaml``): nozzles, droplets, pump, nozzle law,
the speed-scaled flow control and the ground operations of a spray job. SI units except where a
field name says otherwise (bar, L/min).

* Nozzle law. ``kind: hydraulic`` nozzles follow the orifice law q ∝ √p (flow per nozzle from its
  pressure drop) and give finer drops at higher pressure, ``D ∝ p^-n`` with n ≈ 0.3 (Perry's Chemical
  Engineers' Handbook, 8th ed., eq. 14-196: an average of reported values, weighted to Lefebvre,
  *Atomization and Sprays*, 1989); ``rated_flow_lps`` at ``rated_pressure_bar`` anchors both and
  ``droplets`` is the spectrum at that point. ``kind: rotary`` atomisers (spinning discs or cages)
  set the drop size by their speed, not by the flow: ``droplets`` holds at every flow.
* Pump and valve: the delivered flow follows the command through a first-order lag (``pump``); its
  maximum is the tank's ``nozzle_max_flow_lps`` (and the nozzles' ``pressure_range_bar`` bounds it).
* Flow control as flown (``control``): ArduPilot's AC_Sprayer scales the pump with the ground speed
  (flow = rate x track width x speed) and switches it on only above ``speed_min_mps`` after
  ``on_delay_s``, off after ``off_delay_s`` below it (SPRAY_SPEED_MIN 100 cm/s, 100 ms / 1000 ms
  hysteresis in AC_Sprayer.cpp); sections open and close ahead of the row ends by the pump's lag.
* Ground operations (``operations``): refill and battery-swap times, the battery reserve a sortie
  lands with (:class:`OperationsSpec`).
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, model_validator

from vinecli.specs import StrictModel

Vec3L = tuple[float, float, float]

#: bar -> Pa
BAR_PA = 1e5


class NozzleSpec(StrictModel):
    """One spray nozzle: where it sits, its share of the flow, its spray pattern and angle (axis along -z FLU).

    ``pattern`` (docs/deposition.md item 5, :mod:`vinecli.spray.nozzle_pattern`): a *full cone* fills its cone
    with drops, a *hollow cone* (swirl-chamber cone nozzles: TeeJet ConeJet, Albuz ATR/HCI/HCA) puts them on the
    cone's shell, a *flat fan* (TeeJet XR/TT/AI, Albuz AFC) on a thin sheet of ``cone_angle_deg`` across and a few
    degrees along, its long axis ``fan_axis_deg`` from the body's forward axis towards its left (90: across the
    vehicle, as fans sit on a boom). Default full cone: older vehicle files keep their footprint.
    """

    position_m: Vec3L = Field((0.0, 0.0, -0.10), description="nozzle orifice, m, body FLU")
    flow_share: float = Field(1.0, gt=0, description="share of the tank flow (normalised over the nozzles)")
    cone_angle_deg: float = Field(80.0, gt=0, lt=170, description="spray angle, deg: the cone's full angle, or the "
                                                                 "fan's across its sheet")
    pattern: Literal["full_cone", "hollow_cone", "flat_fan"] = Field(
        "full_cone", description="full cone (drops fill the cone), hollow cone (on its shell) or flat fan (a sheet)")
    fan_axis_deg: float = Field(90.0, ge=-180, le=180, description="flat fan: its sheet's long axis, deg from the "
                                                                   "body's forward axis towards its left (90: across)")


class DropletSpectrumSpec(StrictModel):
    """Droplet sizes as a log-normal volume distribution split into equal-volume classes."""

    vmd_um: float = Field(200.0, gt=1, le=2000, description="volume median diameter Dv0.5, µm")
    gsd: float = Field(1.5, ge=1.0, le=4.0, description="geometric standard deviation of the volume distribution")
    classes: int = Field(5, ge=1, le=20, description="number of equal-volume size classes")


class PumpSpec(StrictModel):
    """Pump and valve: the delivered flow follows the commanded flow (L/s, or a duty x the maximum flow)
    with a first-order lag; its maximum is the tank's ``nozzle_max_flow_lps``."""

    tau_up_s: float = Field(0.3, ge=0, le=10, description="time constant of a rising flow (pump spin-up, line pressure), s")
    tau_down_s: float = Field(0.15, ge=0, le=10, description="time constant of a falling flow (valve closing), s")


class SprayControlSpec(StrictModel):
    """Speed-scaled flow with on/off hysteresis, as ArduPilot's AC_Sprayer (SPRAY_SPEED_MIN and its
    compile-time delays), and section switching ahead of the row ends by the pump's lag."""

    speed_min_mps: float = Field(1.0, ge=0, le=20, description="SPRAY_SPEED_MIN: sprayer on only above this ground speed, m/s")
    on_delay_s: float = Field(0.1, ge=0, le=10, description="speed above the minimum this long before the pump starts, s")
    off_delay_s: float = Field(1.0, ge=0, le=10, description="speed below the minimum this long before the pump stops, s")
    section_lead: bool = Field(True, description="open and close the sections ahead of the row ends by ground speed "
                                                 "x the pump's time constants (the deposit then starts and ends at them)")


class OperationsSpec(StrictModel):
    """Ground operations of a refill job (defaults as reported by operators and extension services).

    Ground time of a stop = ``handling_s`` + the refill (litres / ``refill_lpm``) and the battery swap,
    side by side when ``parallel`` (E. Ozkan, Ohio State University, in Ohio's Country Journal: a battery
    lasts 5-15 min with a full tank; "three charged batteries per drone ... allows replacement of a
    discharged battery while refilling the spray tank") or one after the other. A 20 L drone is "back
    in the air, all loaded up again in just over a minute" with a rapid refill pump (Drone Commander,
    operator FAQ, dronecommander.com.au); a test of four spray-drone models in China found ground
    service taking ~50 % of the working time and net spraying ~30 %.
    """

    handling_s: float = Field(30.0, ge=0, le=3600, description="landing to take-off handling: caps, checks, arming, s")
    refill_lpm: float = Field(20.0, gt=0, le=1000, description="refill pump flow, L/min")
    battery_swap_s: float = Field(60.0, ge=0, le=3600, description="time to swap the battery, s")
    parallel: bool = Field(True, description="refill and battery swap done at the same time")
    reserve_soc: float | None = Field(None, ge=0, lt=1, description="state of charge a sortie must land with; "
                                                                    "default: the battery's low_soc (PX4 BAT_LOW_THR)")

    def ground_time_s(self, litres: float, swap: bool) -> float:
        """Ground time of one stop, s: handling + refill of ``litres`` and (if ``swap``) the battery swap."""
        refill = max(litres, 0.0) / self.refill_lpm * 60.0
        swap_s = self.battery_swap_s if swap else 0.0
        return self.handling_s + (max(refill, swap_s) if self.parallel else refill + swap_s)


class SprayerSpec(StrictModel):
    """Nozzles, droplet spectrum, nozzle law, pump, flow control and ground operations of the sprayer."""

    nozzles: list[NozzleSpec] = Field(default_factory=lambda: [NozzleSpec()], min_length=1)
    droplets: DropletSpectrumSpec = DropletSpectrumSpec()
    kind: Literal["hydraulic", "rotary"] = Field("hydraulic", description="hydraulic nozzles (q ∝ √p, drops finer at "
                                                  "higher pressure) or rotary atomisers (drop size set by their speed)")
    rated_flow_lps: float | None = Field(None, gt=0, description="total flow of all nozzles at rated_pressure_bar, L/s "
                                         "(hydraulic; the spectrum ``droplets`` is at this point); none = no pressure law")
    rated_pressure_bar: float = Field(3.0, gt=0, le=100, description="pressure of the rated flow and spectrum, bar")
    pressure_range_bar: tuple[float, float] | None = Field(None, description="nozzles' working pressure range [min, max], bar")
    droplet_pressure_exponent: float = Field(0.3, ge=0, le=1, description="n in D ∝ p^-n (Perry's eq. 14-196)")
    pump: PumpSpec = PumpSpec()
    control: SprayControlSpec = SprayControlSpec()
    operations: OperationsSpec = OperationsSpec()

    @model_validator(mode="after")
    def _range(self) -> SprayerSpec:
        r = self.pressure_range_bar
        if r is not None and not 0 < r[0] < r[1]:
            raise ValueError("pressure_range_bar needs 0 < min < max")
        if r is not None and self.rated_flow_lps is None:
            raise ValueError("pressure_range_bar needs rated_flow_lps (the flow the pressures refer to)")
        return self

    @property
    def pressure_law(self) -> bool:
        """True when flow and drop size follow the nozzle pressure (hydraulic nozzles with a rated point)."""
        return self.kind == "hydraulic" and self.rated_flow_lps is not None

    def pressure_bar(self, flow_lps: float) -> float:
        """Nozzle pressure at a total flow (q ∝ √p), bar; NaN without a pressure law."""
        if not self.pressure_law:
            return math.nan
        return self.rated_pressure_bar * (flow_lps / float(self.rated_flow_lps)) ** 2  # type: ignore[arg-type]

    def flow_at_pressure_lps(self, pressure_bar: float) -> float:
        """Total flow at a nozzle pressure, L/s (needs a pressure law)."""
        return float(self.rated_flow_lps or 0.0) * math.sqrt(pressure_bar / self.rated_pressure_bar)

    def vmd_um(self, flow_lps: float) -> float:
        """Volume median diameter at a total flow, µm: the rated spectrum scaled by (p / p_rated)^-n
        (hydraulic with a pressure law), else the spectrum's."""
        if not self.pressure_law or flow_lps <= 0.0:
            return self.droplets.vmd_um
        return self.droplets.vmd_um * (self.pressure_bar(flow_lps) / self.rated_pressure_bar) ** (
            -self.droplet_pressure_exponent)

    def flow_range_lps(self, pump_max_lps: float) -> tuple[float, float]:
        """(min, max) total flow the sprayer delivers as designed, L/s: the pump's maximum, narrowed by the
        nozzles' pressure range when they have one."""
        lo, hi = 0.0, float(pump_max_lps)
        if self.pressure_range_bar is not None:
            lo = self.flow_at_pressure_lps(self.pressure_range_bar[0])
            hi = min(hi, self.flow_at_pressure_lps(self.pressure_range_bar[1]))
        return lo, hi

    def swath_m(self, height_m: float) -> float:
        """Geometric swath at ``height_m`` below the nozzles, m: lateral nozzle span + 2 h tan(θ/2) (widest cone)."""
        ys = [n.position_m[1] for n in self.nozzles]
        half = max(math.tan(math.radians(n.cone_angle_deg) / 2.0) for n in self.nozzles)
        return (max(ys) - min(ys)) + 2.0 * max(height_m, 0.0) * half
