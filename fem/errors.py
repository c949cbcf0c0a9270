"""Errors raised by :mod:`fem`.

Every message names the offending value and the allowed range or the remedy.
"""


class InputError(ValueError):
    """A user input (material, load, mesh, settings) is outside its allowed range."""


class ConvergenceError(RuntimeError):
    """The contact iteration did not converge even after step cut-backs.

    The message carries the diagnostics: stage, target load, smallest step tried,
    iteration count and the last residuals / active-set changes.
    """
