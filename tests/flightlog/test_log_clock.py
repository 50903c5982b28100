"""A flight log's damaged clock is found and handled. A ULog whose second half is shifted by
10^12 or 10^16 µs, or whose clock restarts at 0 halfway, is fitted on its longest continuous stretch, with a note
saying so, in seconds and bounded memory (``vehicle fit`` hung past 120 s and 1.5 GB, or asked for 3.6 TiB); a log
cut short says so (a note, or the refusal names the cut: "never left the ground" of a log that took off at 3.9 s
was wrong). The real PX4 log of ../shared is attacked the same way when it is there."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from tests.flightlog.synthetic_log import synthetic_log
from tests.identify.ulog_edit import cut, restarted, shifted, shifted_topic
from tests.repo_paths import SHARED_DATA
from tests.safety.memguard import run_child
from vinecli.errors import InputError
from vinecli.flightlog.clock import JUMP_S, continuous_stretch
from vinecli.flightlog.ulog_write import write_ulog

FIT = "import sys; from vinecli.cli.app import app; sys.argv = ['vinecli'] + sys.argv[1:]; app()"
REAL = SHARED_DATA / "flightlogs" / "TestFlight1.ulg"


def test_the_longest_continuous_stretch_is_kept() -> None:
    t = np.concatenate([np.arange(0, 10, 0.01), 1e6 + np.arange(0, 20, 0.01), np.arange(0, 5, 0.01)])
    s = continuous_stretch(t)
    assert (s.epoch, s.t0) == (0, pytest.approx(1e6)) and s.t1 == pytest.approx(1e6 + 19.99)
    assert "restarts 1 time(s)" in s.note and "jumps 1 time(s)" in s.note
    assert s.take(t).sum() == 2000
    small = np.arange(0, 100, 0.01)
    small[500], small[501] = small[501], small[500]  # out-of-order by a sample: not a restart
    assert continuous_stretch(small).note == ""
    gap = np.concatenate([np.arange(0, 10, 0.01), 10 + JUMP_S / 2 + np.arange(0, 10, 0.01)])
    assert continuous_stretch(gap).note == ""  # a logging gap, not a jump


def test_a_clock_running_for_days_is_refused() -> None:
    with pytest.raises(InputError, match="without a break: at most 6 h"):
        continuous_stretch(np.arange(0.0, 30 * 3600.0, 50.0), "long.ulg")


def _fit(log: Path, out: Path) -> tuple[int, float, float, str, dict]:
    t0 = time.monotonic()
    r = run_child([sys.executable, "-c", FIT, "vehicle", "fit", str(log), "--out", str(out), "--mass", "2.0"],
                  timeout=600)
    took = time.monotonic() - t0
    fit = json.loads((out / "fit.json").read_text()) if r.returncode == 0 else {}
    return r.returncode, took, r.peak_rss_mb, r.stderr, fit


def _fit_here(log: Path, out: Path) -> tuple[int, str, dict]:
    """``vehicle fit`` in this process, for the tests that bound neither its time nor its memory (the others run it
    as a process under memguard: its own peak RSS); exit code, stderr, fit.json."""
    from tests.safety.attack_kit import cli

    r = cli("vehicle", "fit", log, "--out", out, "--mass", "2.0")
    fit = json.loads((out / "fit.json").read_text()) if r.exit_code == 0 else {}
    return r.exit_code, r.stderr, fit


@pytest.fixture(scope="module")
def whole(tmp_path_factory: pytest.TempPathFactory) -> bytes:
    return write_ulog(synthetic_log(duration_s=60.0), tmp_path_factory.mktemp("log") / "whole.ulg").read_bytes()


@pytest.mark.parametrize(("name", "edit", "note"), [
    ("jump 1e12 us", lambda d: shifted(d, 0.5, 10**12), "jumps 1 time(s)"),
    ("jump 1e16 us", lambda d: shifted(d, 0.5, 10**16), "jumps 1 time(s)"),
    ("restart at 0", lambda d: restarted(d, 0.5), "restarts 1 time(s)"),
])
def test_a_damaged_clock_is_fitted_on_its_longest_stretch_with_a_note(whole: bytes, tmp_path: Path, name: str, edit,  # noqa: ANN001
                                                                      note: str) -> None:
    (tmp_path / "bad.ulg").write_bytes(edit(whole))
    code, took, rss, err, fit = _fit(tmp_path / "bad.ulg", tmp_path / "fit")
    assert code == 0, err[-2000:]
    assert any(note in n and "longest continuous stretch" in n for n in fit["notes"]), fit["notes"]
    assert fit["log"]["duration_s"] < 40.0  # one half of the 60 s flight, never a span of days
    assert took < 120 and rss < 1500, (took, rss)


@pytest.mark.parametrize("delta_us", [10**12, 10**16])
def test_one_stream_s_clock_jumping_alone_is_dropped_with_a_note(whole: bytes, tmp_path: Path, delta_us: int) -> None:
    """The IMU's clock is whole but the battery's alone jumps halfway: the fit used to take the jumped samples
    silently (its figure of merit moved 7.5 -> 6.7 / 17.4); now they are dropped and a note names the stream."""
    (tmp_path / "bad.ulg").write_bytes(shifted_topic(whole, "battery_status", 0.5, delta_us))
    code, took, rss, err, fit = _fit(tmp_path / "bad.ulg", tmp_path / "fit")
    assert code == 0, err[-2000:]
    note = next((n for n in fit["notes"] if "battery_status" in n), None)
    assert note is not None and "jumps away from the IMU's" in note, fit["notes"]
    assert fit["log"]["duration_s"] > 55.0  # the IMU's whole flight is kept
    assert took < 120 and rss < 1500, (took, rss)


def test_a_log_cut_in_flight_says_so(whole: bytes, tmp_path: Path) -> None:
    (tmp_path / "half.ulg").write_bytes(cut(whole, 0.5))
    code, err, fit = _fit_here(tmp_path / "half.ulg", tmp_path / "fit")
    assert code == 0, err[-2000:]
    notes = " ".join(fit["notes"])
    assert "armed and in the air: cut short" in notes and "ends inside a message" in notes


def test_a_log_cut_soon_after_take_off_is_not_never_left_the_ground(whole: bytes, tmp_path: Path) -> None:
    (tmp_path / "early.ulg").write_bytes(cut(whole, 0.075))  # takes off at 3 s, cut ~1 s later
    code, err, _doc = _fit_here(tmp_path / "early.ulg", tmp_path / "fit")
    assert code == 2
    assert "never left the ground" not in err and "took off at" in err and "cut short" in err, err[-1000:]


@pytest.mark.skipif(not REAL.is_file(), reason="needs ../shared/data/flightlogs/TestFlight1.ulg")
@pytest.mark.parametrize("edit", ["jump", "restart", "cut 10 %"])
def test_the_real_px4_log_damaged(tmp_path: Path, edit: str) -> None:
    data = REAL.read_bytes()
    bad = {"jump": lambda: shifted(data, 0.5, 10**12), "restart": lambda: restarted(data, 0.5),
           "cut 10 %": lambda: cut(data, 0.1)}[edit]()
    (tmp_path / "bad.ulg").write_bytes(bad)
    if edit == "cut 10 %":  # TestFlight1 takes off at 3.9 s; 10 % of the file ends half a second later
        code, err, _doc = _fit_here(tmp_path / "bad.ulg", tmp_path / "fit")
        assert code == 2 and "took off at" in err and "cut short" in err, err[-1000:]
    else:
        code, took, rss, err, fit = _fit(tmp_path / "bad.ulg", tmp_path / "fit")
        assert code == 0 and any("longest continuous stretch" in n for n in fit["notes"]), err[-1000:]
        assert took < 120 and rss < 1500, (took, rss)
