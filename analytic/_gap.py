"""The deformed gap ``g(x)`` outside the contact zones of a solved system.

``g(x) = h(x) - h(edge) + int_edge^x w'`` from the nearest edge on the same side of x, with
``h = h0 - theta x`` and ``w'`` the surface displacement slope of :class:`analytic._sie.System`
(h' subtracted in B only within one clearance of the edge, ``GAP_SUBTRACT_REACH``; the
polynomial growth of the consistency residuals removed,
:meth:`analytic._sie.Batch.residual_growth`); ``g = 0`` in the zones and ``+inf`` where the
profile is undefined.
"""

from __future__ import annotations

import numpy as np

from analytic._sie import System


def in_zones(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    z = edges.reshape(-1, 2)
    return np.any((x[:, None] > z[:, 0]) & (x[:, None] < z[:, 1]), axis=1)


def deformed_gap(sys_: System, x: np.ndarray) -> np.ndarray:
    """``g(x) = h(x) - h(edge) + int_edge^x w'`` from the nearest edge on the same side."""
    edges = sys_.layout.edges
    out = np.zeros(x.shape)
    inside = in_zones(x, edges) | np.isin(x, edges)
    h = sys_.profile.h0(x) - sys_.theta * x
    nearest = _nearest_outer_edge(x, edges)
    out[~inside & ~np.isfinite(h)] = np.inf
    todo = ~inside & np.isfinite(h)
    if np.any(todo):
        i = nearest[todo]
        out[todo] = sys_.gaps_from_edges(i, x[todo], h[todo])
    return out


def _nearest_outer_edge(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Index of the edge bounding the gap (or outer region) that holds each x, nearest side."""
    k = np.searchsorted(edges, x)  # x in (edges[k-1], edges[k])
    idx = np.where(k == 0, 0, np.where(k >= edges.size, edges.size - 1, k))
    gap = (k > 0) & (k < edges.size) & (k % 2 == 0)  # between b_{m} (k-1) and a_{m+1} (k)
    left_nearer = gap & (np.abs(x - edges[np.maximum(k - 1, 0)])
                         <= np.abs(edges[np.minimum(k, edges.size - 1)] - x))
    return np.where(left_nearer, k - 1, idx)
