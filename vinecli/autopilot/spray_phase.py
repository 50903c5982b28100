"""The spray phase of the built-in autopilot: fly the planned passes over the vine rows with the
sprayer on over the rows only, and - for refill jobs (``refill`` in the phase) - end a sortie at
the tank reserve or a low battery, return, land, get serviced (:class:`Service`), take off and
resume from the breakpoint.

Positions are world ENU m; the spray height is above the terrain under the vehicle (the skids'),
the return altitude above home; speeds m/s, flows L/s, times s. Events: ``spray_plan``,
``sortie`` {sortie, event: start|end, reason, breakpoint_enu | last}, ``service``.
"""

from __future__ import annotations

import math

from vinecli.autopilot.base import AutopilotContext
from vinecli.autopilot.flight_phases import Rtl, Takeoff
from vinecli.autopilot.phase import Phase, PhaseHost
from vinecli.control.path import PathFollower
from vinecli.errors import InputError
from vinecli.frames import Vec3
from vinecli.specs.mission import RefillSpec, SprayPhase, TakeoffPhase
from vinecli.types import ServiceRequest


def spray_rows(p: SprayPhase, ctx: AutopilotContext) -> list[list[tuple[float, float]]]:
    """The rows a spray phase covers, polylines (x, y) ENU m: the world's (``rows: world``), some of
    them by index, or the phase's own; rows of fewer than two points are dropped. InputError if none."""
    world_rows = [[(float(x), float(y)) for x, y in r] for r in ctx.vine_rows_enu]
    if p.rows == "world":
        rows = world_rows
    elif p.rows and all(isinstance(r, int) for r in p.rows):
        bad = [i for i in p.rows if not 0 <= int(i) < len(world_rows)]  # type: ignore[arg-type]
        if bad:
            raise InputError(f"spray phase: row index {bad[0]} out of range (the world has {len(world_rows)} rows)")
        rows = [world_rows[int(i)] for i in p.rows]  # type: ignore[arg-type]
    else:
        rows = [[(float(x), float(y)) for x, y in r] for r in p.rows]  # type: ignore[union-attr, misc]
    rows = [r for r in rows if len(r) >= 2]
    if not rows:
        raise InputError("spray phase: no vine rows to spray (the world has none and the phase gives none)")
    return rows


class Service(Phase):
    """On the ground, disarmed: the crew refills the tank (and swaps the battery) in ``time_s``."""

    MODE = "AUTO.LOITER"
    type = "service"

    def __init__(self, spec: RefillSpec, fill_l: float) -> None:
        self.spec = spec
        self.fill_l = fill_l

    def start(self, ap: PhaseHost) -> None:
        self.t = 0.0
        self.requested = False

    def update(self, ap: PhaseHost, dt: float) -> bool:
        self.t += dt
        if self.t < self.spec.time_s:
            return False
        if not self.requested:
            ap.request_service(ServiceRequest(self.fill_l, self.spec.swap_battery))
            self.requested = True
            return False
        return ap.tank_level_l >= self.fill_l - 1e-6


