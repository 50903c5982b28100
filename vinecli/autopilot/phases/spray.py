"""The spray phase of the built-in autopilot: fly the planned passes with section control and a
speed-scaled flow, and - for refill jobs (``refill`` in the phase) - end a sortie when the tank reaches
its reserve or the battery could no longer bring the vehicle home, return, land, get serviced
(refill; a fresh battery when the next sortie needs one), take off and resume at the breakpoint.

* The plan: :func:`vinecli.rows.spray_rate.phase_plan` (passes from the sprayer's effective swath,
  turns fitted to the fence), the same plan the run set-up took the flow from.
* Sections: open only over the passes, with the vehicle on the path (within 0.7 m), judged at the
  vehicle's own position projected on the path - not the carrot's - looking ahead by ground speed x
  the pump's time constant (``tau_up`` to open, ``tau_down`` to close) when ``section_lead``: the
  lagging pump then starts and ends the deposit at the pass ends.
* Segment rates (a canopy dose or a prescription map, docs/dose.md): each pass is cut where the prescribed rate
  changes (:func:`vinecli.rows.rate_path.rate_path`) and each piece has its own litres per metre; a rise is
  commanded ground speed x ``tau_up`` ahead of its piece, a fall ground speed x ``tau_down`` ahead (the pump's
  lag), gaps close the sections; a piece whose flow the pump cannot deliver at the phase's speed is flown slower
  (``speed_caps``). Event ``dose_plan`` {pieces, rate range, out_of_range}.
* Flow: litres per metre x ground speed with AC_Sprayer's minimum speed and on/off delays
  (:class:`~vinecli.control.sprayer.SpeedScaledSprayer`): the dose per hectare holds while the
  vehicle accelerates or brakes. An open section the sprayer does not serve (too slow, tank empty) is
  a cut-out: event ``sprayer_cutout`` {reason, position_est_enu} once per episode.
* Resume: the breakpoint is where the deposit stopped - the vehicle's position on the path when the
  flow stopped, plus the pump's run-down when the sortie closed the sections itself; the next sortie
  flies in along the pass from ``v²/2a`` + 1 m behind it at spraying speed with the sections closed
  and opens them at the breakpoint (``refill.overlap_m`` earlier if asked).
* A job that cannot go on (``max_sorties``, no progress, a battery it may not swap) returns home,
  lands and ends the run ``aborted`` with the cause and the spraying left (:meth:`PhaseHost.abort`). A
  phase without refills whose tank runs dry ends there; the run then judges whether every row got its
  dose (:mod:`vinecli.runs.spray_report`).

Positions are world ENU m; the spray height is above the terrain under the vehicle (the skids'),
the return altitude above home; speeds m/s, flows L/s, times s. Events: ``spray_plan``,
``sortie`` {sortie, event: start|end, reason, breakpoint_enu | last}, ``service``, ``sprayer_cutout``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

from vinecli.autopilot.base import AutopilotContext
from vinecli.autopilot.phases.flight import Rtl, Takeoff
from vinecli.autopilot.phases.phase import Phase, PhaseHost
from vinecli.autopilot.phases.sorties import EnergyLog, Service
from vinecli.control.path import PathFollower
from vinecli.control.sprayer import SpeedScaledSprayer
from vinecli.errors import InputError
from vinecli.frames import Vec3
from vinecli.specs.mission import RefillSpec, SprayPhase, TakeoffPhase

if TYPE_CHECKING:
    from vinecli.rows.plan import RowPlan
    from vinecli.rows.segment_rates import SegmentRates

_ON_PATH_M = 0.7  # the sections open only with the vehicle this close to the path (horizontally and vertically)
_RUN_IN_EXTRA_M = 1.0  # run-in beyond the braking distance v^2 / 2a before a breakpoint, m
_ACC_TAU_S = 0.1  # low-pass of the ground speed's rate of change for the pump's lag compensation, s
#: speed-up with the sections open (above the sprayer's minimum speed), m/s²: the pitch of a 1.5 m/s² acceleration
#: tilts the nozzles' cone back by 0.3 m at 2 m, and where it ends the deposit jumps forward and leaves a dip (a pass
#: the fence leaves no run-in for, started from rest 2.1 m before the row: its 1.0-1.5 m at 0.54x); 0.25 m/s² tilts
#: it by 0.05 m
SPRAY_ACCEL_MPS2 = 0.25


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


class Spray(Phase):
    """Spray the rows (see the module docstring); ``until: empty`` flies them again until the tank is empty."""

    type = "spray"

    def __init__(self, spec: SprayPhase, rows: list[list[tuple[float, float]]],
                 terrain_bounds: tuple[float, float, float, float] | None = None, air_density: float = 1.225,
                 no_spray: Sequence[Sequence[tuple[float, float]]] = (), rates: SegmentRates | None = None) -> None:
        self.spec = spec
        self.rates = rates  # segment rates to follow (None: the phase's one rate)
        self.rated = rates is not None
        self._dose_announced = False
        self._range = (0.0, 0.0)  # the sprayer's flow range, L/s (set at start)
        self.no_spray = no_spray  # the world's no-spray zones: the plan closes the sections at them
        self.rows = rows
        self.terrain_bounds = terrain_bounds
        self.air_density = air_density
        self.timeout_s = spec.timeout_s
        self.sortie = 1
        self.sub: Phase | None = None  # return / service / take-off between sorties
        self.announced = False
        self._queue: list[Phase] = []
        self._resume: tuple[list[Vec3], list[float]] | None = None
        self._left_at_last_end = math.inf  # spraying path left when the last sortie ended, m
        self.energy = EnergyLog()
        self.s_v = 0.0  # the vehicle's position along the path, m
        self._cutout = False
        if spec.flow_lps is None:  # the run set-up resolves rate_lpha against the vehicle (rows/spray_rate.py)
            raise InputError("spray phase: rate_lpha was not resolved to a flow")
        self.per_m = float(spec.flow_lps) / spec.speed_mps  # litres per metre of pass

    @property
    def mode(self) -> str:
        """The sortie step's mode while one runs, else AUTO.MISSION."""
        return self.sub.mode if self.sub is not None else "AUTO.MISSION"

    def _passes(self, ap: PhaseHost, start_xy: tuple[float, float]) -> tuple[list[Vec3], list[float], list[int]]:
        """THE plan of the phase from ``start_xy`` (:func:`~vinecli.rows.spray_rate.phase_plan`): points at the
        spray height, litres per metre on each segment (0 off the passes) and the points to stop at before a run-in.
        ``until: empty`` replans from the last pass's end, so the rows are flown back."""
        from vinecli.rows.spray_rate import phase_plan

        fence = ap.geofence.spec.polygon_enu if ap.geofence is not None and ap.geofence.spec.polygon_enu else None
        plan = phase_plan(self.spec, ap.vehicle, self.rows, start_xy, fence_enu=fence,
                          terrain_bounds=self.terrain_bounds, air_density=self.air_density, no_spray=self.no_spray)
        if not plan.legs:
            raise InputError("spray phase: no rows left inside the geofence")
        if not self.announced:
            lay = plan.layout
            ap.emit("spray_plan", plan.summary(), {
                "passes": plan.order, "length_m": round(plan.length_m, 2), "time_s": plan.time_s,
                "warnings": plan.warnings, "flow_width_m": plan.flow_width_m, "litres_per_m": self.per_m,
                "mode": lay.mode if lay is not None else "rows",
                "row_dose_expected": [round(d, 4) for d in lay.row_dose] if lay is not None else [],
                "stretches": {str(k): [round(a, 3), round(b, 3)] for k, (a, b) in plan.stretches.items()}})
            self.announced = True
        if self.rates is not None:
            pts2, flows, stops = self._rate_path(ap, plan)
        else:
            pts2, flows, stops = plan.path(self.per_m)
        h = self.spec.height_agl_m
        return [(x, y, h) for x, y in pts2], flows, stops

    def _rate_path(self, ap: PhaseHost, plan: RowPlan) -> tuple[list[tuple[float, float]], list[float], list[int]]:
        """The plan's path with each pass at the segment rates under it (module docstring); event ``dose_plan``."""
        from vinecli.rows.rate_path import rate_path

        assert self.rates is not None
        sp = ap.vehicle.sprayer
        rp = rate_path(plan, self.rates, self.rows, speed_mps=self.spec.speed_mps, flow_range_lps=self._range,
                       speed_min_mps=sp.control.speed_min_mps)
        if not self._dose_announced:
            s = rp.summary()
            ap.emit("dose_plan", f"segment rates: {s['pieces']} pieces at {s['rate_min_lpha']:.1f}-"
                                 f"{s['rate_max_lpha']:.1f} L/ha" + "".join(f"; {n['kind']}" for n in rp.notes), s)
            self._dose_announced = True
        return rp.points, rp.flows, rp.stops

    @staticmethod
    def accel(ap: PhaseHost) -> float:
        """Acceleration of the spray path (m/s², the one the plans assume)."""
        from vinecli.rows.plan import plan_accel

        return plan_accel(ap.vehicle)

    def start(self, ap: PhaseHost) -> None:
        self.announced = False
        sp = ap.vehicle.sprayer
        tank = ap.vehicle.tank
        self.sprayer = SpeedScaledSprayer(sp.control, tank.nozzle_max_flow_lps if tank is not None else 0.0)
        lead = sp.control.section_lead
        self.tau_up = sp.pump.tau_up_s if lead else 0.0
        self.tau_down = sp.pump.tau_down_s if lead else 0.0
        self._range = sp.flow_range_lps(tank.nozzle_max_flow_lps if tank is not None else 0.0)
        self._dose_announced = False
        self._new_path(ap)

    # ---- sorties (refill jobs)
    def _reserve_soc(self, ap: PhaseHost, refill: RefillSpec) -> float:
        """State of charge a sortie must land with (job > vehicle operations > battery low_soc)."""
        if refill.reserve_soc is not None:
            return refill.reserve_soc
        ops = ap.vehicle.sprayer.operations
        if ops.reserve_soc is not None:
            return ops.reserve_soc
        bat = ap.vehicle.battery
        return bat.low_soc if bat is not None else 0.0

    def _return_s(self, ap: PhaseHost, refill: RefillSpec) -> float:
        """Time to fly home from here and land, s (transit at up to 5 m/s, climb and descent as the RTL flies)."""
        c = ap.vehicle.control
        d = math.hypot(ap.pos[0] - ap.home[0], ap.pos[1] - ap.home[1])
        zr = ap.home[2] + refill.return_altitude_agl_m
        climb = max(zr - ap.pos[2], 0.0) / c.max_vel_up
        return climb + d / min(5.0, c.max_vel_xy) + (max(zr, ap.pos[2]) - ap.home[2]) / 0.7 + 5.0

    def _sortie_over(self, ap: PhaseHost, refill: RefillSpec) -> str:
        """Why this sortie must end now ('' = it goes on): tank at the reserve, battery needed to get home. With the
        sections open the tank is empty at the litres the pump still delivers as it runs down (flow x tau_down): the
        sortie closes them itself, so its deposit ends in the pump's fall that the next sortie's led opening
        complements (run dry, the flow stopped at once and the led opening sprayed 0.4 m over what the sortie had
        dosed: 1 m at 1.26-1.30x at the breakpoints of the ci job)."""
        rundown = self.sprayer.flow_lps * self.tau_down if self._open else 0.0
        if ap.vehicle.tank is not None and ap.tank_level_l <= max(refill.reserve_l, 1e-6, rundown):
            return "tank empty" if refill.reserve_l <= 0.0 else f"tank at the {refill.reserve_l:g} L reserve"
        soc = ap.battery_soc
        reserve = self._reserve_soc(ap, refill)
        if ap.vehicle.battery is not None and self.energy.must_return(soc, reserve, self._return_s(ap, refill)):
            return f"battery at {soc * 100:.0f} %: just enough to fly home with the {reserve * 100:.0f} % reserve"
        return ""

    def _spraying_left_m(self) -> float:
        """Pass length still to spray from the breakpoint / vehicle position, m."""
        path = self.path
        pts = path.points
        left = 0.0
        for i in range(len(path.flows)):
            a, b = path.cum[i], path.cum[i + 1]
            if path.flows[i] > 0.0 and b > self.s_v:
                f = (b - max(a, self.s_v)) / (b - a) if b > a else 0.0
                left += f * math.hypot(pts[i + 1][0] - pts[i][0], pts[i + 1][1] - pts[i][1])
        return left

    def _abort(self, ap: PhaseHost, cause: str, reason: str) -> bool:
        """End the job here (event ``sortie`` with ``last``), sprayer off, and have the autopilot return, land and end
        the run ``aborted`` naming the cause and what is left to spray."""
        left = self._spraying_left_m()
        ap.emit("sortie", f"sortie {self.sortie} ends ({cause}): job aborted",
                {"sortie": self.sortie, "event": "end", "reason": reason, "last": True,
                 "spraying_left_m": round(left, 2)})
        ap.set_flow(0.0)
        ap.abort(f"spray job aborted in sortie {self.sortie}: {cause}; {left:.1f} m of passes not sprayed")
        return False

    def _breakpoint_s(self, closed_by_us: bool) -> float:
        """Where the deposit stopped along the path, m: the vehicle's position (tank empty: the flow stopped there),
        or further on by the pump's run-down when the sortie closed the sections itself."""
        if not closed_by_us or self.sprayer.flow_lps <= 0.0:
            return self.s_v
        return self.s_v + self._speed * self.tau_down

    def _end_sortie(self, ap: PhaseHost, refill: RefillSpec, reason: str) -> None:
        """Record the breakpoint, then return, land, get serviced and take off again."""
        s_bp = self._breakpoint_s(not ap.tank_empty)
        ap.set_flow(0.0)
        self.sprayer.reset()
        self._resume = self._resume_path(ap, s_bp, refill.overlap_m)
        bp = self.path.from_s(s_bp)[0][0]
        ap.emit("sortie", f"sortie {self.sortie} ends ({reason}) at breakpoint ({bp[0]:.1f}, {bp[1]:.1f})",
                {"sortie": self.sortie, "event": "end", "reason": reason, "breakpoint_enu": [bp[0], bp[1], bp[2]],
                 "breakpoint_s_m": round(s_bp, 3)})
        tank = ap.vehicle.tank
        fill = refill.fill_l if refill.fill_l is not None else (tank.capacity_l if tank is not None else 0.0)
        up = TakeoffPhase(altitude_agl_m=self.spec.height_agl_m)
        self._service = (refill, fill)
        self._queue = [Rtl(refill.return_altitude_agl_m, math.inf), Takeoff(up, ap.vehicle)]
        self._next_step(ap)

    def _service_phase(self, ap: PhaseHost) -> Phase | None:
        """The ground stop after a landing: refill, and a battery swap when the next sortie needs it (or the job says
        so); None when the job cannot go on (it is aborted)."""
        refill, fill = self._service
        self.energy.end_sortie()
        soc = ap.battery_soc
        reserve = self._reserve_soc(ap, refill)
        litres = min(fill, self.per_m * self._spraying_left_m())
        swap, need = self.energy.swap_needed(soc, reserve, litres / max(self.per_m * self.spec.speed_mps, 1e-9))
        rule = refill.swap_battery
        if rule is True or ap.vehicle.battery is None:
            swap = ap.vehicle.battery is not None
        elif rule is False and swap:
            self._abort(ap, f"battery at {soc * 100:.0f} %, the next sortie needs ~{need * 100:.0f} % above the "
                        f"{reserve * 100:.0f} % reserve and the job allows no battery swap", "battery (no swap)")
            return None
        ops = ap.vehicle.sprayer.operations
        t = refill.time_s if refill.time_s is not None else ops.ground_time_s(fill - ap.tank_level_l, swap)
        return Service(t, fill, swap)

    def _next_step(self, ap: PhaseHost) -> None:
        """The next step between sorties (return, service, take-off), or - all done - the next sortie."""
        if self._queue:
            nxt = self._queue.pop(0)
            if isinstance(nxt, Takeoff) and self.sub is not None and self.sub.type == "rtl":
                service = self._service_phase(ap)  # landed: decide the stop now (the battery as it is now)
                if service is None:
                    self.sub = None
                    return
                self._queue.insert(0, nxt)
                nxt = service
            self.sub = nxt
            self.sub.start(ap)
            return
        self.sub = None
        self.sortie += 1
        ap.sortie = self.sortie
        ap.emit("sortie", f"sortie {self.sortie} starts", {"sortie": self.sortie, "event": "start"})
        self._new_path(ap, resume=self._resume)

    def _resume_path(self, ap: PhaseHost, s_bp: float, overlap_m: float) -> tuple[list[Vec3], list[float]]:
        """The path of the next sortie: in along the pass from a run-in point behind the breakpoint (sections
        closed), then the rest of the plan from the breakpoint (``overlap_m`` earlier)."""
        s_open = max(s_bp - overlap_m, 0.0)
        rest, flows = self.path.from_s(s_open)
        dx, dy = self.path.direction_at(s_open)
        v = self.spec.speed_mps
        run_in = v * v / (2.0 * self.accel(ap)) + _RUN_IN_EXTRA_M
        x0, y0, h = rest[0]
        start = (x0 - dx * run_in, y0 - dy * run_in, h)
        return [start, *rest], [0.0, *flows]

    def _new_path(self, ap: PhaseHost, resume: tuple[list[Vec3], list[float]] | None = None) -> None:
        """Follow the planned passes from the hold point, or ``resume`` (points ENU m, litres per metre) after a
        refill."""
        if resume is None:
            pts, flows, stops = self._passes(ap, (ap.hold_sp()[0], ap.hold_sp()[1]))
        else:  # from where the vehicle is to the run-in point (stop there, sections closed), then in along the pass
            h = self.spec.height_agl_m
            pts = [(ap.hold_sp()[0], ap.hold_sp()[1], h), *resume[0]]
            flows = [0.0, *resume[1]]
            stops = [1]
        terrain, lgh = ap.terrain, ap.vehicle.frame.landing_gear_height_m

        def skids_above_terrain(x: float, y: float) -> float:
            return terrain(x, y) + lgh  # the height is the skids' (as the recorded height_agl_m)

        speeds = None
        if self.rated:  # pieces whose flow the pump cannot deliver at the phase's speed are flown slower
            from vinecli.rows.rate_path import speed_caps

            speeds = speed_caps(flows, self.spec.speed_mps, self._range[1])
        self.path = PathFollower(pts, self.spec.speed_mps, accel=self.accel(ap), flows=flows, terrain=skids_above_terrain,
                                 acceptance_m=0.7, max_lead_m=2.0, stops=stops, speeds=speeds,
                                 max_vz=min(ap.vehicle.control.max_vel_up, ap.vehicle.control.max_vel_down),
                                 spray_accel=SPRAY_ACCEL_MPS2,
                                 spray_accel_above=ap.vehicle.sprayer.control.speed_min_mps)
        self.s_v = 0.0
        self._speed = 0.0
        self._acc = 0.0  # rate of change of the ground speed, low-passed, m/s²
        self._open = False  # a section is open

    def _spray(self, ap: PhaseHost, dt: float, sp: Vec3) -> None:
        """Section control and the speed-scaled flow for the next ``dt`` s (module docstring)."""
        s_v, off = self.path.project(ap.pos)
        self.s_v = s_v
        speed = math.hypot(ap.vel[0], ap.vel[1])
        # open ahead of a pass start by the pump's rise, close ahead of its end by its fall
        per_m = self.path.flow_at(s_v + speed * self.tau_up)
        if self.rated:  # a rise ahead by the pump's rise, a fall (a lower rate, a gap) ahead by its fall
            per_dn = self.path.flow_at(s_v + speed * self.tau_down)
            per_m = max(per_m, per_dn) if self.tau_up >= self.tau_down else min(per_m, per_dn)
        elif per_m <= 0.0 and self._open:
            per_m = self.path.flow_at(s_v + speed * self.tau_down)
        open_ = per_m > 0.0 and off < _ON_PATH_M and abs(sp[2] - ap.pos[2]) < _ON_PATH_M
        self._open = open_
        # the pump lags its command by tau: command the speed the vehicle will have then (its ground speed's rate of
        # change, low-passed over _ACC_TAU_S), so the litres per metre hold while it speeds up or brakes
        if dt > 0.0:
            self._acc += dt / (_ACC_TAU_S + dt) * ((speed - self._speed) / dt - self._acc)
        self._speed = speed
        acc = self._acc
        ahead = speed + acc * (self.tau_up if acc > 0.0 else self.tau_down)
        q = self.sprayer.update(dt, speed, per_m * (ahead / speed if speed > 0.1 and ahead > 0.0 else 1.0), open_)
        ap.set_flow(q)
        starved = open_ and (q <= 0.0 or ap.tank_empty)
        if starved and not self._cutout:
            ctl = ap.vehicle.sprayer.control
            why = "tank empty" if ap.tank_empty else (f"ground speed {speed:.2f} m/s: the sprayer runs only after "
                                                      f"{ctl.on_delay_s:g} s at {ctl.speed_min_mps:g} m/s or more")
            p = ap.pos
            ap.emit("sprayer_cutout", f"sprayer cut out over a pass: {why}",
                    {"reason": why, "position_est_enu": [p[0], p[1], p[2]], "path_s_m": round(s_v, 3)})
        self._cutout = starved

    def update(self, ap: PhaseHost, dt: float) -> bool:
        self.energy.update(dt, ap.airborne, ap.battery_soc, ap.flow > 0.0)
        if self.sub is not None:
            if self.sub.update(ap, dt):
                self._next_step(ap)
            return False
        refill = self.spec.refill
        if refill is not None:
            reason = self._sortie_over(ap, refill)
            if reason:
                if self.sortie >= refill.max_sorties:
                    return self._abort(ap, f"{reason}: max_sorties {refill.max_sorties} reached", reason)
                left = self._spraying_left_m()
                if left >= self._left_at_last_end - 0.5:
                    return self._abort(ap, f"{reason} before reaching new rows", f"no progress ({reason})")
                self._left_at_last_end = left
                self._end_sortie(ap, refill, reason)
                return False
        if ap.tank_empty:  # no refill: the phase ends here (the run says whether every row got its dose)
            ap.set_flow(0.0)
            ap.set_position(ap.hold_sp(), (0.0, 0.0, 0.0))
            left = self._spraying_left_m()
            if self.spec.until == "rows_done" and left > 0.5:
                ap.emit("sortie", f"sortie {self.sortie} ends (tank empty) with {left:.1f} m of passes left",
                        {"sortie": self.sortie, "event": "end", "reason": "tank empty", "last": True,
                         "spraying_left_m": round(left, 2)})
            return True
        sp, vff, done = self.path.update(dt, ap.pos)
        ap.set_position(sp, vff, aff=self.path.aff)
        self._spray(ap, dt, sp)
        if done:
            if self.spec.until == "empty":
                self._new_path(ap)
                return False
            ap.set_flow(0.0)
            return True
        return False
