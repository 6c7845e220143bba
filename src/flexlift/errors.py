"""The one exception type for bad user input.

Library code raises :class:`InputError` (a ``ValueError``) whenever a value supplied by the
user cannot be used; its message is one line naming the field, the value and what is allowed.
The CLI turns it into that line on stderr and exit code 2.
"""

from __future__ import annotations

import re
import reprlib


class InputError(ValueError):
    """Bad user input: the message names the field, the value and what is allowed."""

    def __init__(self, field: str, value, allowed: str):
        self.field = field
        self.value = value
        self.allowed = allowed
        super().__init__(f"{field}: got {value!r}; {allowed}")

    @classmethod
    def from_line(cls, line: str) -> InputError:
        """An error whose whole message is already composed (e.g. from a validator)."""
        err = cls.__new__(cls)
        err.field, err.value, err.allowed = "", None, line
        ValueError.__init__(err, line)
        return err


class SimulationError(RuntimeError):
    """The numerics failed (NaN, solver failure); partial results are attached."""

    def __init__(self, message: str, partial=None):
        super().__init__(message)
        self.partial = partial


# ---------------------------------------------------------------------- one-line messages
#: longest echo of a user's value in a message [characters]
ECHO_LIMIT = 80
#: longest whole message line the CLI prints [characters]
LINE_LIMIT = 400

_UNSAFE = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029\u200b-\u200f\u202a-\u202e\u2066-\u2069\ufeff]")


def _escape_char(m: re.Match) -> str:
    c = m.group()
    return {"\n": "\\n", "\r": "\\r", "\t": "\\t"}.get(c) or (
        f"\\x{ord(c):02x}" if ord(c) < 0x100 else f"\\u{ord(c):04x}")


def clean(text: str, limit: int | None = ECHO_LIMIT) -> str:
    """``text`` on one line: control, line-break and direction-changing characters escaped
    (``\\n``, ``\\x1b``, ``\\u2028``), cut to ``limit`` characters with ``...`` in the middle."""
    if limit is not None and len(text) > 4 * limit:  # escaping at most quadruples a character
        text = text[: 2 * limit] + text[-2 * limit :]
    text = _UNSAFE.sub(_escape_char, text)
    if limit is not None and len(text) > limit:
        head = (limit - 3) * 2 // 3
        text = text[:head] + "..." + text[len(text) - (limit - 3 - head) :]
    return text


class _Brief(reprlib.Repr):
    def __init__(self, limit: int):
        super().__init__()
        self.maxlevel = 3
        self.maxstring = self.maxother = limit
        self.maxlist = self.maxtuple = self.maxset = self.maxfrozenset = self.maxdict = 6
        self.maxlong = 40

    def repr_int(self, x, level):
        if x.bit_length() > 160:  # never convert a huge integer to text (slow, or refused)
            return f"<an integer of about {int(x.bit_length() * 0.30103) + 1} digits>"
        return super().repr_int(x, level)

    def repr_str(self, x, level):
        return repr(x[: 2 * self.maxstring]) if len(x) > 2 * self.maxstring else repr(x)


def brief(value, limit: int = ECHO_LIMIT) -> str:
    """A short one-line ``repr`` of any value, for messages: at most ``limit`` characters,
    never expanding a huge (or self-referencing) structure to find out."""
    try:
        text = _Brief(limit).repr(value)
    except Exception:  # a value whose repr fails: name its type only
        text = f"<{type(value).__name__}>"
    return clean(text, limit)
