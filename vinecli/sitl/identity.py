"""Which firmware flew a run: name, version and git hash as the firmware reports them (MAVLink
AUTOPILOT_VERSION), and the sha256 of the binary vinecli started. Written to summary.json ``firmware``."""

from __future__ import annotations

import hashlib
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

#: FIRMWARE_VERSION_TYPE (the low byte of flight_sw_version)
_VERSION_TYPE = {0: "dev", 64: "alpha", 128: "beta", 192: "rc", 255: ""}
_sha_cache: dict[tuple[str, int, int], str] = {}


@dataclass
class FirmwareIdentity:
    """The firmware of one run (None where it was not reported)."""

    firmware: str  # "PX4", "ArduCopter"
    version: str | None = None  # "4.7.0-dev", "1.15.4"
    git_hash: str | None = None  # as the firmware reports it (ArduPilot 8 hex digits, PX4 16)
    binary: str | None = None  # the executable vinecli started
    sha256: str | None = None  # of that executable

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def binary_sha256(path: str | Path) -> str:
    """sha256 of a file (cached per path, size and modification time: a batch hashes its binary once)."""
    p = Path(path).resolve()
    st = p.stat()
    key = (str(p), st.st_size, st.st_mtime_ns)
    if key not in _sha_cache:
        h = hashlib.sha256()
        with p.open("rb") as f:
            for chunk in iter(lambda: f.read(1 << 20), b""):
                h.update(chunk)
        _sha_cache[key] = h.hexdigest()
    return _sha_cache[key]


def decode_version(flight_sw_version: int) -> str:
    """``major.minor.patch[-type]`` from AUTOPILOT_VERSION.flight_sw_version."""
    v = int(flight_sw_version)
    kind = _VERSION_TYPE.get(v & 0xFF, f"type{v & 0xFF}")
    base = f"{(v >> 24) & 0xFF}.{(v >> 16) & 0xFF}.{(v >> 8) & 0xFF}"
    return f"{base}-{kind}" if kind else base


def decode_git_hash(custom: Any) -> str | None:
    """The git hash in AUTOPILOT_VERSION.flight_custom_version: ArduPilot puts the short hash's ASCII
    characters there, PX4 the hash as a little-endian 64-bit number (a short 8-digit hash in its high half)."""
    raw = bytes(int(b) & 0xFF for b in custom)
    if not any(raw):
        return None
    text = raw.split(b"\x00", 1)[0]
    if text and all(chr(c) in "0123456789abcdefABCDEF" for c in text):
        return text.decode().lower()
    value = raw[::-1].hex()
    return value[:8] if value.endswith("00000000") else value  # PX4: a short hash in the high 32 bits


def identity_from_message(firmware: str, msg: Any, binary: str | os.PathLike[str] | None) -> FirmwareIdentity:
    """A :class:`FirmwareIdentity` from an AUTOPILOT_VERSION message (or None: only the binary's hash)."""
    ident = FirmwareIdentity(firmware)
    if msg is not None:
        ident.version = decode_version(msg.flight_sw_version)
        ident.git_hash = decode_git_hash(msg.flight_custom_version)
    if binary is not None:
        ident.binary = str(Path(binary).resolve())
        ident.sha256 = binary_sha256(Path(binary))
    return ident


__all__ = ["FirmwareIdentity", "binary_sha256", "decode_git_hash", "decode_version", "identity_from_message"]
