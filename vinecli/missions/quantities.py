"""What a check may measure, resolved when the mission loads (a typo is exit 2, not a failed check later).

A check's ``quantity`` is ``status``, a time-series column (:func:`vinecli.sim.row.timeseries_columns`;
rotor columns up to the vehicle's rotor count) or ``metric:<name>`` (the registry of
:mod:`vinecli.missions.metrics` or a scalar the simulator reports, :data:`SIMULATOR_METRICS`). A
string ``bound``/``reference`` names a metric too, except for ``status`` checks, whose bound is a
run status (:class:`vinecli.autopilot.base.RunStatus`).
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Sequence
from pathlib import Path

from vinecli.errors import SpecError
from vinecli.specs.mission import CheckSpec

#: scalars the simulation loop reports in ``SimResult.metrics`` (``metric:<name>`` in checks)
SIMULATOR_METRICS = frozenset({
    "liftoff_s", "touchdown_s", "tank_empty_s", "total_mass_start_kg", "rigid_mass_kg", "liquid_start_kg",
    "hover_w_pred", "physics_rate_hz", "max_impact_speed_mps", "spawn_settle_s", "spawn_tilt_rad", "steps",
    "final_mass_kg", "energy_wh", "battery_soc_end", "deposition_records",
    "px4_stalls", "px4_resyncs", "px4_lockstep_steps", "px4_lockstep_recoveries", "px4_battery_warnings",
    "px4_scheduler_faults",
    "ardupilot_stalls", "ardupilot_lockstep_steps", "ardupilot_boot_s", "ardupilot_late_markers",
})  # timing figures (wall time, µs per step, real-time factor) are SimResult.timing, not checkable metrics
_ROTOR_RE = re.compile(r"rotor(\d+)_(w_radps|cmd_radps|thrust_n)")


def known_metrics() -> set[str]:
    """Every name ``metric:<name>`` may use."""
    from vinecli.missions.metrics import METRICS

    return set(METRICS) | SIMULATOR_METRICS


def _columns() -> list[str]:
    from vinecli.sim.row import timeseries_columns

    return timeseries_columns(0)


def _unknown(kind: str, name: str, choices: Sequence[str]) -> str:
    close = difflib.get_close_matches(name, choices, n=1)
    return f"unknown {kind} {name!r}" + (f" (did you mean {close[0]!r}?)" if close else "")


def quantity_problem(quantity: str, n_rotors: int | None = None) -> str | None:
    """Why ``quantity`` cannot be measured, or None. ``n_rotors`` None: any rotor number is accepted."""
    if quantity == "status":
        return None
    if quantity.startswith("metric:"):
        name = quantity[len("metric:"):]
        return None if name in known_metrics() else _unknown("metric", name, sorted(known_metrics()))
    m = _ROTOR_RE.fullmatch(quantity)
    if m:
        i = int(m.group(1))
        if i < 1 or (n_rotors is not None and i > n_rotors):
            return f"{quantity!r}: the vehicle has rotors 1..{n_rotors if n_rotors is not None else 'n'}"
        return None
    cols = _columns()
    if quantity in cols:
        return None
    return _unknown("quantity", quantity, [*cols, "status", "rotor1_w_radps", "rotor1_thrust_n"])


def _reference_problem(check: CheckSpec) -> tuple[str, str] | None:
    """(field, problem) for a string bound/reference that is not what the check needs."""
    if check.quantity == "status":
        from vinecli.autopilot.base import RunStatus

        statuses = [s.value for s in RunStatus]
        if str(check.bound) not in statuses:
            return "bound", _unknown("status", str(check.bound), statuses) + f" (one of {', '.join(statuses)})"
        return None
    refs = [("reference", check.reference)]
    refs += [("bound", b) for b in (check.bound if isinstance(check.bound, (list, tuple)) else [check.bound])]
    for field, ref in refs:
        if isinstance(ref, str):
            name = ref[len("metric:"):] if ref.startswith("metric:") else ref
            if name not in known_metrics():
                return field, _unknown("metric", name, sorted(known_metrics()))
    return None


def check_quantities(checks: Sequence[CheckSpec], path: Path | str, n_rotors: int | None = None) -> None:
    """SpecError ``path: checks.N.quantity: unknown quantity ...`` for the first check that cannot be evaluated."""
    for i, c in enumerate(checks):
        problem = quantity_problem(c.quantity, n_rotors)
        if problem is not None:
            raise SpecError(f"checks.{i}.quantity: {problem}", path=path)
        ref = _reference_problem(c)
        if ref is not None:
            raise SpecError(f"checks.{i}.{ref[0]}: {ref[1]}", path=path)
