"""ArduPilot's JSON SITL protocol, physics side (ArduPilot ``libraries/SITL/SIM_JSON.cpp``).

ArduPilot (``--model JSON:127.0.0.1``) sends each servo frame over UDP to ``9002 + 10 * instance``:
``<HHI16H`` = magic 18458, frame rate (Hz), frame count, 16 PWM values in µs (magic 29569 and 32 PWM
with ``SERVO_32_ENABLE``). It then blocks until the physics answers, to the sender's address, with one
line of compact JSON (ArduPilot's parser skips exactly ``"key":``, so no spaces after colons)::

    {"timestamp":s,"imu":{"gyro":[p,q,r],"accel_body":[ax,ay,az]},"position":[n,e,d],
     "velocity":[vn,ve,vd],"quaternion":[w,x,y,z]}

gyro rad/s and accel_body (specific force, m/s²) in body FRD, position m NED from the ``--home`` point,
velocity m/s NED, quaternion body FRD -> NED. A frame not answered within ~1 s of wall time is sent
again with the same count; ArduPilot's time advances only by the answers, so one answer per count is
one lockstep step.

**Time stamps.** ArduPilot adds ``(timestamp - previous) * 1e6`` to an integer µs clock, truncating.
A difference of exactly ``dt`` in decimal seconds is often 3999.9999999 µs after parsing, which
truncates to 3999 and drifts the firmware's clock by a frame now and then (its main loop then runs
two physics steps at once: "Main loop slow"). The stamps sent are ``k * (dt_us + 0.5) µs``: every
difference truncates to exactly ``dt_us``, so the firmware's clock is the simulation's clock.
"""

from __future__ import annotations

import math
import socket
import struct
import time
from dataclasses import dataclass

from vinecli.errors import AutopilotError

SERVO_MAGIC_16 = 18458
SERVO_MAGIC_32 = 29569
JSON_PORT_BASE = 9002
_HEADER = struct.Struct("<HHI")


@dataclass(frozen=True, slots=True)
class ServoFrame:
    """One servo frame of ArduPilot: its frame rate (Hz), count and PWM outputs (µs, channel 1 first)."""

    rate_hz: int
    count: int
    pwm: tuple[int, ...]


def parse_servo_frame(data: bytes) -> ServoFrame | None:
    """A servo frame from a UDP datagram; None for anything else (wrong magic or length)."""
    if len(data) < _HEADER.size:
        return None
    magic, rate, count = _HEADER.unpack_from(data)
    n = 16 if magic == SERVO_MAGIC_16 else 32 if magic == SERVO_MAGIC_32 else 0
    if n == 0 or len(data) < _HEADER.size + 2 * n:
        return None
    return ServoFrame(rate, count, struct.unpack_from(f"<{n}H", data, _HEADER.size))


def timestamp_s(step: int, dt_us: int) -> float:
    """The JSON time stamp of answer number ``step`` (1, 2, ...): see the module docstring."""
    return step * (2 * dt_us + 1) / 2e6


def _vec(v: tuple[float, ...]) -> str:
    for x in v:
        if not math.isfinite(x):
            raise AutopilotError(f"ArduPilot JSON state: non-finite value in {v}")
    return "[" + ",".join(repr(float(x)) for x in v) + "]"


def state_line(t_s: float, gyro_frd: tuple[float, float, float], accel_frd: tuple[float, float, float],
               pos_ned: tuple[float, float, float], vel_ned: tuple[float, float, float],
               quat_wxyz: tuple[float, float, float, float]) -> bytes:
    """One answer: the JSON line (framed by newlines) for the state after a physics step."""
    return (f'\n{{"timestamp":{t_s!r},"imu":{{"gyro":{_vec(gyro_frd)},"accel_body":{_vec(accel_frd)}}},'
            f'"position":{_vec(pos_ned)},"velocity":{_vec(vel_ned)},"quaternion":{_vec(quat_wxyz)}}}\n').encode()


class JsonPhysicsLink:
    """The UDP socket ArduPilot sends its servo frames to (``host:port``); answers go to the sender."""

    def __init__(self, host: str, port: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.sock.bind((host, port))
        except OSError as exc:
            self.sock.close()
            raise AutopilotError(f"cannot bind UDP {host}:{port} for ArduPilot's servo frames: "
                                 f"{exc.strerror or exc}") from None
        self.port = port
        self.peer: tuple[str, int] | None = None
        self.frames = 0  # valid frames received (resent ones included)
        self.garbage = 0  # datagrams that were not servo frames

    def recv_frame(self, timeout_s: float) -> ServoFrame | None:
        """The next servo frame (None after ``timeout_s`` of wall time without one, however many datagrams that
        are not servo frames arrive meanwhile: they are counted in :attr:`garbage` and skipped)."""
        deadline = time.monotonic() + timeout_s
        while True:
            self.sock.settimeout(max(1e-3, deadline - time.monotonic()))
            try:
                data, addr = self.sock.recvfrom(512)
            except TimeoutError:
                return None
            frame = parse_servo_frame(data)
            if frame is not None:
                self.peer = addr
                self.frames += 1
                return frame
            self.garbage += 1
            if time.monotonic() >= deadline:
                return None

    def answer(self, line: bytes) -> None:
        """Send one JSON line to the firmware that sent the last frame."""
        if self.peer is None:
            raise AutopilotError("ArduPilot JSON link: an answer before any servo frame")
        self.sock.sendto(line, self.peer)

    def close(self) -> None:
        self.sock.close()


__all__ = ["JSON_PORT_BASE", "JsonPhysicsLink", "ServoFrame", "parse_servo_frame", "state_line", "timestamp_s"]
