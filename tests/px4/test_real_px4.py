"""Against a real PX4 SITL binary: only collected when ``PX4_SITL_BIN`` is set (see conftest.py,
which deselects ``@pytest.mark.px4`` tests otherwise).

``PX4_SITL_BIN`` = ``.../PX4-Autopilot/build/px4_sitl_default/bin/px4``. The test starts PX4 with
the command ``vinecli px4 doctor`` prints (airframe none_iris, instance 7, its own working
directory), flies takeoff - hover - land through Px4SitlAutopilot, and stops the PX4 process it
started.
"""

from __future__ import annotations

import os
import shlex
import subprocess
from pathlib import Path

import pytest

from vinecli.autopilot.base import RunStatus
from vinecli.autopilot.px4_sitl import Px4SitlAutopilot, px4_start_command
from vinecli.sim.runner import run_simulation
from vinecli.specs.mission import MissionSpec

INSTANCE = 7


@pytest.mark.px4
@pytest.mark.timeout(600)
def test_real_px4_takeoff_hover_land(world, tmp_path: Path):
    px4_bin = os.environ["PX4_SITL_BIN"]
    cmd = px4_start_command(INSTANCE, px4_bin=px4_bin, workdir=str(tmp_path / "px4"))
    parts = shlex.split(cmd)
    env = dict(os.environ)
    while "=" in parts[0]:
        k, v = parts.pop(0).split("=", 1)
        env[k] = v
    (tmp_path / "px4").mkdir()
    ap = Px4SitlAutopilot(instance=INSTANCE, connect_timeout_s=60, step_timeout_s=0.5, max_stalls=200,
                          boot_timeout_s=120, health_timeout_s=180)
    log = (tmp_path / "px4.log").open("w")
    proc = subprocess.Popen(parts, cwd=tmp_path / "px4", env=env, stdin=subprocess.DEVNULL, stdout=log,
                            stderr=subprocess.STDOUT)
    mission = MissionSpec.model_validate({
        "name": "real-px4-hover", "autopilot": "px4", "max_duration_s": 240.0,
        "phases": [{"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "hold", "duration_s": 5.0}, {"type": "land"}]})
    try:
        res = run_simulation(world, mission, ap, seed=1)
    finally:
        ap.close()
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)
        log.close()
    text = (tmp_path / "px4.log").read_text(errors="replace")
    assert res.status is RunStatus.COMPLETED, (res.status, res.detail, text[-2000:])
    z = res.timeseries["pos_enu_z_m"] - world.spawn_enu[2]
    assert 2.3 < z.max() < 4.0 and abs(z[-1]) < 0.2
    assert ap.lockstep_steps > 1000
    assert "Simulator connected" in text or "simulator" in text.lower()
