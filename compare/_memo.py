"""A small cache keyed by the identity of an object (analytic solutions are not hashable).

The report's figures need the same analytic states, surface curves and load cycles as the
metrics of the case (``compare.stress``, ``compare.report``); solving them once saves about a
third of the per-case report time.  The cache holds a strong reference to each key object, so
an ``id`` is never reused while its entry lives; the oldest entries go first.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import TypeVar

T = TypeVar("T")
#: Entries kept (a few cases' worth: one per analytic state, surface window and cycle).
MEMO_SIZE = 64
_MEMO: dict[tuple[int, Hashable], tuple[object, object]] = {}


def memo(owner: object, tag: Hashable, make: Callable[[], T]) -> T:
    """``make()`` computed once per (``owner`` object, ``tag``)."""
    key = (id(owner), tag)
    hit = _MEMO.get(key)
    if hit is not None and hit[0] is owner:
        return hit[1]  # type: ignore[return-value]
    value = make()
    while len(_MEMO) >= MEMO_SIZE:
        _MEMO.pop(next(iter(_MEMO)))
    _MEMO[key] = (owner, value)
    return value
