"""Start and stop an ArduCopter SITL process for one run (``--ardupilot-bin``): one process, one instance.

Command (ArduPilot's SITL, JSON physics backend)::

    arducopter --model JSON:127.0.0.1 --speedup 10000 -I N --serial0 tcp:0 \\
        --defaults <bin>/../defaults/copter.parm,vinecli.parm --home LAT,LON,ALT,YAW --start-time T

in a fresh working directory (ArduPilot writes ``eeprom.bin``, ``logs/`` and ``terrain/`` there). The
run's parameters (:mod:`vinecli.sitl.ardupilot.params`) are the last defaults file, so they win over
ArduPilot's own SITL copter defaults, which the SITL tarball ships beside its ``bin/``. ``--speedup``
only stops ArduPilot from pacing itself to the wall clock: its clock is the physics' time stamps.
``--serial0 tcp:0`` starts without waiting for a ground station; ``--start-time`` fixes the simulated
UTC (GPS week and log names), so two runs of a seed are the same. Instance N takes TCP 5760+10N
(SERIAL0) and 5762/5763+10N, UDP 9002+10N (vinecli's servo-frame socket), 5501+10N (RC in) and
9005+10N; an instance is only reserved when all are free.
"""

from __future__ import annotations

import socket
from pathlib import Path

from vinecli.sitl.ardupilot.json_link import JSON_PORT_BASE
from vinecli.sitl.params import check_params, format_value
from vinecli.sitl.process import FirmwareProcess, InstanceLock, port_free
from vinecli.sitl.process import reserve_instance as reserve_firmware_instance

SERIAL0_PORT_BASE = 5760
_TCP_BASES = (SERIAL0_PORT_BASE, 5762, 5763)
_UDP_BASES = (JSON_PORT_BASE, 5501, 9005)
#: simulated UTC at boot: 2025-07-01T00:00:00Z (ArduPilot's build date era)
START_TIME_S = 1751328000
PARAM_FILE = "vinecli.parm"


def _ports_free(i: int) -> bool:
    return all(port_free(b + 10 * i, socket.SOCK_STREAM)[0] for b in _TCP_BASES) and all(
        port_free(b + 10 * i, socket.SOCK_DGRAM)[0] for b in _UDP_BASES)


def reserve_instance() -> InstanceLock:
    """Lock the first ArduPilot instance (10-99) whose lock file is free and whose ports are unused."""
    return reserve_firmware_instance("ArduPilot", _ports_free)


def param_file_text(params: dict[str, int | float]) -> str:
    """The run's parameters in ArduPilot's ``.parm`` format (``NAME VALUE`` lines); InputError for a bad one."""
    checked = check_params(params, "ArduPilot")
    return "# written by vinecli: this run's ArduCopter parameters\n" + "".join(
        f"{name} {format_value(value)}\n" for name, value in checked.items())


class ArdupilotProcess(FirmwareProcess):
    """One ArduCopter SITL process (:class:`~vinecli.sitl.process.FirmwareProcess`) on the JSON backend."""

    firmware = "ArduPilot"
    option = "--ardupilot-bin"
    log_name = "ardupilot.log"

    def __init__(self, binary: str | Path, instance: int, *, home: tuple[float, float, float, float],
                 params: dict[str, int | float], workdir: str | Path | None = None, sim_host: str = "127.0.0.1") -> None:
        text = param_file_text(params)  # validated before anything is created
        super().__init__(binary, instance, workdir=workdir)
        self.home, self.sim_host, self.param_text = home, sim_host, text
        ship = self.bin.resolve().parent.parent / "defaults" / "copter.parm"
        self.defaults = [ship] if ship.is_file() else []

    @property
    def param_path(self) -> Path:
        return self.workdir / PARAM_FILE

    def command(self) -> list[str]:
        lat, lon, alt, yaw = self.home
        defaults = ",".join(str(p) for p in [*self.defaults, self.param_path])
        return [str(self.bin.resolve()), "--model", f"JSON:{self.sim_host}", "--speedup", "10000",
                "-I", str(self.instance), "--serial0", "tcp:0", "--defaults", defaults,
                "--home", f"{lat:.7f},{lon:.7f},{alt:.3f},{yaw:.2f}", "--start-time", str(START_TIME_S)]

    def prepare(self) -> None:
        self.param_path.write_text(self.param_text, encoding="utf-8")


__all__ = ["PARAM_FILE", "SERIAL0_PORT_BASE", "ArdupilotProcess", "param_file_text", "reserve_instance"]
