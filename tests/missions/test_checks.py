"""Check semantics: time references, windows, every reduce and op, failure messages."""

from __future__ import annotations

import numpy as np
import pytest

from vinecli.missions.checks import evaluate_check, evaluate_checks
from vinecli.missions.rundata import RunData, parse_time_ref
from vinecli.specs.mission import CheckSpec


@pytest.fixture()
def data() -> RunData:
    t = np.round(np.arange(0, 10.0001, 0.1), 6)  # 0 .. 10 s at 10 Hz
    y = t.copy()  # y(t) = t
    phase = np.where(t < 4.0, 0, np.where(t < 7.0, 1, 2))
    z = np.where(t < 5.0, -1.0, 3.0)
    return RunData(
        timeseries={"t_s": t, "y": y, "z": z, "phase_index": phase, "n": np.where(t < 1, np.nan, t)},
        events=[(2.0, "liftoff"), (9.0, "touchdown"), (9.5, "touchdown")],
        status="completed",
        metrics={"tank_empty_s": 6.0, "hover_w_pred": 900.0},
    )


def chk(**kw) -> CheckSpec:
    kw.setdefault("name", "c")
    return CheckSpec(**kw)


@pytest.mark.parametrize(
    ("ref", "expected"),
    [
        ("liftoff", ("liftoff", None, 0.0)),
        ("liftoff-1.0", ("liftoff", None, -1.0)),
        ("liftoff+3", ("liftoff", None, 3.0)),
        ("end - 5", ("end", None, -5.0)),
        ("phase:2", ("phase", 2, 0.0)),
        ("phase_end:1+0.5", ("phase_end", 1, 0.5)),
        ("tank_empty", ("tank_empty", None, 0.0)),
    ],
)
def test_parse_time_ref(ref: str, expected: tuple) -> None:
    assert parse_time_ref(ref) == expected


@pytest.mark.parametrize("ref", ["liftoff--1", "phase", "liftoff:2", "3 s", "end+", ""])
def test_parse_time_ref_rejects(ref: str) -> None:
    with pytest.raises(ValueError):
        parse_time_ref(ref)


@pytest.mark.parametrize(
    ("ref", "t"),
    [
        ("start", 0.0), ("end", 10.0), ("end-5", 5.0), ("liftoff-1.0", 1.0), ("liftoff+3", 5.0),
        ("phase:1", 4.0), ("phase_end:1", 6.9), ("phase:2", 7.0), ("touchdown", 9.0), ("tank_empty", 6.0), (2.5, 2.5),
    ],
)
def test_resolve_time(data: RunData, ref, t: float) -> None:
    assert data.resolve_time(ref) == pytest.approx(t)


@pytest.mark.parametrize(
    ("reduce", "window", "value"),
    [
        ("max", None, 10.0), ("min", None, 0.0), ("mean", None, 5.0), ("final", None, 10.0),
        ("max", ("liftoff", "liftoff+3"), 5.0), ("min", ("liftoff", "liftoff+3"), 2.0),
        ("mean", (2.0, 4.0), 3.0), ("final", ("phase:1", "phase_end:1"), 6.9),
        ("std", (0.0, 1.0), float(np.std(np.arange(0, 1.0001, 0.1)))),
        ("range", ("phase:1", "phase_end:1"), 2.9),
    ],
)
def test_reduce_over_window(data: RunData, reduce: str, window, value: float) -> None:
    r = evaluate_check(chk(quantity="y", reduce=reduce, window=window, op="<=", bound=100), data)
    assert r.passed, r.message
    assert r.value == pytest.approx(value)
    if window is not None:
        assert r.window is not None and len(r.window) == 2


def test_absmax_and_at(data: RunData) -> None:
    assert evaluate_check(chk(quantity="z", reduce="absmax", op="==", bound=3.0), data).passed
    assert evaluate_check(chk(quantity="z", reduce="absmax", window=(0, 4), op="==", bound=1.0), data).passed
    r = evaluate_check(chk(quantity="y", reduce="at", at="liftoff+0.25", op="==", bound=2.25), data)
    assert r.passed and r.value == pytest.approx(2.25)


def test_nan_samples_ignored(data: RunData) -> None:
    r = evaluate_check(chk(quantity="n", reduce="min", op="==", bound=1.0), data)
    assert r.passed and r.value == pytest.approx(1.0)


@pytest.mark.parametrize(
    ("op", "bound", "passed"),
    [
        ("<", 10.0, False), ("<", 10.5, True), ("<=", 10.0, True), (">", 10.0, False), (">=", 10.0, True),
        ("==", 10.0, True), ("!=", 10.0, False), ("between", (9.5, 10.5), True), ("between", (0.0, 9.0), False),
    ],
)
def test_ops(data: RunData, op: str, bound, passed: bool) -> None:
    r = evaluate_check(chk(quantity="y", reduce="max", op=op, bound=bound), data)
    assert r.passed is passed
    assert "10" in r.message


def test_within_pct_number_and_metric(data: RunData) -> None:
    ok = evaluate_check(chk(quantity="y", reduce="max", op="within_pct", bound=1.0, reference=9.95), data)
    assert ok.passed
    bad = evaluate_check(chk(quantity="y", reduce="max", op="within_pct", bound=1.0, reference=9.8), data)
    assert not bad.passed and "%" in bad.message
    # reference and bound taken from metrics the simulator reported
    r = evaluate_check(chk(quantity="metric:hover_w_pred", op="within_pct", bound=0.5, reference=901.0), data)
    assert r.passed and r.value == 900.0
    r = evaluate_check(chk(quantity="y", reduce="max", op="<", bound="metric:hover_w_pred"), data)
    assert r.passed


def test_status_checks(data: RunData) -> None:
    assert evaluate_check(chk(quantity="status", op="==", bound="completed"), data).passed
    r = evaluate_check(chk(quantity="status", op="==", bound="cannot_take_off"), data)
    assert not r.passed and "completed" in r.message
    assert evaluate_check(chk(quantity="status", op="!=", bound="crashed"), data).passed


def test_failures_have_messages(data: RunData) -> None:
    r = evaluate_check(chk(quantity="nope", reduce="max", op="<", bound=1), data)
    assert not r.passed and "nope" in r.message
    r = evaluate_check(chk(quantity="y", window=("landing", "end"), op="<", bound=1), data)
    assert not r.passed and "landing" in r.message
    r = evaluate_check(chk(quantity="y", window=("phase:5", "end"), op="<", bound=1), data)
    assert not r.passed and "phase 5" in r.message
    r = evaluate_check(chk(quantity="y", window=(20, 30), reduce="max", op="<", bound=1), data)
    assert not r.passed and "no finite samples" in r.message
    r = evaluate_check(chk(quantity="metric:unknown_thing", op="<", bound=1), data)
    assert not r.passed and "unknown_thing" in r.message


def test_implicit_status_check(data: RunData) -> None:
    res = evaluate_checks([chk(quantity="y", reduce="max", op="<", bound=100)], data)
    assert [r.name for r in res] == ["c", "status"]
    assert res[1].implicit and all(r.passed for r in res)
    data.status = "crashed"
    res = evaluate_checks([chk(quantity="y", reduce="max", op="<", bound=100)], data)
    assert not res[1].passed
    res = evaluate_checks([chk(quantity="status", op="==", bound="crashed")], data)
    assert len(res) == 1 and res[0].passed
