"""One validation layer for the public arguments of :mod:`analytic` (type, finiteness, range).

Every check returns the converted value (a Python ``float`` / ``int`` / ``str`` / 1-D float
array) or raises :class:`~analytic.errors.InputError` with one message of the form
``"<name>=<value> is not allowed: need <what is allowed>"``.  Numbers may be Python or numpy
scalars, 0-d arrays or 1-element sequences; ``bool``, ``None``, strings and complex values are
refused.  Non-finite values never pass, so they never reach the solver.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable

import numpy as np

from analytic.errors import InputError


def refuse(name: str, value: object, need: str) -> InputError:
    """The one error message: the parameter, its value and what is allowed."""
    return InputError(f"{name}={_show(value)} is not allowed: need {need}")


def _show(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _as_real(value: object) -> float | None:
    """The float of a real scalar, 0-d array or 1-element sequence; None if it is not one."""
    if isinstance(value, (bool, np.bool_, str, bytes)) or value is None:
        return None
    if isinstance(value, numbers.Real):
        return float(value)
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):
        return None
    if arr.size != 1 or arr.dtype.kind not in "iuf":
        return None
    return float(arr.reshape(()))


def real(name: str, value: object, need: str = "a finite number",
         test: Callable[[float], bool] | None = None) -> float:
    """A finite real number that passes ``test`` (``need`` says what is allowed)."""
    x = _as_real(value)
    if x is None or not math.isfinite(x) or (test is not None and not test(x)):
        raise refuse(name, value, need)
    return x


def positive(name: str, value: object, what: str = "") -> float:
    """A finite number > 0."""
    return real(name, value, f"a finite {what + ' ' if what else ''}value > 0", lambda v: v > 0)


AP_RANGE = (1e-150, 1e150)
"""Allowed ``A P`` (a length, the indentation's scale): the solver multiplies and divides it by
lengths of its own size (zone widths ~ sqrt(A P R), the edges' span), which stay normal doubles
here; beyond, A P = 1e-300 * 1e-300 underflowed to 0 (a raw ZeroDivisionError) and a cylinder's
residuals overflowed at A P = 1e160."""


def load_scale(A: float, P: float) -> float:
    """``A P`` of a checked compliance and load, refused outside AP_RANGE."""
    ap = A * P
    lo, hi = AP_RANGE
    if not lo <= ap <= hi:
        raise refuse("A*P", ap, f"{lo:g} <= A*P <= {hi:g} (got A={A!r}, P={P!r}; A P, a "
                     "length, is the indentation's scale)")
    return ap


def non_negative(name: str, value: object) -> float:
    """A finite number >= 0."""
    return real(name, value, "a finite value >= 0", lambda v: v >= 0)


def optional_real(name: str, value: object, need: str = "a finite number or None") -> float | None:
    """None, or a finite number."""
    return None if value is None else real(name, value, need)


def angle(name: str, value: object) -> float:
    """An angle in radians strictly between 0 and pi/2."""
    return real(name, value, "an angle in radians with 0 < angle < pi/2",
                lambda v: 0.0 < v < math.pi / 2)


def integer(name: str, value: object, low: int) -> int:
    """An integer (or integral float) >= ``low``."""
    x = _as_real(value)
    if x is None or not math.isfinite(x) or x != int(x) or x < low:
        raise refuse(name, value, f"an integer >= {low}")
    return int(x)


def flag(name: str, value: object) -> bool:
    """A boolean."""
    if not isinstance(value, (bool, np.bool_)):
        raise refuse(name, value, "True or False")
    return bool(value)


def choice(name: str, value: object, allowed: tuple[str, ...]) -> str:
    """One of the allowed strings."""
    if not isinstance(value, str) or value not in allowed:
        raise refuse(name, value, "one of " + ", ".join(repr(a) for a in allowed))
    return value


def vector(name: str, value: object, min_size: int = 1,
           test: Callable[[np.ndarray], bool] | None = None, need: str = "") -> np.ndarray:
    """A 1-D array of at least ``min_size`` finite real numbers (a scalar counts as one)."""
    need = need or f"a 1-D sequence of at least {min_size} finite numbers"
    arr = _numbers(name, value, need)
    if arr.ndim > 1:
        raise refuse(name, value, need)
    arr = arr.reshape(-1)
    if arr.size < min_size or not np.all(np.isfinite(arr)) or (test is not None and not test(arr)):
        raise refuse(name, value, need)
    return arr


def array(name: str, value: object, need: str = "finite real numbers (a number or an array)"
          ) -> np.ndarray:
    """A float array of any shape (a scalar counts as 0-d) of finite real numbers."""
    arr = _numbers(name, value, need)
    if not np.all(np.isfinite(arr)):
        raise refuse(name, value, need)
    return arr


def _numbers(name: str, value: object, need: str) -> np.ndarray:
    """``value`` as a float array of any shape if it holds real numbers, else the refusal."""
    if isinstance(value, (str, bytes)) or value is None:
        raise refuse(name, value, need)
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):
        raise refuse(name, value, need) from None
    if arr.dtype.kind not in "iuf":
        raise refuse(name, value, need)
    return arr.astype(float)


def instance(name: str, value: object, cls: type, what: str) -> object:
    """An instance of ``cls`` (``what`` names the expected type for the message)."""
    if not isinstance(value, cls):
        raise refuse(name, value, f"{what} (got a {type(value).__name__})")
    return value
