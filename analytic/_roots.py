"""Scalar root bracketing: Brent's method.

The analytic side finds a few hundred bracketed scalar roots per case (touch points, rotation
searches, profile crossings).  ``scipy.optimize.brentq`` would do, but importing
``scipy.optimize`` loads every SciPy optimiser with it: 13.6 MB of resident memory and ~0.1 s
for one function, in every process that solves a case (issue 28 counts the peak memory of the
whole FE comparison run).  This module is Brent's method in the form of Forsythe, Malcolm and
Moler's ``zeroin``, with SciPy's tolerance convention and errors.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable

#: Default absolute and relative x tolerances and iteration cap (those of scipy.optimize.brentq).
XTOL, RTOL, MAXITER = 2e-12, 4 * sys.float_info.epsilon, 100


def brentq(f: Callable[[float], float], a: float, b: float, *, xtol: float = XTOL,
           rtol: float = RTOL, maxiter: int = MAXITER) -> float:
    """A root of ``f`` in ``[a, b]`` where ``f(a)`` and ``f(b)`` differ in sign.

    Brent's method (R. P. Brent, *Algorithms for Minimization without Derivatives*, 1973,
    ch. 4; G. E. Forsythe, M. A. Malcolm, C. B. Moler, *Computer Methods for Mathematical
    Computations*, 1977, ``zeroin``): inverse quadratic interpolation or the secant step when
    it stays well inside the bracket and shrinks it fast enough, bisection otherwise.  The
    bracket always holds a sign change; the result ``x`` is within ``xtol + rtol |x|`` of it
    (the convention of ``scipy.optimize.brentq``).

    Raises ValueError when f(a) and f(b) have the same sign, when f is NaN at a point it is
    evaluated, or for xtol <= 0 / rtol < 4 eps; RuntimeError after ``maxiter`` iterations.
    """
    if not xtol > 0:
        raise ValueError(f"xtol={xtol!r}: must be > 0")
    if not rtol >= RTOL:
        raise ValueError(f"rtol={rtol!r}: must be >= 4 eps = {RTOL!r}")
    fa, fb = _value(f, a), _value(f, b)
    if fa == 0.0:
        return a
    if fb == 0.0:
        return b
    if (fa > 0) == (fb > 0):
        raise ValueError(f"f(a) and f(b) must have different signs: f({a!r}) = {fa!r}, "
                         f"f({b!r}) = {fb!r}")
    c, fc = a, fa  # c: the end of the bracket [b, c] opposite the best estimate b
    d = e = b - a  # the last step and the one before
    for _ in range(maxiter):
        if (fb > 0) == (fc > 0):  # the sign change moved: the bracket is [a, b]
            c, fc = a, fa
            d = e = b - a
        if abs(fc) < abs(fb):  # b the best estimate
            a, b, c = b, c, b
            fa, fb, fc = fb, fc, fb
        tol = 0.5 * (xtol + rtol * abs(b))
        m = 0.5 * (c - b)
        if abs(m) <= tol or fb == 0.0:
            return b
        d, e = _step(a, b, c, fa, fb, fc, d, e, m, tol)
        a, fa = b, fb
        b += d if abs(d) > tol else math.copysign(tol, m)
        fb = _value(f, b)
    raise RuntimeError(f"brentq: no convergence in {maxiter} iterations (bracket [{b!r}, "
                       f"{c!r}], f = {fb!r}, {fc!r})")


def _step(a: float, b: float, c: float, fa: float, fb: float, fc: float, d: float, e: float,
          m: float, tol: float) -> tuple[float, float]:
    """(new step, the step before it): interpolation when the last steps shrank the bracket
    and it lands well inside, else bisection (``m`` = half the bracket from b)."""
    if abs(e) < tol or abs(fa) <= abs(fb):
        return m, m
    s = fb / fa
    if a == c:  # secant
        p, q = 2.0 * m * s, 1.0 - s
    else:  # inverse quadratic interpolation through a, b, c
        q, r = fa / fc, fb / fc
        p = s * (2.0 * m * q * (q - r) - (b - a) * (r - 1.0))
        q = (q - 1.0) * (r - 1.0) * (s - 1.0)
    if p > 0:
        q = -q
    else:
        p = -p
    if 2.0 * p < min(3.0 * m * q - abs(tol * q), abs(e * q)):
        return p / q, d
    return m, m


def _value(f: Callable[[float], float], x: float) -> float:
    v = float(f(x))
    if math.isnan(v):
        raise ValueError(f"the function value at x={x!r} is NaN; the root search cannot go on")
    return v
