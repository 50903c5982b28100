"""Names that become file or directory names: run ids, case, mission, pipeline, vehicle and world names.

One rule everywhere (specs through :data:`SafeName`, ``--run-id`` and derived case names through
:func:`check_name`): 1 to :data:`MAX_NAME_LEN` characters from ``A-Z a-z 0-9 . _ + -``, starting
with a letter, digit or ``_``, and no ``..``. So a name can never be a path (``/``, ``..``, an
absolute path), a hidden file, an option (``-x``) or carry a control character into a report.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated

from pydantic import AfterValidator

from vinecli.errors import InputError

MAX_NAME_LEN = 120
_NAME_RE = re.compile(r"[A-Za-z0-9_][A-Za-z0-9._+-]*")


def name_problem(name: object) -> str | None:
    """Why ``name`` is not a safe name, or None if it is."""
    if not isinstance(name, str):
        return f"must be a string, got {type(name).__name__}"
    if not name:
        return "must not be empty"
    if len(name) > MAX_NAME_LEN:
        return f"is longer than {MAX_NAME_LEN} characters"
    if not _NAME_RE.fullmatch(name) or ".." in name:
        return (f"{name!r} is not a safe name (letters, digits, '.', '_', '+', '-'; starting with a letter, "
                f"digit or '_'; no '..', '/' or control characters)")
    return None


def check_name(name: str, what: str = "name", *, path: str | Path | None = None) -> str:
    """``name`` if it is safe; InputError (exit 2) ``what: problem`` naming ``path`` otherwise."""
    problem = name_problem(name)
    if problem is not None:
        raise InputError(f"{what} {problem}", path=path)
    return name


def name_from(text: str, fallback: str = "mission") -> str:
    """A safe name derived from free text (a file stem): unsafe runs of characters become ``_``; ``fallback``
    if nothing usable is left."""
    s = re.sub(r"[^A-Za-z0-9._+-]+", "_", text)
    s = re.sub(r"\.{2,}", ".", s).lstrip(".+-")[:MAX_NAME_LEN]
    return s if name_problem(s) is None else fallback


def _validate(name: str) -> str:
    problem = name_problem(name)
    if problem is not None:
        raise ValueError(problem)
    return name


#: a pydantic string field holding a safe name (validation error names the field)
SafeName = Annotated[str, AfterValidator(_validate)]
