"""The autopilot options of ``vinecli run mission`` (``--autopilot px4 [--px4-bin PATH]
--px4-instance N --px4-host H --px4-connect-timeout S --px4-lockstep-timeout S``, ``--autopilot ardupilot
--ardupilot-bin PATH``, ``--mavlink URL [--mavlink-port P] [--realtime] [--mavlink-allow-remote]``) with
their defaults (:class:`AutopilotOptions`, declared once here; ``vinecli px4 doctor`` shares the host and
instance), and one factory for the autopilot of a run (:func:`make_run_autopilot`). Light to import: the
command line reads the defaults from here."""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vinecli.errors import InputError
from vinecli.inputs import note_input

if TYPE_CHECKING:
    from vinecli.autopilot.base import Autopilot


@dataclass(frozen=True)
class AutopilotOptions:
    """The PX4/MAVLink options of one run; the field defaults are the options' defaults."""

    px4_instance: int | None = None  # PX4 SITL instance (px4 -i N); None: 0, or a free one with px4_bin
    px4_bin: str | None = None  # PX4 SITL binary: vinecli starts (and stops) PX4 for the run
    px4_step_timeout_s: float | None = None  # None: each step waits for PX4's answer (lockstep); s: then a stall
    mavlink_local_port: int | None = None  # vinecli's own UDP port with udp:/udpout: (None: 14580)
    px4_host: str = "127.0.0.1"  # address to listen on for PX4 (loopback)
    px4_connect_timeout_s: float = 30.0  # seconds to wait for PX4
    mavlink: str | None = None  # serve the built-in autopilot over MAVLink at this URL
    realtime: bool = False  # with mavlink: pace the run at wall-clock speed
    mavlink_allow_remote: bool = False  # allow a non-loopback mavlink address
    px4_allow_remote: bool = False  # allow a non-loopback px4_host
    ardupilot_bin: str | None = None  # ArduCopter SITL binary: vinecli starts (and stops) ArduPilot for the run

    def changed(self) -> dict[str, Any]:
        """Only the options that differ from their defaults (what a run's manifest.json records)."""
        return {f.name: getattr(self, f.name) for f in fields(self) if getattr(self, f.name) != f.default}


#: the defaults of every option
PX4_DEFAULTS = AutopilotOptions()
#: the PX4 instance an external PX4 started by hand runs as (``px4 -i 0``)
PX4_DEFAULT_INSTANCE = 0
#: seconds ``vinecli px4 doctor`` waits for a running PX4 to answer
PX4_PROBE_TIMEOUT_S = 2.0


def firmware_binary(path: Path | None, option: str = "--px4-bin", firmware: str = "PX4") -> str | None:
    """A firmware binary option as an absolute path (None stays None); InputError when it is not a file."""
    if path is None:
        return None
    if not path.is_file():
        raise InputError(f"{firmware} binary not found ({option})", path=path)
    note_input(path, f"{firmware} binary")  # no output may be, contain or lie inside it
    return str(path.resolve())


def px4_binary(path: Path | None) -> str | None:
    """``--px4-bin`` as an absolute path (None stays None); InputError when it is not a file."""
    return firmware_binary(path)


def make_run_autopilot(name: str, options: AutopilotOptions = PX4_DEFAULTS) -> Autopilot:
    """The backend ``name`` of one run, with its ``options``.

    * ``mavlink`` set: the built-in autopilot behind a MAVLink vehicle endpoint
      (:class:`vinecli.autopilot.mavlink_vehicle.MavlinkControlledAutopilot`), lockstep or ``realtime``;
    * ``name == "px4"``: :class:`vinecli.sitl.px4.backend.Px4SitlAutopilot` on TCP
      ``px4_host:4560+px4_instance``; with ``px4_bin`` vinecli starts PX4 itself (on a free
      instance unless ``px4_instance`` is given) and stops it after the run;
    * ``name == "ardupilot"``: :class:`vinecli.sitl.ardupilot.backend.ArdupilotSitlAutopilot`, which starts
      ArduCopter SITL (``ardupilot_bin``) on a free instance and stops it after the run;
    * otherwise ``vinecli.autopilot.registry.make_autopilot(name)``.

    Ground-truth runs (the mission's ``truth``) need no option here: the simulator hands the
    backend its perfect estimator in the context.
    """
    o = options
    if o.mavlink is not None:
        if name != "builtin":
            raise InputError(f"--mavlink serves the built-in autopilot; with --autopilot {name} connect your "
                             "ground station to that autopilot directly (PX4: UDP 14550 / 14540+i)")
        from vinecli.autopilot.mavlink_vehicle import serve_mavlink

        return serve_mavlink(o.mavlink, realtime=o.realtime, allow_remote=o.mavlink_allow_remote,  # type: ignore[return-value]
                             local_port=o.mavlink_local_port)
    if o.realtime:
        raise InputError("--realtime applies to --mavlink runs (PX4 runs pace themselves in lockstep)")
    if name == "px4":
        from vinecli.sitl.px4.backend import Px4SitlAutopilot

        instance = o.px4_instance
        if instance is None and o.px4_bin is None:
            instance = PX4_DEFAULT_INSTANCE  # an external PX4 started by hand: instance 0 unless told
        return Px4SitlAutopilot(host=o.px4_host, instance=instance, connect_timeout_s=o.px4_connect_timeout_s,  # type: ignore[return-value]
                                step_timeout_s=o.px4_step_timeout_s, allow_remote=o.px4_allow_remote, px4_bin=o.px4_bin)
    if name == "ardupilot":
        from vinecli.sitl.ardupilot.backend import ArdupilotSitlAutopilot

        return ArdupilotSitlAutopilot(ardupilot_bin=o.ardupilot_bin)  # type: ignore[return-value]
    if o.px4_bin is not None:
        raise InputError(f"--px4-bin needs --autopilot px4 (this run uses {name!r})")
    if o.ardupilot_bin is not None:
        raise InputError(f"--ardupilot-bin needs --autopilot ardupilot (this run uses {name!r})")
    from vinecli.autopilot.registry import make_autopilot

    return make_autopilot(name)
