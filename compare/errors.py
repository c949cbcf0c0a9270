"""Errors raised by :mod:`compare`.

``CaseError`` (a ``ValueError``) is bad input: a case file or a case argument is wrong; the
message names the bad key / value and what is allowed.  The CLI maps it to exit code 2.
``SweepError`` (a ``CaseError``) is bad sweep input (``compare.sweep``).
"""

from __future__ import annotations


class CaseError(ValueError):
    """Bad case input: the message names the offending key or value and the allowed ones."""


class SweepError(CaseError):
    """Bad sweep input (a :class:`CaseError`, so the CLI maps it to exit code 2)."""
