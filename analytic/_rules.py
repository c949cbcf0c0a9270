"""One-dimensional quadrature rules of the singular-integral solver (no knowledge of layouts).

Gauss-Jacobi rules for the edge factors ``(x - lo)^alpha_lo (hi - x)^alpha_hi`` of ``omega = 1/W``
(alpha = +-1/2), the sine-mapped Gauss-Legendre rule for a profile slope ``h0' ~ d^(-1/2)`` next
to a vertical end, the node count of an interval from its clearance to the nearest outside
singularity, and the rule graded geometrically (ratio GRADING) away from a near singularity.
The zone and gap quadrature plans (:mod:`analytic._zone_quadrature`,
:mod:`analytic._gap_quadrature`) are assembled from these.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from scipy.special import roots_jacobi

BASE_NODES = 32
MAX_NODES = 640


@lru_cache(maxsize=512)
def jacobi_rule(n: int, alpha_hi: float, alpha_lo: float) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Jacobi rule on [-1, 1] for the weight ``(1 - t)^alpha_hi (1 + t)^alpha_lo``."""
    t, w = roots_jacobi(n, alpha_hi, alpha_lo)
    return t, w


def mapped_rule(lo: float, hi: float, alpha_lo: float, alpha_hi: float, n: int):
    """Nodes and weights on [lo, hi] for ``(x - lo)^alpha_lo (hi - x)^alpha_hi f(x)``."""
    t, w = jacobi_rule(int(n), float(alpha_hi), float(alpha_lo))
    half = 0.5 * (hi - lo)
    return 0.5 * (lo + hi) + half * t, w * half ** (1.0 + alpha_lo + alpha_hi)


def _wanted_nodes(length: float, clearance: float) -> float:
    """Uncapped quadrature size for an interval whose nearest outside singularity is
    ``clearance`` away (inf when the clearance vanishes against the length)."""
    ratio = float(length) / max(float(clearance), 1e-300)
    if not ratio < 1e300:
        return math.inf
    return BASE_NODES + 14.0 * math.sqrt(max(ratio, 0.0))


def nodes_for(length: float, clearance: float) -> int:
    """Quadrature size for an interval whose nearest outside singularity is ``clearance`` away."""
    n = _wanted_nodes(length, clearance)
    return MAX_NODES if math.isinf(n) else int(min(MAX_NODES, 8 * math.ceil(n / 8)))


def capped(length: float, clearance: float) -> bool:
    """Whether :func:`nodes_for` would need more than MAX_NODES (length / clearance above
    ~1.9e3): one rule on the interval is then under-resolved and must be graded instead."""
    return not _wanted_nodes(length, clearance) <= MAX_NODES


GRADING = 4.0


@lru_cache(maxsize=4096)
def graded_rule(length: float, clearance: float, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """Rule for ``int_0^length t^eps f(t) dt`` where f varies on the scale ``clearance`` near 0.

    Sub-intervals grow geometrically from ``clearance``: Gauss-Jacobi (weight ``t^eps``) on the
    first, Gauss-Legendre with ``t^eps`` folded into the weights on the others.
    """
    first = min(length, max(clearance, 1e-300))
    t, w = mapped_rule(0.0, first, eps, 0.0, nodes_for(first, clearance))
    ts, ws = [t], [w]
    lo = first
    while lo < length * (1 - 1e-14):
        hi = min(length, lo * GRADING)
        tt, ww = mapped_rule(lo, hi, 0.0, 0.0, 24)
        ts.append(tt)
        ws.append(ww * tt**eps)
        lo = hi
    return np.concatenate(ts), np.concatenate(ws)


@lru_cache(maxsize=64)
def sine_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre in v on [-1, 1] mapped by ``t = sin(pi v / 2)``: ``(1 -+ t)^(+-1/2)`` and
    ``d^(-1/2)`` slopes (a vertical end) times ``dt`` are smooth in v (no Jacobi weight)."""
    v, wv = np.polynomial.legendre.leggauss(n)
    return np.sin(0.5 * np.pi * v), wv * 0.5 * np.pi * np.cos(0.5 * np.pi * v)

