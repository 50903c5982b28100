"""``vinecli px4 doctor``: can vinecli and PX4 SITL find each other?

Checks (each ``ok`` / ``warn`` / ``fail`` with a one-line detail):

* the PX4 binary (``--px4-bin``): exists, is executable, has the SITL ``etc/`` tree next to it
  (``build/px4_sitl_default/{bin/px4, etc/init.d-posix/rcS}``); without ``--px4-bin``: ``px4`` on PATH;
* TCP 4560+i is free for vinecli to listen on (PX4 connects to it);
* UDP 14540+i is free for vinecli's mission link (PX4's API link sends there);
* a running PX4 instance answers on its API port UDP 14580+i (we send a GCS HEARTBEAT, PX4
  replies to the sender) -- only once PX4 gets sensor data, i.e. while a simulator runs;

and the exact command that starts PX4 SITL against vinecli.
"""

from __future__ import annotations

import os
import shutil
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path

from vinecli.errors import InputError
from vinecli.sitl.options import PX4_DEFAULT_INSTANCE, PX4_DEFAULTS, PX4_PROBE_TIMEOUT_S
from vinecli.sitl.process import port_free
from vinecli.sitl.px4.backend import API_PORT_BASE, PX4_API_LOCAL_BASE, SIM_PORT_BASE
from vinecli.sitl.px4.process import px4_start_command


@dataclass
class Check:
    name: str
    status: str  # "ok" | "warn" | "fail"
    detail: str


@dataclass
class DoctorReport:
    instance: int
    host: str
    checks: list[Check] = field(default_factory=list)
    start_command: str = ""
    px4_running: bool = False

    @property
    def ok(self) -> bool:
        return all(c.status != "fail" for c in self.checks)


def probe_px4(host: str, port: int, timeout_s: float, sysid: int) -> str | None:
    """Send a GCS HEARTBEAT to PX4's API port; PX4's first HEARTBEAT back (as 'autopilot N, sysid S') or None."""
    from vinecli.mavlink import px4modes as M
    from vinecli.mavlink.link import UdpLink

    link = UdpLink((host, 0), (host, port), reply_to_sender=False, src_system=255, src_component=190)
    try:
        deadline = time.monotonic() + timeout_s
        next_hb = 0.0
        while time.monotonic() < deadline:
            if time.monotonic() >= next_hb:
                link.send(link.mav.heartbeat_encode(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, M.MAV_STATE_ACTIVE))
                next_hb = time.monotonic() + 0.5
            m = link.recv(0.1)
            if m is not None and m.get_type() == "HEARTBEAT" and m.get_srcComponent() == 1:
                return f"autopilot {m.autopilot}, system {m.get_srcSystem()}"
        return None
    finally:
        link.close()


def px4_doctor(px4_bin: str | Path | None = None, *, instance: int = PX4_DEFAULT_INSTANCE,
               host: str = PX4_DEFAULTS.px4_host, probe_timeout_s: float = PX4_PROBE_TIMEOUT_S) -> DoctorReport:
    """Run the checks (see the module docstring). InputError for a bad instance number."""
    if not 0 <= instance <= 99:
        raise InputError(f"--instance {instance}: expected 0..99")
    rep = DoctorReport(instance=instance, host=host)
    add = rep.checks.append
    bin_for_cmd = "px4"
    if px4_bin is not None:
        p = Path(px4_bin).expanduser()
        bin_for_cmd = str(p.resolve()) if p.exists() else str(p)
        if not p.is_file():
            add(Check("PX4 binary", "fail", f"{p}: not found"))
        elif not os.access(p, os.X_OK):
            add(Check("PX4 binary", "fail", f"{p}: not executable (chmod +x)"))
        else:
            add(Check("PX4 binary", "ok", str(p.resolve())))
            rcs = p.resolve().parent.parent / "etc" / "init.d-posix" / "rcS"
            if rcs.is_file():
                add(Check("PX4 SITL startup files", "ok", str(rcs.parent.parent)))
            else:
                add(Check("PX4 SITL startup files", "warn",
                          f"{rcs} missing: give the SITL etc/ directory on the command line (build/px4_sitl_default/etc)"))
    else:
        found = shutil.which("px4")
        if found:
            bin_for_cmd = found
            add(Check("PX4 binary", "ok", f"{found} (on PATH)"))
        else:
            add(Check("PX4 binary", "warn", "no --px4-bin given and no px4 on PATH (fine if PX4 runs elsewhere)"))
    sim_port = SIM_PORT_BASE + instance
    free, why = port_free(sim_port, socket.SOCK_STREAM, host)
    add(Check(f"TCP {host}:{sim_port} (simulator)", "ok" if free else "fail",
              "free for vinecli to listen on" if free else f"in use ({why}): another simulator or vinecli run holds it"))
    api_port = API_PORT_BASE + instance if instance <= 9 else 14549
    free, why = port_free(api_port, socket.SOCK_DGRAM, host)
    add(Check(f"UDP {host}:{api_port} (mission link)", "ok" if free else "warn",
              "free for vinecli's mission client" if free else f"in use ({why}): MAVSDK/MAVROS or another run listens there"))
    px4_port = PX4_API_LOCAL_BASE + instance
    found_px4 = probe_px4(host, px4_port, probe_timeout_s, instance + 1)
    rep.px4_running = found_px4 is not None
    add(Check(f"PX4 on UDP {host}:{px4_port}", "ok" if found_px4 else "warn",
              f"running PX4 answered ({found_px4})" if found_px4 else
              "no PX4 answered (not started, or still waiting for a simulator on TCP "
              f"{sim_port}: its MAVLink links start once sensor data flows)"))
    rep.start_command = px4_start_command(instance, host, bin_for_cmd)
    return rep
