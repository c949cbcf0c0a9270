"""The two exceptions the analytic solver raises.

``InputError`` (a ``ValueError``): the input itself is wrong; the message names the bad value and
what is allowed.  ``ConvergenceError`` (a ``RuntimeError``): the input is valid but no admissible
solution was found; ``diagnostics`` holds the residuals and the last iterate.
"""

from __future__ import annotations

from typing import Any


class InputError(ValueError):
    """Bad input: the message names the offending value and the allowed range."""


class ConvergenceError(RuntimeError):
    """No admissible solution was found; never a silent answer."""

    def __init__(self, message: str, diagnostics: dict[str, Any] | None = None) -> None:
        super().__init__(message)
        self.diagnostics = dict(diagnostics or {})
