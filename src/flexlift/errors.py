"""The one exception type for bad user input.

Library code raises :class:`InputError` (a ``ValueError``) whenever a value supplied by the
user cannot be used; its message is one line naming the field, the value and what is allowed.
The CLI turns it into that line on stderr and exit code 2.
"""

from __future__ import annotations


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
