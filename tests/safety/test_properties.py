"""As properties (hypothesis): whatever a careless or hostile user puts in a spec field, a
command-line option or an input file, vinecli ends with exit 0 (or 1: a check failed), or 2 with one line,
never 3 or a traceback, and its inputs stay byte-identical.

Deterministic (``derandomize``: the same examples every run) and bounded, to fit the CI budget: each
property draws a few dozen examples of values chosen to break things (NaN, ±inf, huge and negative
numbers, wrong types, lists for mappings, control characters, truncated and flipped bytes).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest
import yaml
from attack_kit import cli, fingerprint
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from repo_paths import TEST_DATA

PROPS = settings(derandomize=True, deadline=None, database=None, phases=[Phase.explicit, Phase.generate],
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

#: values that break naive code: non-finite, huge, negative, wrong types, nested the wrong way
NASTY = st.one_of(
    st.sampled_from([float("nan"), float("inf"), -float("inf"), 1e308, -1e308, 1e-308, 0, -1, 2**64, 2**31,
                     "", "abc", "\x1b[2J", "../../etc/passwd", None, True, [], {}, [[1, 2]], {"a": 1}]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.text(max_size=12),
    st.lists(st.floats(allow_nan=False, width=32), max_size=4),
)

MISSION = {
    "name": "fuzz", "vehicle": "x500-sprayer", "tank_fill_l": 0.5, "max_duration_s": 1.0, "record_rate_hz": 10,
    "phases": [{"type": "takeoff", "altitude_agl_m": 1.0},
               {"type": "spray", "rows": [[[0.0, 0.0], [3.0, 0.0]]], "height_agl_m": 1.0, "speed_mps": 2.0,
                "flow_lps": 0.01},
               {"type": "land"}],
    "checks": [{"name": "c", "quantity": "pos_enu_z_m", "reduce": "max", "op": "<", "bound": 10.0}],
}
FIELDS = ["name", "vehicle", "tank_fill_l", "payload_kg", "record_rate_hz", "truth", "autopilot", "wind",
          "wind.law", "geofence", "phases", "phases.0", "phases.0.altitude_agl_m", "phases.0.climb_speed_mps",
          "phases.1.rows", "phases.1.height_agl_m", "phases.1.speed_mps", "phases.1.flow_lps", "phases.1.until",
          "phases.2.descent_speed_mps", "checks", "checks.0.quantity", "checks.0.bound", "checks.0.window",
          "checks.0.op", "checks.0.name", "base", "extra_key"]


def _set(data: dict[str, Any], dotted: str, value: Any) -> None:
    """Put ``value`` at ``dotted`` (a.0.b), creating mappings on the way; no-op where the path cannot go."""
    *head, last = dotted.split(".")
    cur: Any = data
    for part in head:
        if isinstance(cur, list) and part.isdigit() and int(part) < len(cur):
            cur = cur[int(part)]
        elif isinstance(cur, dict):
            cur = cur.setdefault(part, {})
        else:
            return
    if isinstance(cur, list) and last.isdigit() and int(last) < len(cur):
        cur[int(last)] = value
    elif isinstance(cur, dict):
        cur[last] = value


def _ok(r: Any) -> None:
    """exit 0, 1 (a check failed) or 2 with one vinecli error line (or the command line's own usage error);
    never 3, never a traceback."""
    assert r.exit_code in (0, 1, 2), r.output
    assert "Traceback" not in r.output and "internal error" not in r.output, r.output
    if r.exit_code == 2 and "Usage:" not in r.stderr:
        lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1 and lines[0].startswith("vinecli: error:"), r.stderr


@pytest.fixture(scope="module")
def work(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("fuzz")


@settings(PROPS, max_examples=30)
@given(fields=st.lists(st.tuples(st.sampled_from(FIELDS), NASTY), min_size=1, max_size=2))
def test_spec_fields(flat_world_dir: Path, work: Path, fields: list[tuple[str, Any]]) -> None:
    data = json.loads(json.dumps(MISSION))
    for dotted, value in fields:
        _set(data, dotted, value)
    if isinstance(data.get("max_duration_s"), (int, float)):
        data["max_duration_s"] = 1.0  # a valid mutation flies one second, not hours
    m = work / "m.yaml"
    m.write_text(yaml.safe_dump(data, allow_unicode=True))
    before = fingerprint(m, flat_world_dir)
    _ok(cli("run", "mission", m, "--world", flat_world_dir, "--out", work / "runs", "--overwrite"))
    assert fingerprint(m, flat_world_dir) == before


@settings(PROPS, max_examples=20)
@given(seed=st.one_of(st.integers(-(2**66), 2**66), st.sampled_from(["x", "1e3", "nan"])),
       rate=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from(["x", "0", "-5"])),
       run_id=st.one_of(st.none(), st.text(max_size=10), st.sampled_from(["../x", "/tmp/x", "a\x1bb", ".", "-r"])))
def test_cli_options(flat_world_dir: Path, work: Path, seed: Any, rate: Any, run_id: str | None) -> None:
    m = work / "opt.yaml"
    m.write_text(yaml.safe_dump({**MISSION, "name": "opt", "checks": []}))
    args = ["run", "mission", m, "--world", flat_world_dir, "--out", work / "optruns", "--overwrite",
            "--seed", str(seed), "--rate", str(rate)] + (["--run-id", run_id] if run_id is not None else [])
    before = fingerprint(m, flat_world_dir)
    _ok(cli(*args))
    assert fingerprint(m, flat_world_dir) == before
    assert not (work.parent / "x").exists()


def _mutate_json(doc: Any, path: list[str | int], value: Any) -> Any:
    if not path:
        return value
    if isinstance(doc, dict) and path[0] in doc:
        return {**doc, path[0]: _mutate_json(doc[path[0]], path[1:], value)}
    return doc


WORLD_KEYS = [["schema"], ["name"], ["origin"], ["origin", "alt"], ["terrain"], ["terrain", "kind"],
              ["terrain", "bounds_enu"], ["terrain", "files"], ["terrain", "grid"], ["vehicle"], ["vehicle", "urdf"],
              ["vehicle", "spec"], ["spawn"], ["spawn", "enu"], ["wind"], ["vine_rows_enu"], ["geofence"],
              ["physics_rate_hz"], ["gravity_mps2"]]


@settings(PROPS, max_examples=30)
@given(key=st.sampled_from(WORLD_KEYS), value=NASTY, cut=st.one_of(st.none(), st.integers(0, 400)))
def test_world_json_contents(flat_world_dir: Path, work: Path, key: list[str], value: Any, cut: int | None) -> None:
    world = work / "world"
    if not world.exists():
        shutil.copytree(flat_world_dir, world)
    doc = json.loads((flat_world_dir / "world.json").read_text())
    text = json.dumps(_mutate_json(doc, key, value))
    (world / "world.json").write_text(text[:cut] if cut is not None else text)
    before = fingerprint(world)
    _ok(cli("plan", "rows", world, "--out", work / "rows.plan", "--overwrite", "--detect"))
    assert fingerprint(world) == before


@settings(PROPS, max_examples=20)
@given(data=st.binary(max_size=64), where=st.floats(0.0, 1.0), flip=st.booleans())
def test_geotiff_contents(work: Path, data: bytes, where: float, flip: bool) -> None:
    src = (TEST_DATA / "pysheds_dem_3arcsec_epsg4326_int16.tif").read_bytes()
    i = int(where * len(src))
    bad = src[:i] + bytes(b ^ 0xFF for b in data) + src[i + len(data):] if flip else src[:i]
    tif = work / "bad.tif"
    tif.write_bytes(bad)
    before = fingerprint(tif)
    _ok(cli("terrain", "info", tif))
    _ok(cli("terrain", "convert", tif, "--to", "heightmap", "--size", "33", "--out", work / "hm", "--overwrite"))
    assert fingerprint(tif) == before


@settings(PROPS, max_examples=30)
@given(text=st.one_of(st.text(max_size=200), st.binary(max_size=200).map(lambda b: b.decode("latin-1")),
                      st.sampled_from(["a: &a [x, x]\nb: &b [*a, *a]\nc: [*b, *b]\n", "base: /etc/passwd\n",
                                       "name: x\nbase: ../../../../etc/shadow\nphases: []\n", "- 1\n- 2\n",
                                       "name: [1]\nphases: {a: 1}\n", "!!python/object:os.system 'ls'\n"])))
def test_yaml_contents(flat_world_dir: Path, work: Path, text: str) -> None:
    m = work / "y.yaml"
    m.write_text(text, encoding="utf-8", errors="surrogateescape")
    before = fingerprint(m)
    _ok(cli("run", "mission", m, "--world", flat_world_dir, "--out", work / "yruns"))
    assert fingerprint(m) == before


#: numbers for command-line options: non-finite, huge, zero, negative, tiny, and a few ordinary ones
NUMBER = st.one_of(st.sampled_from(["nan", "inf", "-inf", "1e308", "-1e308", "0", "-1", "1e-300", "x", ""]),
                   st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6).map(repr))


@settings(PROPS, max_examples=12)
@given(height=NUMBER, speed=NUMBER, crosswind=NUMBER, cv=NUMBER, band=NUMBER)
def test_plan_swath_options(work: Path, height: str, speed: str, crosswind: str, cv: str, band: str) -> None:
    """``plan swath``: any option value ends in exit 0 or 2 with one line, never 3 or a hang (a 10 km height
    and a 100 m/s crosswind take seconds)."""
    _ok(cli("plan", "swath", "--out", work / "swath", "--overwrite", "--height", height, "--speed", speed,
            "--crosswind", crosswind, "--cv-limit", cv, "--band", band))


@settings(PROPS, max_examples=15)
@given(height=NUMBER, speed=NUMBER, flow=NUMBER, spacing=st.one_of(st.none(), NUMBER), tank=st.one_of(st.none(), NUMBER),
       takeoff=NUMBER)
def test_plan_rows_options(work: Path, rows_world: Path, height: str, speed: str, flow: str, spacing: str | None,
                           tank: str | None, takeoff: str) -> None:
    """``plan rows`` on a built world with two rows: any option value ends in exit 0 or 2, the world stays
    byte-identical."""
    world = rows_world
    before = fingerprint(world)
    args = ["plan", "rows", world, "--out", work / "p.plan", "--overwrite", "--height", height, "--speed", speed,
            "--flow", flow, "--takeoff", takeoff]
    args += ["--spacing", spacing] if spacing is not None else []
    args += ["--tank", tank] if tank is not None else []
    _ok(cli(*args))
    assert fingerprint(world) == before
