"""Firmware parameters of a run: validated once, written as a file into the run, read back from the firmware.

Both firmwares take a run's parameters at boot (PX4: a ``px4-rc.params`` script its ``rcS`` sources;
ArduPilot: a ``--defaults`` parameter file). :class:`ParamReadback` then asks the running firmware for
every one (PARAM_REQUEST_READ -> PARAM_VALUE), stepped in simulated time like the rest of the
conversation, and fails the run naming each parameter the firmware does not know or holds at another
value: the file in the run folder is what the firmware flew with, proven.
"""

from __future__ import annotations

import math
import re
import struct
from collections.abc import Mapping
from typing import Any

from vinecli.errors import AutopilotError, AutopilotTimeout, InputError
from vinecli.sitl.polled_link import param_name

ParamValue = int | float
_NAME = re.compile(r"[A-Z][A-Z0-9_]{0,15}")


def check_params(params: Mapping[str, Any], firmware: str) -> dict[str, ParamValue]:
    """``params`` as a plain dict; InputError for a name that is not up to 16 of A-Z, 0-9, _ or a value
    that is not a finite number."""
    out: dict[str, ParamValue] = {}
    for name, value in params.items():
        if not _NAME.fullmatch(str(name)):
            raise InputError(f"{firmware} parameter name {name!r}: expected up to 16 of A-Z, 0-9, _")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputError(f"{firmware} parameter {name}: value {value!r} is not a finite number")
        out[str(name)] = value
    return out


def format_value(value: ParamValue) -> str:
    """A parameter value as the files write it (integers bare, floats with every digit)."""
    return str(value) if isinstance(value, int) else repr(float(value))


def float32(x: float) -> float:
    """``x`` rounded to single precision (MAVLink carries parameter values as float32)."""
    return float(struct.unpack("<f", struct.pack("<f", float(x)))[0])


class ParamReadback:
    """Reads every parameter of ``expected`` back from the firmware, ``batch`` requests at a time.

    Feed it every message (:meth:`on_message`) and the simulated time (:meth:`tick`); ``done`` once all
    matched, AutopilotError naming the mismatches, AutopilotTimeout naming the silent ones after
    ``timeout_us``. ``decode(msg)`` turns a PARAM_VALUE into the number (ArduPilot sends every type as a
    float; PX4 sends integers bit-cast into the float field)."""

    def __init__(self, expected: Mapping[str, ParamValue], target_system: int, *, firmware: str,
                 decode: Any = None, batch: int = 8, resend_us: int = 1_000_000, timeout_us: int = 30_000_000) -> None:
        self.expected = dict(expected)
        self.target = target_system
        self.firmware = firmware
        self.decode = decode or (lambda m: float(m.param_value))
        self.batch, self.resend_us, self.timeout_us = batch, resend_us, timeout_us
        self.read: dict[str, float] = {}
        self.wrong: dict[str, float] = {}
        self._pending: list[str] = list(self.expected)
        self._asked: dict[str, int] = {}
        self._t0: int | None = None

    @property
    def done(self) -> bool:
        return len(self.read) == len(self.expected)

    def on_message(self, m: Any) -> None:
        if m.get_type() != "PARAM_VALUE" or m.get_srcSystem() != self.target:
            return
        name = param_name(m)
        if name not in self.expected or name in self.read:
            return
        got = self.decode(m)
        want = self.expected[name]
        self._asked.pop(name, None)
        if float32(got) != float32(want) and not math.isclose(got, want, rel_tol=1e-6, abs_tol=1e-6):
            self.wrong[name] = got
            raise AutopilotError(f"{self.firmware} did not take parameter {name} = {format_value(want)}: "
                                 f"it reads {got:g}")
        self.read[name] = got

    def tick(self, link: Any, t_us: int) -> None:
        """Ask for the next parameters, again for those unanswered after ``resend_us``."""
        if self.done:
            return
        if self._t0 is None:
            self._t0 = t_us
        if t_us - self._t0 > self.timeout_us:
            silent = sorted(set(self.expected) - set(self.read))
            raise AutopilotTimeout(f"{self.firmware} did not answer for parameter(s) {', '.join(silent[:8])}"
                                   f"{' ...' if len(silent) > 8 else ''} (unknown to this firmware build?)")
        for name, t in list(self._asked.items()):
            if t_us - t >= self.resend_us:
                self._request(link, name, t_us)
        while self._pending and len(self._asked) < self.batch:
            self._request(link, self._pending.pop(0), t_us)

    def _request(self, link: Any, name: str, t_us: int) -> None:
        self._asked[name] = t_us
        link.send(link.mav.param_request_read_encode(self.target, 1, name.encode(), -1))


__all__ = ["ParamReadback", "ParamValue", "check_params", "float32", "format_value"]
