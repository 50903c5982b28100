"""One factory for the autopilot of a run, covering the PX4 and MAVLink options of
``vinecli run mission`` (``--autopilot px4 [--px4-bin PATH] --px4-instance N --px4-host H
--px4-connect-timeout S --px4-lockstep-timeout S``, ``--mavlink URL [--mavlink-port P] [--realtime]
[--mavlink-allow-remote]``)."""

from __future__ import annotations

from typing import Any

from vinecli.autopilot.base import Autopilot
from vinecli.errors import InputError


def make_run_autopilot(
    name: str,
    *,
    truth: bool | None = None,
    mavlink: str | None = None,
    realtime: bool = False,
    mavlink_allow_remote: bool = False,
    px4_instance: int | None = None,
    px4_host: str = "127.0.0.1",
    px4_connect_timeout_s: float = 30.0,
    px4_step_timeout_s: float = 1.0,
    px4_allow_remote: bool = False,
    px4_bin: str | None = None,
    mavlink_local_port: int | None = None,
) -> Autopilot:
    """The backend for one run.

    * ``mavlink`` set: the built-in autopilot behind a MAVLink vehicle endpoint
      (:class:`vinecli.autopilot.mavlink_vehicle.MavlinkControlledAutopilot`), lockstep or ``realtime``;
    * ``name == "px4"``: :class:`vinecli.autopilot.px4_sitl.Px4SitlAutopilot` on TCP
      ``px4_host:4560+px4_instance``; with ``px4_bin`` vinecli starts PX4 itself (on a free
      instance unless ``px4_instance`` is given) and stops it after the run;
    * otherwise ``vinecli.autopilot.registry.make_autopilot(name)`` (``truth`` for the builtin).
    """
    if mavlink is not None:
        if name != "builtin":
            raise InputError(f"--mavlink serves the built-in autopilot; with --autopilot {name} connect your "
                             "ground station to that autopilot directly (PX4: UDP 14550 / 14540+i)")
        from vinecli.autopilot.mavlink_vehicle import serve_mavlink

        return serve_mavlink(mavlink, realtime=realtime, allow_remote=mavlink_allow_remote, truth=truth,  # type: ignore[return-value]
                             local_port=mavlink_local_port)
    if realtime:
        raise InputError("--realtime applies to --mavlink runs (PX4 runs pace themselves in lockstep)")
    if name == "px4":
        from vinecli.autopilot.px4_sitl import Px4SitlAutopilot

        if px4_instance is None and px4_bin is None:
            px4_instance = 0  # an external PX4 started by hand: instance 0 unless told
        return Px4SitlAutopilot(host=px4_host, instance=px4_instance, connect_timeout_s=px4_connect_timeout_s,  # type: ignore[return-value]
                                step_timeout_s=px4_step_timeout_s, allow_remote=px4_allow_remote, px4_bin=px4_bin)
    if px4_bin is not None:
        raise InputError(f"--px4-bin needs --autopilot px4 (this run uses {name!r})")
    from vinecli.autopilot.registry import make_autopilot

    opts: dict[str, Any] = {"truth": truth} if name == "builtin" and truth is not None else {}
    return make_autopilot(name, **opts)
