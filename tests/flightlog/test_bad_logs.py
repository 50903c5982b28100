"""Every bad flight log exits 2 with one line naming the file and what is wrong or missing, no traceback,
and nothing written: missing, empty, foreign, random, truncated, incomplete, unsupported, never airborne."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tests.flightlog.synthetic_log import synthetic_log
from vinecli.cli.app import app
from vinecli.flightlog.dataflash_write import write_dataflash
from vinecli.flightlog.ulog_write import FORMATS, write_ulog

runner = CliRunner()


def _fit(log: Path, out: Path, *extra: str) -> tuple[int, str]:
    r = runner.invoke(app, ["vehicle", "fit", str(log), "--out", str(out), *extra])
    return r.exit_code, r.output


def _ulog_without(log, path: Path, topic: str) -> Path:
    return write_ulog(log, path, topics=[t for t in FORMATS if t != topic])


def _bad_logs(d: Path) -> list[tuple[str, Path, str]]:
    """(case, file, what the message must say)."""
    log = synthetic_log()
    cases: list[tuple[str, Path, str]] = [("missing", d / "missing.ulg", "not found")]
    (d / "empty.ulg").write_bytes(b"")
    cases.append(("empty", d / "empty.ulg", "empty file"))
    (d / "notes.txt").write_text("takeoff at 10:02, landed 10:05\n")
    cases.append(("text", d / "notes.txt", "not a PX4 ULog or ArduPilot DataFlash"))
    (d / "random.bin").write_bytes(np.random.default_rng(0).integers(0, 256, 4096, dtype=np.uint8).tobytes())
    cases.append(("random bytes", d / "random.bin", "not a PX4 ULog or ArduPilot DataFlash"))
    full = write_ulog(log, d / "full.ulg").read_bytes()
    (d / "head.ulg").write_bytes(full[:20])
    cases.append(("ULog cut in its header", d / "head.ulg", "no logged data"))
    defs_end = full.index(b"actuator_outputs", full.index(b"actuator_outputs") + 1)  # the first subscription
    (d / "defs.ulg").write_bytes(full[:defs_end])
    cases.append(("ULog cut after its definitions", d / "defs.ulg", "no logged data"))
    dfb = write_dataflash(log, d / "full.bin").read_bytes()
    (d / "cut.bin").write_bytes(dfb[:3000])
    cases.append(("DataFlash cut after its formats", d / "cut.bin", "too few motor-output samples (4; the log is truncated"))
    cases.append(("ULog without actuator_outputs", _ulog_without(log, d / "noout.ulg", "actuator_outputs"),
                  "no motor outputs (actuator_outputs"))
    cases.append(("ULog without attitude", _ulog_without(log, d / "noatt.ulg", "vehicle_attitude"),
                  "vehicle_attitude"))
    pwm = log.motors.pwm_us.copy()
    pwm[100:110] = np.nan
    nan = replace(log, motors=replace(log.motors, pwm_us=pwm))
    cases.append(("NaN motor outputs", write_ulog(nan, d / "nan.ulg"), "not finite"))
    cases.append(("fixed wing", write_ulog(log, d / "plane.ulg", params={**log.params, "MAV_TYPE": 1.0}),
                  "unsupported vehicle: MAV_TYPE 1"))
    cases.append(("hexacopter on a quad base", write_ulog(synthetic_log(6), d / "hexa.ulg"), "6 motors"))
    cases.append(("never airborne", write_ulog(synthetic_log(airborne=False), d / "ground.ulg"), "airborne"))
    cases.append(("a directory", d, "not a file"))
    return cases


def test_every_bad_log_exits_2_naming_the_file(tmp_path: Path) -> None:
    logs = tmp_path / "logs"  # beside the outputs: an output inside an input folder is refused first
    logs.mkdir()
    for case, path, needle in _bad_logs(logs):
        out = tmp_path / "out" / case.replace(" ", "_")
        code, text = _fit(path, out)
        assert code == 2, (case, text)
        line = " ".join(text.split())
        assert str(path) in line and needle in line, (case, text)
        assert "Traceback" not in text and "internal error" not in text, (case, text)
        assert not out.exists(), case


def test_replay_refuses_bad_input(tmp_path: Path) -> None:
    log = write_ulog(synthetic_log(), tmp_path / "s.ulg")
    for args, needle in ((["--vehicle", "x900"], "unknown vehicle 'x900'"),
                         (["--vehicle", "x500", "--window", "0"], "--window"),
                         (["--vehicle", "hex-sprayer"], "6 rotors")):
        out = tmp_path / "o"
        r = runner.invoke(app, ["vehicle", "replay", str(log), "--out", str(out), *args])
        assert r.exit_code == 2 and needle in " ".join(r.output.split()), (args, r.output)
        assert not out.exists()


@pytest.mark.parametrize("bad_mass", ["0", "-1", "nan", "1e9"])
def test_fit_refuses_an_impossible_mass(tmp_path: Path, bad_mass: str) -> None:
    code, text = _fit(write_ulog(synthetic_log(), tmp_path / "s.ulg"), tmp_path / "o", "--mass", bad_mass)
    assert code == 2 and "--mass" in text


def test_formats_cover_what_the_reader_needs() -> None:
    assert {"actuator_outputs", "sensor_combined", "vehicle_attitude", "vehicle_local_position"} <= set(FORMATS)
