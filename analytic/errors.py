"""The two exceptions the analytic solver raises.

``InputError`` (a ``ValueError``): the input itself is wrong; the message names the bad value and
what is allowed (``TableEndError``, one kind of it: the contact would leave a tabulated
profile's table).  ``ConvergenceError`` (a ``RuntimeError``): the input is valid but no admissible
solution was found; ``diagnostics`` holds the residuals and the last iterate.
"""

from __future__ import annotations

from typing import Any


class InputError(ValueError):
    """Bad input: the message names the offending value and the allowed range."""


class TableEndError(InputError):
    """The contact would reach the end of a tabulated profile's table, where h0 is unknown
    (extend the table).  A moment search treats it at a trial rotation as a failed solve."""


class ConvergenceError(RuntimeError):
    """No admissible solution was found; never a silent answer."""

    def __init__(self, message: str, diagnostics: dict[str, Any] | None = None) -> None:
        super().__init__(message)
        self.diagnostics = dict(diagnostics or {})
