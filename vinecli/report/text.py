"""Text from run directories (names, messages, errors: anything a user or a run wrote) made safe per format.

Control characters become visible ``\\xNN`` escapes everywhere (XML 1.0 cannot hold most of them, a
terminal escape has no business in a report); Markdown additionally gets ``&``, ``<`` and ``>`` as
entities (raw HTML in summary.md is rendered by many viewers) and ``|`` escaped (table cells).
HTML goes through Jinja's autoescaping plus :func:`printable`.
"""

from __future__ import annotations

import re
from typing import Any

_TAG_RE = re.compile(r"<(?=[A-Za-z/!?])")
_AMP_RE = re.compile(r"&(?=[A-Za-z#])")
# C0 controls but tab/newline/carriage return, DEL, C1 controls, surrogates and the XML non-characters
_CONTROL_RE = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f\ud800-\udfff\ufffe\uffff]")


def printable(value: Any) -> str:
    """``str(value)`` with control characters replaced by ``\\xNN`` (``\\uNNNN``) escapes."""
    return _CONTROL_RE.sub(lambda m: f"\\x{ord(m.group()):02x}" if ord(m.group()) < 0x100
                           else f"\\u{ord(m.group()):04x}", str(value))


def md_text(value: Any) -> str:
    """Text for a Markdown table cell or line: printable, one line, no raw HTML, ``|`` escaped.

    A ``<`` that could open a tag, comment or autolink (followed by a letter, ``/``, ``!`` or ``?``) and
    an ``&`` that could start an entity become entities; ``<= 0.1`` stays readable.
    """
    s = _AMP_RE.sub("&amp;", printable(value))
    s = _TAG_RE.sub("&lt;", s)
    return s.replace("|", "\\|").replace("\r", " ").replace("\n", " ")


def format_value(v: Any) -> str:
    """A check or metric value for people: floats to 4 significant digits, lists element-wise, None as ``-``."""
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(format_value(x) for x in v) + "]"
    return "-" if v is None else str(v)
