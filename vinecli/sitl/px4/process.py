"""Start and stop a PX4 SITL process for one run (``--px4-bin``): one process, one instance.

PX4 v1.15 ``px4_sitl_default`` serves ONE simulator connection per process, so every run gets
a fresh process with a fresh working directory (parameters from defaults). The instance number
is reserved under a lock file (:func:`vinecli.sitl.process.reserve_instance`) and only taken
when PX4's TCP and UDP ports for it are free. Command (PX4's own README)::

    PX4_SIM_MODEL=none_iris <bin>/px4 -d -i N -w WORKDIR <bin>/../etc

The run's PX4 parameters (the vehicle's ``px4.params`` and the mission's) are set at boot through
a ``px4-rc.params`` that PX4's ``rcS`` sources from ``PATH`` (:func:`boot_params_script`), after
:data:`SAFE_BOOT_PARAMS` (which a run's own value overrides).
"""

from __future__ import annotations

import os
import shlex
import socket
from pathlib import Path

from vinecli.errors import InputError
from vinecli.sitl.params import check_params, format_value
from vinecli.sitl.process import FirmwareProcess, InstanceLock, port_free
from vinecli.sitl.process import reserve_instance as reserve_firmware_instance

SIM_PORT_BASE = 4560
#: UDP ports PX4 binds for instance i (GCS, API/offboard, payload, gimbal links)
PX4_UDP_BASES = (18570, 14580, 14280, 13030)
#: parameters every PX4 that vinecli starts boots with. ``IMU_GYRO_CAL_EN = 0``: PX4 v1.15's ``gyro_calibration``
#: (rcS starts it when the parameter is 1, the default) re-arms its own periodic timer from its work item at
#: each arming (``ScheduleOnInterval(10_s)``), while the HRT thread may still be between that timer's callout
#: and re-taking its lock in ``hrt_call_invoke`` (platforms/posix drv_hrt.cpp); the entry is then queued twice,
#: the callout list is cut after it, and the purely periodic work items behind it never run again:
#: ``battery_simulator`` (battery_status stops, and 5 s later "Preflight Fail: Battery unhealthy" and a failsafe)
#: and ``load_mon`` (cpuload stops). Measured: BENCHMARKS.md "PX4's periodic work". The module only calibrates after
#: 10 s at rest disarmed; vinecli arms at ~4 s, so it never calibrated anything in a vinecli run.
SAFE_BOOT_PARAMS: dict[str, int | float] = {"IMU_GYRO_CAL_EN": 0}


#: parameters a PX4 started by hand needs against vinecli: no data-link or RC-loss failsafe, and the boot-safe ones
HAND_START_PARAMS: dict[str, int | float] = {"NAV_DLL_ACT": 0, "COM_RC_IN_MODE": 1, **SAFE_BOOT_PARAMS}


def px4_start_command(instance: int = 0, host: str = "127.0.0.1", px4_bin: str = "px4", airframe: str = "none_iris",
                      workdir: str | None = None) -> str:
    """The shell command that starts PX4 SITL against vinecli (daemon mode): it writes :data:`HAND_START_PARAMS` into
    a ``px4-rc.params`` that PX4's ``rcS`` sources from ``PATH`` at boot (PX4 v1.15 ignores ``PX4_PARAM_*``)."""
    bin_path = px4_bin
    etc = "build/px4_sitl_default/etc"
    if os.sep in px4_bin and os.path.basename(os.path.dirname(os.path.abspath(px4_bin))) == "bin":
        build = os.path.dirname(os.path.dirname(os.path.abspath(px4_bin)))  # build/px4_sitl_default/{bin,etc}
        etc = os.path.join(build, "etc")
    wd = workdir or f"/tmp/px4-sitl-{instance}"
    rc = shlex.quote(f"{wd}/rc")
    lines = " ".join(shlex.quote(line) for line in _param_set_lines(HAND_START_PARAMS))
    env = [f"PATH={rc}:$PATH", f"PX4_SIM_MODEL={airframe}"]
    if host not in ("127.0.0.1", "localhost"):
        env.append(f"PX4_SIM_HOST_ADDR={host}")
    return (f"mkdir -p {rc} && printf '%s\\n' {lines} > {rc}/px4-rc.params && "
            + " ".join([*env, shlex.quote(bin_path), "-d", "-i", str(instance), "-w", shlex.quote(f"{wd}/rootfs"),
                        shlex.quote(etc)]))


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


def _param_set_lines(params: dict[str, int | float]) -> list[str]:
    """PX4 shell lines setting ``params`` (``param set NAME VALUE``); InputError for a bad name or value."""
    return [f"param set {name} {format_value(value)}" for name, value in check_params(params, "PX4").items()]


def boot_params_script(params: dict[str, int | float]) -> str:
    """``px4-rc.params`` setting ``params`` at boot ('' for none); InputError for a bad name or value.

    PX4 v1.15 has no ``PX4_PARAM_*`` environment, and some parameters only act from boot
    (``EKF2_HGT_REF`` is reboot-required; an output function set over MAVLink just before arming
    was picked up too late), so a PX4 that vinecli starts gets them in its start-up script.
    """
    lines = _param_set_lines(params)
    return "#!/bin/sh\n# written by vinecli: this run's parameters\n" + "\n".join(lines) + "\n" if lines else ""


class Px4Process(FirmwareProcess):
    """One PX4 SITL daemon (:class:`~vinecli.sitl.process.FirmwareProcess`), the run's parameters at boot."""

    firmware = "PX4"
    option = "--px4-bin"
    log_name = "px4.log"

    def __init__(self, px4_bin: str | Path, instance: int, *, workdir: str | Path | None = None,
                 airframe: str = "none_iris", sim_host: str = "127.0.0.1",
                 params: dict[str, int | float] | None = None) -> None:
        params_script = boot_params_script({**SAFE_BOOT_PARAMS, **(params or {})})  # validated before anything exists
        super().__init__(px4_bin, instance, workdir=workdir)
        self.airframe, self.sim_host = airframe, sim_host
        self.params = params_script

    def check(self) -> None:
        """A PX4 binary needs its SITL ``etc/`` beside its ``bin/`` (InputError before any folder is made)."""
        self.etc = etc_dir_for(self.bin)

    @property
    def cwd(self) -> Path:
        return self.workdir / "rootfs"

    def command(self) -> list[str]:
        """argv of the PX4 daemon (the environment adds PX4_SIM_MODEL)."""
        return [str(self.bin.resolve()), "-d", "-i", str(self.instance), "-w", str(self.cwd), str(self.etc)]

    def environment(self) -> dict[str, str]:
        env = dict(os.environ, PX4_SIM_MODEL=self.airframe)
        if self.params:  # rcS sources px4-rc.params from PATH before EKF2 and the outputs start
            env["PATH"] = f"{self.workdir / 'rc'}{os.pathsep}{env.get('PATH', '')}"
        if self.sim_host not in ("127.0.0.1", "localhost"):
            env["PX4_SIM_HOST_ADDR"] = self.sim_host
        return env

    def prepare(self) -> None:
        if self.params:
            rc = self.workdir / "rc"
            rc.mkdir(exist_ok=True)
            (rc / "px4-rc.params").write_text(self.params, encoding="utf-8")


__all__ = ["HAND_START_PARAMS", "SAFE_BOOT_PARAMS", "Px4Process", "boot_params_script", "etc_dir_for", "px4_start_command", "reserve_instance"]
