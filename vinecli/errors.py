"""One error hierarchy for the whole library.

Every error the library raises on purpose is a :class:`VinecliError`. Each class carries
the process exit code the CLI maps it to (see :mod:`vinecli.cli.console`):

* 1 - the run finished but a check failed (:class:`ChecksFailed`)
* 2 - bad input or usage (:class:`InputError` and subclasses)
* 3 - runtime failure (:class:`RuntimeFailure` and subclasses)
* 128 + N - stopped by signal N (:class:`Interrupted`: 130 SIGINT, 143 SIGTERM)

Messages are one line and name the file (or endpoint) and the problem.
"""

from __future__ import annotations

import math
from pathlib import Path


class VinecliError(Exception):
    """Root of every error vinecli raises on purpose."""

    exit_code: int = 3

    def __init__(self, message: str, *, path: str | Path | None = None) -> None:
        self.path = str(path) if path is not None else None
        self.problem = message
        super().__init__(f"{self.path}: {message}" if self.path else message)


class InputError(VinecliError, ValueError):
    """Bad input: unreadable or invalid file, bad option value (exit 2)."""

    exit_code = 2


class SpecError(InputError):
    """A YAML/JSON spec that does not validate; the message names file and field."""


def check_range(option: str, value: float, lo: float, hi: float, *, open_lo: bool = False, why: str = "") -> None:
    """SpecError (exit 2, one line naming ``option``) for a ``value`` that is not finite or outside [lo, hi] ((lo, hi]
    with ``open_lo``); ``why`` says where the bound comes from."""
    if not math.isfinite(value) or value > hi or value < lo or (open_lo and value == lo):
        raise SpecError(f"{option} {value:g}: use {'more than' if open_lo else 'at least'} {lo:g} and at most {hi:g}"
                        + (f" ({why})" if why else ""))


class TerrainError(InputError):
    """A raster or point cloud that cannot be turned into terrain."""


class OutputError(InputError):
    """The output location cannot be written (exists, not writable...)."""


class RuntimeFailure(VinecliError, RuntimeError):
    """Something failed while running (engine, network peer...) (exit 3)."""

    exit_code = 3


class AutopilotError(RuntimeFailure):
    """The autopilot backend failed (PX4 unreachable, refused to arm...)."""


class AutopilotTimeout(AutopilotError, TimeoutError):
    """The autopilot backend did not answer in time."""


class FirmwareUnreachable(AutopilotTimeout):
    """No firmware answered where the user said one runs (an external PX4 never started): a set-up problem of the
    command, exit 2, and no run is written (a firmware vinecli starts itself that fails is an error run, exit 3)."""

    exit_code = 2


class ChecksFailed(VinecliError):
    """The work finished but at least one check failed (exit 1)."""

    exit_code = 1


class Interrupted(VinecliError):
    """The work was stopped by a signal; exit code 128 + the signal number (130 SIGINT, 143 SIGTERM)."""

    exit_code = 130

    def __init__(self, message: str, *, path: str | Path | None = None, signum: int = 2) -> None:
        super().__init__(message, path=path)
        self.exit_code = 128 + signum
