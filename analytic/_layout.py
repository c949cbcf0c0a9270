"""The contact topology and the real values of the fundamental function W on the line.

A :class:`Layout` is the edges ``[a1, b1, a2, b2, ...]`` with their singular flags.  With the
exponents ``eps = +1/2`` (nonsingular edge) and ``-1/2`` (singular edge),
``W(z) = prod (z - e_i)^(eps_i)``; on the real line its modulus is :func:`w_abs` and its sign
follows from ``d = #nonsingular - #singular`` edges to the right of x (:func:`sign_exponent`,
:func:`sign_from_d`; on zone k the sign ``s_k`` of ``W_s`` is :func:`zone_signs`, the paper's
``(-1)^(n-k)`` of Eq. 2 when e = 2n).  The equations built on them are in :mod:`analytic._sie`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np


@dataclass(frozen=True)
class Layout:
    """Contact topology: edges ``[a1, b1, a2, b2, ...]`` (absolute x) and singular flags."""

    edges: np.ndarray
    pinned: np.ndarray

    @property
    def n(self) -> int:
        return self.edges.size // 2

    @property
    def e(self) -> int:
        """Number of nonsingular edges."""
        return _edge_flags(self.pinned.tobytes())[0]

    @property
    def eps(self) -> np.ndarray:
        """Exponent of each edge in W: +1/2 nonsingular, -1/2 singular (read-only)."""
        return _edge_flags(self.pinned.tobytes())[1]

    @property
    def free(self) -> np.ndarray:
        """Indices of the nonsingular edges (read-only)."""
        return _edge_flags(self.pinned.tobytes())[2]

    def zones(self) -> list[tuple[float, float]]:
        return [(float(a), float(b)) for a, b in self.edges.reshape(-1, 2)]

    def edge_widths(self) -> np.ndarray:
        """Width of the zone each edge belongs to ``(2n,)``."""
        return np.repeat(np.diff(self.edges.reshape(-1, 2), axis=1).ravel(), 2)

    def with_edges(self, edges: np.ndarray) -> Layout:
        return Layout(np.asarray(edges, float), self.pinned)


@lru_cache(maxsize=256)
def _edge_flags(pinned: bytes) -> tuple[int, np.ndarray, np.ndarray]:
    """``e``, the exponents ``eps`` and the free-edge indices of the singular flags ``pinned``
    (as bytes); the arrays are read-only."""
    flags = np.frombuffer(pinned, dtype=bool)
    eps = np.where(flags, -0.5, 0.5)
    free = np.flatnonzero(~flags)
    eps.flags.writeable = free.flags.writeable = False
    return int(free.size), eps, free


def sign_exponent(x: np.ndarray, edges: np.ndarray, pinned: np.ndarray) -> np.ndarray:
    """``d = #nonsingular - #singular`` edges strictly to the right of each x."""
    right = edges[None, :] > np.asarray(x)[:, None]
    return (right & ~pinned).sum(1) - (right & pinned).sum(1)


def sign_from_d(d: np.ndarray) -> np.ndarray:
    """Real sign of ``W`` (d even, outside L) or of ``W_s`` (d odd, inside L)."""
    k = (d - (d % 2)) // 2
    return 1.0 - 2.0 * (k % 2)


def w_abs(x: np.ndarray, edges: np.ndarray, eps: np.ndarray, skip: np.ndarray | None = None):
    """``prod |x - e_i|^eps_i`` over the edges not in ``skip`` (boolean mask); an x on an edge
    gives the limit, 0 (eps_i > 0) or inf (eps_i < 0), without a warning."""
    use = np.ones(edges.size, bool) if skip is None else ~skip
    diff = np.abs(np.asarray(x)[..., None] - edges[use])
    with np.errstate(divide="ignore"):
        return np.exp(np.sum(eps[use] * np.log(diff), axis=-1))


def zone_signs(pinned: Sequence[bool]) -> list[float]:
    """``s_k``: the sign of ``W_s`` on each zone (from d, the edges to the right of its middle),
    given the singular flags of the edges."""
    d, out = 0, []
    for i, pin in reversed(list(enumerate(pinned))):
        d += -1 if pin else 1
        if i % 2 == 1:  # d now counts b_k and everything right of it
            out.append(1.0 - 2.0 * (((d - (d % 2)) // 2) % 2))
    return out[::-1]
