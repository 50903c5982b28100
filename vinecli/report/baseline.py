"""Comparison with an earlier batch (``--baseline OTHER_RUNS``): regressions by case name.

A regression is a check that passed in the baseline and fails now, a case that ran in the
baseline and errors now, or a metric that moved in its worse direction by more than its
tolerance. Moves in the better direction beyond the tolerance are reported as improvements.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

from vinecli.errors import InputError
from vinecli.report.loader import Run
from vinecli.report.text import format_value

Better = Literal["lower", "higher", "closer_to_1", "any"]


@dataclass(frozen=True)
class Tolerance:
    """Allowed move of a metric: ``|new - old| <= abs + rel * |old|``; ``better`` says which way is good."""

    abs: float
    rel: float = 0.0
    better: Better = "any"

    def limit(self, old: float) -> float:
        return self.abs + self.rel * abs(old)


#: default tolerances (metric names as in summary.json ``metrics`` and the report's ``max_tilt_deg``)
DEFAULT_TOLERANCES: dict[str, Tolerance] = {
    "hpos_error_max_m": Tolerance(0.2, 0.0, "lower"),       # position error, m
    "cross_track_rms_m": Tolerance(0.1, 0.0, "lower"),      # spray track error, m
    "drain_time_ratio": Tolerance(0.02, 0.0, "closer_to_1"),  # drain time / predicted
    "max_tilt_deg": Tolerance(2.0, 0.1, "lower"),           # max tilt airborne, deg
    "tilt_into_wind_ratio": Tolerance(0.15, 0.0, "closer_to_1"),
    "rotor_wind_period_ratio": Tolerance(0.1, 0.0, "closer_to_1"),
    "rotor_mass_correlation": Tolerance(0.1, 0.0, "higher"),
    "tank_force_rest_ratio": Tolerance(0.01, 0.0, "closer_to_1"),
    "climb_tank_force_ratio": Tolerance(0.03, 0.0, "closer_to_1"),
    "drag_opposes_vertical_motion": Tolerance(0.02, 0.0, "higher"),
}


@dataclass
class Regression:
    """One flagged difference against the baseline (``kind``: check, error, metric)."""

    case: str
    kind: str
    name: str
    message: str
    baseline: Any = None
    current: Any = None
    tolerance: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class Comparison:
    """Result of comparing a batch with its baseline."""

    baseline_dir: str
    regressions: list[Regression] = field(default_factory=list)
    improvements: list[Regression] = field(default_factory=list)
    new_cases: list[str] = field(default_factory=list)
    missing_cases: list[str] = field(default_factory=list)
    compared: int = 0

    def for_case(self, case: str) -> list[Regression]:
        return [r for r in self.regressions if r.case == case]

    def to_dict(self) -> dict[str, Any]:
        return {"baseline_dir": self.baseline_dir, "compared_cases": self.compared,
                "regressions": [r.to_dict() for r in self.regressions],
                "improvements": [r.to_dict() for r in self.improvements],
                "new_cases": self.new_cases, "missing_cases": self.missing_cases}


def parse_tolerances(items: Sequence[str]) -> dict[str, Tolerance]:
    """``NAME=ABS`` or ``NAME=ABS:REL`` (REL fraction of the baseline value) -> tolerances; direction kept
    from the defaults (``any`` for unknown metrics). InputError for malformed items."""
    out: dict[str, Tolerance] = {}
    for item in items:
        name, sep, val = item.partition("=")
        try:
            if not sep or not name.strip():
                raise ValueError
            a, _, r = val.partition(":")
            tol_abs, tol_rel = float(a), float(r) if r else 0.0
            if tol_abs < 0 or tol_rel < 0 or not (math.isfinite(tol_abs) and math.isfinite(tol_rel)):
                raise ValueError
        except ValueError:
            raise InputError(f"bad --tolerance {item!r} (expected NAME=ABS or NAME=ABS:REL, non-negative)") from None
        better = DEFAULT_TOLERANCES.get(name.strip(), Tolerance(0.0)).better
        out[name.strip()] = Tolerance(tol_abs, tol_rel, better)
    return out


def compare(current: Sequence[Run], baseline: Sequence[Run], baseline_dir: str,
            tolerances: Mapping[str, Tolerance] | None = None) -> Comparison:
    """Compare runs by case name; see the module docstring for what is flagged."""
    tols = dict(DEFAULT_TOLERANCES)
    tols.update(tolerances or {})
    base = {r.case: r for r in baseline}
    cur = {r.case: r for r in current}
    comp = Comparison(baseline_dir=baseline_dir, new_cases=[c for c in cur if c not in base],
                      missing_cases=[c for c in base if c not in cur])
    for case, run in cur.items():
        old = base.get(case)
        if old is None:
            continue
        comp.compared += 1
        if run.errored and not old.errored:
            comp.regressions.append(Regression(case, "error", "run", f"the case errors now: {run.error}",
                                               old.status, "error"))
            continue
        old_checks = {c["name"]: c for c in old.checks}
        for c in run.checks:
            o = old_checks.get(c["name"])
            if o is not None and o.get("passed") and not c.get("passed"):
                comp.regressions.append(Regression(
                    case, "check", c["name"],
                    f"check {c['name']} newly fails: {format_value(c.get('value'))} (baseline {format_value(o.get('value'))}), "
                    f"bound {c.get('op')} {format_value(c.get('bound'))}", o.get("value"), c.get("value")))
        new_m, old_m = run.metrics(), old.metrics()
        for name, tol in tols.items():
            a, b = _num(old_m.get(name)), _num(new_m.get(name))
            if a is None or b is None:
                continue
            delta = b - a
            limit = tol.limit(a)
            if abs(delta) <= limit:
                continue
            worse = _is_worse(a, b, tol.better)
            entry = Regression(case, "metric", name,
                               f"{name} moved {format_value(a)} -> {format_value(b)} (Δ {delta:+.4g}, tolerance ±{limit:.4g}"
                               f"{'' if tol.better == 'any' else ', better: ' + tol.better.replace('_', ' ')})",
                               a, b, limit)
            (comp.regressions if worse else comp.improvements).append(entry)
    return comp


def _is_worse(old: float, new: float, better: Better) -> bool:
    if better == "lower":
        return new > old
    if better == "higher":
        return new < old
    if better == "closer_to_1":
        return abs(new - 1.0) > abs(old - 1.0)
    return True


def _num(v: Any) -> float | None:
    if isinstance(v, bool) or v is None:
        return None
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None
