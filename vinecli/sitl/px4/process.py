"""Start and stop a PX4 SITL process for one run (``--px4-bin``): one process, one instance.

PX4 v1.15 ``px4_sitl_default`` serves ONE simulator connection per process, so every run gets
a fresh process with a fresh working directory (parameters from defaults). The instance number
is reserved under a lock file (:func:`vinecli.sitl.process.reserve_instance`) and only taken
when PX4's TCP and UDP ports for it are free. Command (PX4's own README)::

    PX4_SIM_MODEL=none_iris <bin>/px4 -d -i N -w WORKDIR <bin>/../etc

The run's PX4 parameters (the vehicle's ``px4.params`` and the mission's) are set at boot through
a ``px4-rc.params`` that PX4's ``rcS`` sources from ``PATH`` (:func:`boot_params_script`).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from pathlib import Path

from vinecli.errors import AutopilotError, InputError
from vinecli.sitl.process import InstanceLock, die_with_parent, port_free
from vinecli.sitl.process import reserve_instance as reserve_firmware_instance

SIM_PORT_BASE = 4560
#: UDP ports PX4 binds for instance i (GCS, API/offboard, payload, gimbal links)
PX4_UDP_BASES = (18570, 14580, 14280, 13030)


def etc_dir_for(px4_bin: Path) -> Path:
    """The SITL ``etc`` directory of a PX4 binary (``.../bin/px4`` -> ``.../etc``); InputError if missing."""
    etc = px4_bin.resolve().parent.parent / "etc"
    if not (etc / "init.d-posix" / "rcS").is_file():
        raise InputError(f"--px4-bin {px4_bin}: no SITL start-up files at {etc}/init.d-posix/rcS "
                         "(expected the build/px4_sitl_default/{bin,etc} layout)")
    return etc


def _px4_ports_free(i: int) -> bool:
    return port_free(SIM_PORT_BASE + i, socket.SOCK_STREAM)[0] and all(
        port_free(b + i, socket.SOCK_DGRAM)[0] for b in PX4_UDP_BASES)


def reserve_instance() -> InstanceLock:
    """Lock the first PX4 instance (10-99) whose lock file is free and whose PX4 ports are unused."""
    return reserve_firmware_instance("PX4", _px4_ports_free)


def boot_params_script(params: dict[str, int | float]) -> str:
    """``px4-rc.params`` setting ``params`` at boot ('' for none); InputError for a bad name or value.

    PX4 v1.15 has no ``PX4_PARAM_*`` environment, and some parameters only act from boot
    (``EKF2_HGT_REF`` is reboot-required; an output function set over MAVLink just before arming
    was picked up too late), so a PX4 that vinecli starts gets them in its start-up script.
    """
    import math
    import re

    lines = []
    for name, value in params.items():
        if not re.fullmatch(r"[A-Z][A-Z0-9_]{0,15}", name):
            raise InputError(f"PX4 parameter name {name!r}: expected up to 16 of A-Z, 0-9, _")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputError(f"PX4 parameter {name}: value {value!r} is not a finite number")
        lines.append(f"param set {name} {value if isinstance(value, int) else repr(float(value))}")
    return "#!/bin/sh\n# written by vinecli: this run's parameters\n" + "\n".join(lines) + "\n" if lines else ""


class Px4Process:
    """One PX4 SITL daemon: :meth:`start`, :meth:`alive`, :meth:`log_tail`, :meth:`stop`.

    ``workdir`` None: a fresh temporary directory, deleted by :meth:`stop` (the log is read first).
    """

    def __init__(self, px4_bin: str | Path, instance: int, *, workdir: str | Path | None = None,
                 airframe: str = "none_iris", sim_host: str = "127.0.0.1",
                 params: dict[str, int | float] | None = None) -> None:
        self.bin = Path(px4_bin).expanduser()
        if not self.bin.is_file() or not os.access(self.bin, os.X_OK):
            raise InputError(f"--px4-bin {px4_bin}: not an executable file")
        self.etc = etc_dir_for(self.bin)
        self.instance, self.airframe, self.sim_host = instance, airframe, sim_host
        self._own_dir = workdir is None
        self.workdir = Path(workdir) if workdir is not None else Path(tempfile.mkdtemp(prefix=f"vinecli-px4-{instance}-"))
        self.log_path = self.workdir / "px4.log"
        self.params = boot_params_script(params or {})  # validated now, before anything starts
        self.proc: subprocess.Popen[bytes] | None = None
        self.returncode: int | None = None
        self._log_text = ""

    def command(self) -> list[str]:
        """argv of the PX4 daemon (the environment adds PX4_SIM_MODEL)."""
        return [str(self.bin.resolve()), "-d", "-i", str(self.instance), "-w", str(self.workdir / "rootfs"), str(self.etc)]

    def start(self) -> None:
        """Start PX4 in its own process group; it connects to TCP sim_host:4560+instance."""
        (self.workdir / "rootfs").mkdir(parents=True, exist_ok=True)
        env = dict(os.environ, PX4_SIM_MODEL=self.airframe)
        if self.params:  # rcS sources px4-rc.params from PATH before EKF2 and the outputs start
            rc = self.workdir / "rc"
            rc.mkdir(exist_ok=True)
            (rc / "px4-rc.params").write_text(self.params, encoding="utf-8")
            env["PATH"] = f"{rc}{os.pathsep}{env.get('PATH', '')}"
        if self.sim_host not in ("127.0.0.1", "localhost"):
            env["PX4_SIM_HOST_ADDR"] = self.sim_host
        with self.log_path.open("wb") as log:
            try:
                self.proc = subprocess.Popen(self.command(), cwd=self.workdir / "rootfs", env=env, stdin=subprocess.DEVNULL,
                                             stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
                                             preexec_fn=die_with_parent if os.name == "posix" else None)
            except OSError as exc:
                raise AutopilotError(f"cannot start PX4 {self.bin}: {exc.strerror or exc}") from None

    def alive(self) -> bool:
        """True while the process runs."""
        return self.proc is not None and self.proc.poll() is None

    def log_tail(self, lines: int = 12) -> str:
        """The last lines PX4 printed (for error messages)."""
        text = self._log_text
        if not text and self.log_path.is_file():
            text = self.log_path.read_text(errors="replace")
        return "\n".join(text.splitlines()[-lines:])

    def stop(self, timeout_s: float = 5.0) -> int | None:
        """SIGTERM the process group, SIGKILL after ``timeout_s``; remove a temporary workdir. Idempotent."""
        p = self.proc
        if p is not None and self.returncode is None:
            for sig, wait in ((signal.SIGTERM, timeout_s), (signal.SIGKILL, 5.0)):
                if p.poll() is not None:
                    break
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(p.pid, sig)
                deadline = time.monotonic() + wait
                while p.poll() is None and time.monotonic() < deadline:
                    time.sleep(0.02)
            self.returncode = p.poll()
        if self.log_path.is_file():
            self._log_text = self.log_path.read_text(errors="replace")
        if self._own_dir and self.workdir.exists():
            shutil.rmtree(self.workdir, ignore_errors=True)
        return self.returncode


__all__ = ["Px4Process", "boot_params_script", "etc_dir_for", "reserve_instance"]
