"""Evaluating a mission's checks on a finished run.

A check is ``reduce(quantity over window) op bound`` (see :class:`~vinecli.specs.mission.CheckSpec`):

* ``quantity``: a time-series column (SI, frame in the name, e.g. ``tank_force_enu_z_n``),
  ``status`` (the run's final status name, ops ``==``/``!=``), or ``metric:<name>``: a derived
  metric of :mod:`vinecli.missions.metrics` computed over the check's window (or a scalar the
  simulator reported, e.g. ``metric:liftoff_s``). ``reduce`` is ignored for status and metrics.
* ``reduce``: ``max``, ``min``, ``mean``, ``final`` (last sample), ``at`` (linear interpolation
  at the ``at`` time), ``std`` (population), ``absmax`` (max |x|), ``range`` (max - min).
  NaN samples are ignored.
* ``window``: ``[t0, t1]``, each a number (s from the run start) or a time reference (below);
  default: the whole run. Samples with ``t0 <= t <= t1`` are used.
* ``op``: ``<``, ``<=``, ``>``, ``>=``, ``==``, ``!=``, ``between`` (``bound: [lo, hi]``,
  inclusive), ``within_pct`` (``|value - reference| <= bound/100 * |reference|``).
  ``bound`` and ``reference`` may be numbers or ``metric:<name>`` / a bare metric name.

Time references: ``start``, ``end``, an event kind (``liftoff``, ``touchdown``, ``tank_empty``
or any kind in the run's events; first occurrence), ``phase:N`` (first sample of phase N,
0-based as the ``phase_index`` column) and ``phase_end:N`` (last sample of phase N), each
optionally followed by ``+s`` or ``-s`` (seconds), e.g. ``"liftoff-1.0"``, ``"end-5"``.
A reference to an event that did not happen makes the check fail (with that message).

If a mission has no check on ``status``, an implicit ``status == completed`` check is added; the
default checks of a spraying mission (:mod:`vinecli.missions.dose`) are implicit too.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from vinecli.missions.metrics import METRICS
from vinecli.missions.rundata import EventMissing, RunData
from vinecli.specs.mission import CheckSpec


@dataclass
class CheckResult:
    """Outcome of one check (the summary.json ``checks`` entries)."""

    name: str
    description: str
    quantity: str
    reduce: str
    window: list[float] | None
    op: str
    bound: Any
    value: Any
    passed: bool
    message: str
    implicit: bool = False

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        if not d["implicit"]:
            d.pop("implicit")
        return d


#: counters a firmware run must end at 0, each an implicit check when the run has it: the lockstep stalls a
#: firmware backend counts (steps that went on without the firmware's answer) and the faults the firmware's own
#: log shows in the firmware (vinecli.sitl.px4.log_audit)
_STALLS = "every lockstep step had the firmware's answer (implicit)"
FIRMWARE_COUNTERS = {"px4_stalls": _STALLS, "ardupilot_stalls": _STALLS,
                     "px4_scheduler_faults": "PX4 ran its periodic work (battery simulator, load monitor) to the end "
                                             "of its log; a stop is PX4's own scheduler fault (implicit)"}


def implicit_checks(checks: Sequence[CheckSpec], metrics: Mapping[str, Any] | None = None,
                    defaults: Sequence[CheckSpec] = ()) -> list[CheckSpec]:
    """The checks actually evaluated: the mission's, the ``defaults`` (e.g. the dose checks), plus
    ``status == completed`` if none tests the status, and, for a firmware run (its stall counter in
    ``metrics``), ``<firmware>_stalls == 0`` unless the mission checks that counter itself: a step without
    the firmware's answer is not the firmware's flight; likewise ``px4_scheduler_faults == 0`` when PX4's log was
    audited (:data:`FIRMWARE_COUNTERS`)."""
    out = [*checks, *defaults]
    if not any(c.quantity == "status" for c in checks):
        out.append(
            CheckSpec(name="status", quantity="status", op="==", bound="completed",
                      description="the mission ran to completion (implicit)")
        )
    for name, description in FIRMWARE_COUNTERS.items():
        if metrics is not None and name in metrics and not any(c.quantity == f"metric:{name}" for c in checks):
            out.append(CheckSpec(name=name, quantity=f"metric:{name}", op="<=", bound=0.0, description=description))
    return out


def evaluate_checks(checks: Sequence[CheckSpec], data: RunData, defaults: Sequence[CheckSpec] = ()) -> list[CheckResult]:
    """Evaluate every check (plus the ``defaults`` and the implicit status check, marked implicit); never raises for
    run-dependent problems."""
    explicit = len(checks)
    results = []
    for i, c in enumerate(implicit_checks(checks, data.metrics, defaults)):
        r = evaluate_check(c, data)
        r.implicit = i >= explicit
        results.append(r)
    return results


def evaluate_check(check: CheckSpec, data: RunData) -> CheckResult:
    """Evaluate one check on ``data``."""
    window: tuple[float, float] | None = None
    res = CheckResult(check.name, check.description, check.quantity, check.reduce, None, check.op,
                      _jsonable_bound(check.bound), None, False, "")
    try:
        if check.window is not None:
            window = (data.resolve_time(check.window[0]), data.resolve_time(check.window[1]))
            res.window = [round(window[0], 6), round(window[1], 6)]
        if check.quantity == "status":
            res.value = data.status
            res.passed = (data.status == str(check.bound)) if check.op == "==" else (data.status != str(check.bound))
            res.message = f"status {data.status!r} {check.op} {check.bound!r}"
            return res
        value = _quantity_value(check, data, window)
        res.value = value
        if value is None or not math.isfinite(value):
            res.message = f"{_describe(check)} has no finite value"
            return res
        res.passed, res.message = _compare(check, value, data, window)
    except EventMissing as exc:
        res.message = str(exc)
    except KeyError as exc:
        res.message = f"unknown quantity {exc.args[0]!r}"
    except ValueError as exc:
        res.message = str(exc)
    return res


def _quantity_value(check: CheckSpec, data: RunData, window: tuple[float, float] | None) -> float | None:
    q = check.quantity
    if q.startswith("metric:"):
        return metric_value(q[len("metric:"):], data, window)
    if not data.has(q):
        raise KeyError(q)
    y = data.column(q)
    t = data.t
    if check.reduce == "at":
        if check.at is None:
            raise ValueError("reduce 'at' needs an 'at' time")
        ta = data.resolve_time(check.at)
        ok = np.isfinite(y)
        if not ok.any():
            return None
        if ta < t[0] - 1e-9 or ta > t[-1] + 1e-9:
            raise ValueError(f"'at' time {ta:.3f} s is outside the run [{t[0]:.3f}, {t[-1]:.3f}] s")
        return float(np.interp(ta, t[ok], y[ok]))
    sel = y[data.window_mask(window)]
    sel = sel[np.isfinite(sel)]
    if sel.size == 0:
        w = f" [{window[0]:.3f}, {window[1]:.3f}] s" if window else ""
        raise ValueError(f"window{w} has no finite samples of {q}")
    return reduce_values(sel, check.reduce)


def reduce_values(x: np.ndarray, how: str) -> float:
    """Reduce a non-empty array of finite samples."""
    if how == "max":
        return float(np.max(x))
    if how == "min":
        return float(np.min(x))
    if how == "mean":
        return float(np.mean(x))
    if how == "final":
        return float(x[-1])
    if how == "std":
        return float(np.std(x))
    if how == "absmax":
        return float(np.max(np.abs(x)))
    if how == "range":
        return float(np.max(x) - np.min(x))
    raise ValueError(f"unknown reduce {how!r}")


def metric_value(name: str, data: RunData, window: tuple[float, float] | None = None) -> float:
    """A derived metric (registry in :mod:`vinecli.missions.metrics`) or a scalar the simulator reported."""

    if name in METRICS:
        return float(METRICS[name].fn(data, window))
    if name in data.metrics:
        return float(data.metrics[name])
    raise KeyError(f"metric:{name}")


def _number(ref: Any, data: RunData, window: tuple[float, float] | None, what: str) -> float:
    if isinstance(ref, (int, float)):
        return float(ref)
    if isinstance(ref, str):
        name = ref[len("metric:"):] if ref.startswith("metric:") else ref
        try:
            return metric_value(name, data, window)
        except KeyError:
            raise ValueError(f"{what} {ref!r} is neither a number nor a known metric") from None
    raise ValueError(f"{what} {ref!r} is not a number")


def _compare(check: CheckSpec, v: float, data: RunData, window: tuple[float, float] | None) -> tuple[bool, str]:
    op = check.op
    d = _describe(check)
    if op == "between":
        b = check.bound
        if not isinstance(b, (list, tuple)) or len(b) != 2:
            raise ValueError("op 'between' needs bound [lo, hi]")
        lo, hi = _number(b[0], data, window, "bound"), _number(b[1], data, window, "bound")
        return lo <= v <= hi, f"{d} = {v:.6g}, expected in [{lo:.6g}, {hi:.6g}]"
    if op == "within_pct":
        pct = _number(check.bound, data, window, "bound")
        ref = _number(check.reference, data, window, "reference")
        dev = abs(v - ref) / abs(ref) * 100.0 if ref != 0 else (0.0 if v == 0 else math.inf)
        return dev <= pct, f"{d} = {v:.6g}, {dev:.3g} % from {ref:.6g} (allowed {pct:.6g} %)"
    b = _number(check.bound, data, window, "bound")
    ok = {
        "<": v < b, "<=": v <= b, ">": v > b, ">=": v >= b, "==": v == b, "!=": v != b,
    }[op]
    return ok, f"{d} = {v:.6g}, expected {op} {b:.6g}"


def _describe(check: CheckSpec) -> str:
    if check.quantity.startswith("metric:"):
        return check.quantity
    return f"{check.reduce}({check.quantity})"


def _jsonable_bound(b: Any) -> Any:
    return list(b) if isinstance(b, tuple) else b