class Spray(Phase):
    """Spray the rows (see the module docstring); ``until: empty`` flies them again until the tank is empty."""

    type = "spray"

    def __init__(self, spec: SprayPhase, rows: list[list[tuple[float, float]]]) -> None:
        self.spec = spec
        self.rows = rows
        self.timeout_s = spec.timeout_s
        self.sortie = 1
        self.sub: Phase | None = None  # return / service / take-off between sorties
        self.announced = False
        self._queue: list[Phase] = []
        self._resume: tuple[list[Vec3], list[float]] | None = None
        self._left_at_last_end = math.inf  # path length left when the last sortie ended, m

    @property
    def mode(self) -> str:
        """The sortie step's mode while one runs, else AUTO.MISSION."""
        return self.sub.mode if self.sub is not None else "AUTO.MISSION"

    def _passes(self, ap: PhaseHost, start_xy: tuple[float, float]) -> tuple[list[Vec3], list[float]]:
        """The operator plan from ``start_xy`` (:func:`~vinecli.rows.plan.plan_rows`: nearest row
        first, boustrophedon, headland turns from the speed and acceleration, rows clipped to the geofence
        with a 1 m margin); flow on over the rows only. ``until: empty`` replans from the last row's end,
        so the rows are flown back."""
        from vinecli.rows.plan import plan_rows

        fence = ap.geofence.spec.polygon_enu if ap.geofence is not None and ap.geofence.spec.polygon_enu else None
        plan = plan_rows(self.rows, start_xy, speed_mps=self.spec.speed_mps, accel_mps2=self.accel(ap),
                         fence_enu=fence)
        if not plan.legs:
            raise InputError("spray phase: no rows left inside the geofence")
        if not self.announced:
            ap.emit("spray_plan", plan.summary(), {"rows": plan.order, "length_m": round(plan.length_m, 2),
                                                   "time_s": plan.time_s, "warnings": plan.warnings})
            self.announced = True
        flow = self.spec.flow_lps
        if flow is None:  # the runner resolves rate_lpha against the vehicle's nozzles (missions/spray_rate.py)
            raise InputError("spray phase: rate_lpha was not resolved to a flow")
        pts2, flows = plan.path(flow)
        h = self.spec.height_agl_m
        return [(x, y, h) for x, y in pts2], flows

    @staticmethod
    def accel(ap: PhaseHost) -> float:
        """Acceleration of the spray path (m/s², the one the plans assume)."""
        from vinecli.rows.plan import plan_accel

        return plan_accel(ap.vehicle)

    def start(self, ap: PhaseHost) -> None:
        self.announced = False
        self._new_path(ap)

    # ---- sorties (refill jobs)
    @staticmethod
    def _sortie_over(ap: PhaseHost, refill: RefillSpec) -> str:
        """Why this sortie must end now ('' = it goes on): tank at the reserve, battery low."""
        if ap.vehicle.tank is not None and ap.tank_level_l <= max(refill.reserve_l, 1e-6):
            return "tank empty" if refill.reserve_l <= 0.0 else f"tank at the {refill.reserve_l:g} L reserve"
        bat = ap.vehicle.battery
        if refill.swap_battery and bat is not None and ap.battery_soc <= bat.low_soc:
            return f"battery at {ap.battery_soc * 100:.0f} % (low {bat.low_soc * 100:.0f} %)"
        return ""

    def _last_sortie(self, ap: PhaseHost, why: str, reason: str) -> bool:
        """End the job in this sortie (event ``sortie`` with ``last``), sprayer off; True (phase done)."""
        ap.emit("sortie", f"sortie {self.sortie} ends {why}",
                {"sortie": self.sortie, "event": "end", "reason": reason, "last": True})
        ap.set_flow(0.0)
        return True

    def _end_sortie(self, ap: PhaseHost, refill: RefillSpec, reason: str) -> None:
        """Record the breakpoint, then return, land, get serviced and take off again."""
        ap.set_flow(0.0)
        bp = self.path.sp
        self._resume = self.path.remaining(refill.overlap_m)
        ap.emit("sortie", f"sortie {self.sortie} ends ({reason}) at breakpoint ({bp[0]:.1f}, {bp[1]:.1f})",
                {"sortie": self.sortie, "event": "end", "reason": reason, "breakpoint_enu": [bp[0], bp[1], bp[2]]})
        tank = ap.vehicle.tank
        fill = refill.fill_l if refill.fill_l is not None else (tank.capacity_l if tank is not None else 0.0)
        up = TakeoffPhase(altitude_agl_m=self.spec.height_agl_m)
        self._queue = [Rtl(refill.return_altitude_agl_m, math.inf), Service(refill, fill), Takeoff(up, ap.vehicle)]
        self._next_step(ap)

    def _next_step(self, ap: PhaseHost) -> None:
        """The next step between sorties (return, service, take-off), or - all done - the next sortie."""
        if self._queue:
            self.sub = self._queue.pop(0)
            self.sub.start(ap)
            return
        self.sub = None
        self.sortie += 1
        ap.sortie = self.sortie
        ap.emit("sortie", f"sortie {self.sortie} starts", {"sortie": self.sortie, "event": "start"})
        self._new_path(ap, resume=self._resume)

    def _new_path(self, ap: PhaseHost, resume: tuple[list[Vec3], list[float]] | None = None) -> None:
        """Follow the planned passes from the hold point, or ``resume`` (points ENU m, flows L/s) after a refill."""
        if resume is None:
            pts, flows = self._passes(ap, (ap.hold_sp()[0], ap.hold_sp()[1]))
        else:  # from where the vehicle is to the breakpoint (flow off), then the rest of the rows
            h = self.spec.height_agl_m
            pts = [(ap.hold_sp()[0], ap.hold_sp()[1], h), *resume[0]]
            flows = [0.0, *resume[1]]
        terrain, lgh = ap.terrain, ap.vehicle.frame.landing_gear_height_m

        def skids_above_terrain(x: float, y: float) -> float:
            return terrain(x, y) + lgh  # the height is the skids' (as the recorded height_agl_m)

        self.path = PathFollower(pts, self.spec.speed_mps, accel=self.accel(ap), flows=flows, terrain=skids_above_terrain,
                                 acceptance_m=0.7,
                                 max_lead_m=2.0, max_vz=min(ap.vehicle.control.max_vel_up, ap.vehicle.control.max_vel_down))

    def update(self, ap: PhaseHost, dt: float) -> bool:
        if self.sub is not None:
            if self.sub.update(ap, dt):
                self._next_step(ap)
            return False
        refill = self.spec.refill
        if refill is not None:
            reason = self._sortie_over(ap, refill)
            if reason:
                if self.sortie >= refill.max_sorties:
                    return self._last_sortie(ap, f"({reason}): max_sorties {refill.max_sorties} reached", reason)
                left = self.path.total - self.path.s
                if left >= self._left_at_last_end - 0.5:
                    return self._last_sortie(ap, f"({reason}) before reaching new rows: job aborted",
                                             f"no progress ({reason})")
                self._left_at_last_end = left
                self._end_sortie(ap, refill, reason)
                return False
        if ap.tank_empty:
            ap.set_flow(0.0)
            ap.set_position(ap.hold_sp(), (0.0, 0.0, 0.0))
            return True
        sp, vff, done = self.path.update(dt, ap.pos)
        ap.set_position(sp, vff, aff=self.path.aff)
        # spray only when the vehicle itself is at the carrot (not while catching up)
        near = math.hypot(sp[0] - ap.pos[0], sp[1] - ap.pos[1]) < 0.7 and abs(sp[2] - ap.pos[2]) < 0.7
        ap.set_flow(self.path.flow if near else 0.0)
        if done:
            if self.spec.until == "empty":
                self._new_path(ap)
                return False
            ap.set_flow(0.0)
            return True
        return False

