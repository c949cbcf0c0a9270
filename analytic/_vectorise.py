"""Numpy's calling convention for the vectorised methods of the results.

A method ``f(self, x)`` decorated with :func:`elementwise` is written for a 1-D float array and
then accepts what numpy's ufuncs accept: a scalar gives a scalar (``np.float64``), an array of
any shape gives an array of that shape (``NormalSolution.pressure(0.5)`` is a number, not a
1-element array).
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np


def elementwise(method: Callable[..., np.ndarray]) -> Callable[..., np.ndarray | np.float64]:
    """Wrap a method of a 1-D array ``x``: scalar in, scalar out; shape in, same shape out."""

    @functools.wraps(method)
    def wrapper(self, x, *args, **kwargs):
        arr = np.asarray(x, dtype=float)
        out = np.asarray(method(self, arr.reshape(-1), *args, **kwargs)).reshape(arr.shape)
        return out[()]

    return wrapper
