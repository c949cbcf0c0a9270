"""Pure comparison metrics between analytic functions and FE nodal interface data.

Conventions: zones are lists of ``(a, b)`` ordered by x; FE data are nodal arrays ``x, w, p, q``
(``w`` the tributary length, so ``sum f w`` is the integral of f).  Errors relative to a zone
are divided by the *analytic* zone width.  Norms are discrete L2 norms with the tributary
weights: ``||f|| = sqrt(sum w f^2)``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

#: Nodes closer than this fraction of the zone width to a singular point (sharp-corner edge:
#: p ~ 1/sqrt; profile kink inside a zone: p ~ log) are left out of the traction errors: a
#: nodal value cannot represent an unbounded traction, and the L2 norm of 1/sqrt diverges.
SINGULAR_EXCLUSION = 0.03
#: Floor of the Jaeger-Ciavarella error's denominator (compare.run.jc_error), as a fraction of
#: mu ||p||: the shear passes through small norms (e.g. early in stage 2), where a relative error
#: would be meaningless.  (The shear error itself is in units of mu ||p||: bounded_l2.)
SHEAR_FLOOR = 0.1

Zone = tuple[float, float]


def nearest(values: Sequence[float], target: float) -> float:
    """The element of ``values`` closest to ``target`` (nan if empty)."""
    if len(values) == 0:
        return float("nan")
    v = np.asarray(values, float)
    return float(v[np.argmin(np.abs(v - target))])


def edge_errors(an: Sequence[Zone], fe: Sequence[Zone]) -> list[tuple[float, float]]:
    """Per analytic zone: absolute errors of the left and right edges.

    Each analytic left (right) edge is paired with the nearest FE left (right) edge, so a
    missing or extra FE zone shows up as a large error instead of a shifted pairing.
    """
    lefts, rights = [z[0] for z in fe], [z[1] for z in fe]
    return [(abs(nearest(lefts, a) - a), abs(nearest(rights, b) - b)) for a, b in an]


def local_spacing(x: np.ndarray, at: float) -> float:
    """Node spacing of the element holding ``at`` (the nearest end element outside the nodes):
    the length that turns an edge error into elements."""
    if x.size < 2 or not np.isfinite(at):
        return float("nan")
    j = int(np.clip(np.searchsorted(x, at) - 1, 0, x.size - 2))
    return float(x[j + 1] - x[j])


def in_elements(error: float, x: np.ndarray, at: float) -> float:
    """An edge error (length) divided by the local node spacing at ``at``."""
    h = local_spacing(x, at)
    return error / h if h > 0 else float("nan")


#: A nodal L2 error is reported as dominated by one node when that node carries more than this
#: share of the squared error (sum w e**2): the verdict then hinges on where an edge falls
#: between nodes, not on the field.
DOMINANT_SHARE = 0.5


#: Below this relative L2 error there is no error for one node to dominate (round-off).
SHARE_FLOOR = 1e-9


def top_share(fe: np.ndarray, an: np.ndarray, w: np.ndarray, x: np.ndarray
              ) -> tuple[float, float]:
    """(largest share of one node in sum w (fe - an)**2, that node's x); (nan, nan) when the
    relative L2 error is below SHARE_FLOOR."""
    sq = w * (fe - an) ** 2
    total = float(np.sum(sq))
    if not total > (SHARE_FLOOR * l2(an, w)) ** 2:
        return float("nan"), float("nan")
    i = int(np.argmax(sq))
    return float(sq[i]) / total, float(x[i])


def overlap(z1: Zone, z2: Zone) -> float:
    """Length of the intersection of two intervals (0 if disjoint)."""
    return max(0.0, min(z1[1], z2[1]) - max(z1[0], z2[0]))


def match_zones(an: Sequence[Zone], fe: Sequence[Zone]) -> list[int | None]:
    """For each analytic zone, the index of the FE zone overlapping it most (None: no overlap)."""
    out: list[int | None] = []
    for z in an:
        ov = [overlap(z, f) for f in fe]
        out.append(int(np.argmax(ov)) if ov and max(ov) > 0 else None)
    return out


def stick_edge_error(an: Zone | None, fe: Zone | None, width: float) -> float:
    """Stick-zone edge error relative to the contact-zone width.

    Both in full slip (None): 0.  One in full slip: the other's half width (the distance of
    its edges from a vanishing stick zone at its centre).  Otherwise the larger edge error.
    """
    if an is None and fe is None:
        return 0.0
    if an is None or fe is None:
        c, d = an if fe is None else fe
        return 0.5 * (d - c) / width
    return max(abs(fe[0] - an[0]), abs(fe[1] - an[1])) / width


def regular_mask(x: np.ndarray, zones: Sequence[Zone], singular_points: Sequence[float]
                 ) -> np.ndarray:
    """Nodes not within SINGULAR_EXCLUSION * (zone width) of a singular point."""
    keep = np.ones(x.shape, bool)
    for s in singular_points:
        keep &= np.abs(x - s) > SINGULAR_EXCLUSION * zone_width_at(zones, s)
    return keep


def zone_width_at(zones: Sequence[Zone], s: float) -> float:
    """Width of the narrowest zone holding ``s`` (the widest zone if none; 0 without zones):
    the length scale of the exclusion around a singular point."""
    widths = [b - a for a, b in zones]
    return min((wd for (a, b), wd in zip(zones, widths, strict=True) if a - 1e-12 <= s
                <= b + 1e-12), default=max(widths) if widths else 0.0)


def singular_points(zones: Sequence[Zone], singular: Sequence[tuple[bool, bool]],
                    kinks: Sequence[float]) -> list[float]:
    """Singular edges of the zones plus kinks strictly inside a zone."""
    pts = [e for (a, b), (sl, sr) in zip(zones, singular, strict=True)
           for e, s in ((a, sl), (b, sr)) if s]
    pts += [k for k in kinks for a, b in zones if a < k < b]
    return pts


def l2(f: np.ndarray, w: np.ndarray) -> float:
    """Discrete L2 norm ``sqrt(sum w f^2)``."""
    return float(np.sqrt(np.sum(w * f * f)))


def relative_l2(fe: np.ndarray, an: np.ndarray, w: np.ndarray, floor: float = 0.0) -> float:
    """``||fe - an|| / max(||an||, floor)`` (nan when both norms vanish)."""
    den = max(l2(an, w), floor)
    return l2(fe - an, w) / den if den > 0 else float("nan")


def bounded_l2(fe: np.ndarray, an: np.ndarray, w: np.ndarray, bound: float) -> float:
    """``||fe - an|| / bound`` (nan when ``bound`` is 0): an error in units of a fixed scale,
    e.g. the shear error in units of the Coulomb bound ``mu ||p||``."""
    return l2(fe - an, w) / bound if bound > 0 else float("nan")


def relative_max(fe: np.ndarray, an: np.ndarray) -> float:
    """``max |fe - an| / max |an|``."""
    den = float(np.max(np.abs(an))) if an.size else 0.0
    return float(np.max(np.abs(fe - an))) / den if den > 0 else float("nan")


def zone_load(x: np.ndarray, w: np.ndarray, p: np.ndarray, zone: Zone) -> float:
    """FE load carried by the nodes in ``zone`` (closed interval)."""
    m = (x >= zone[0] - 1e-12) & (x <= zone[1] + 1e-12)
    return float(np.sum(p[m] * w[m]))


def zone_nodes(x: np.ndarray, zone: Zone, pad: float = 0.1) -> np.ndarray:
    """Nodes within the zone widened by ``pad`` of its width on each side."""
    a, b = zone
    d = pad * (b - a)
    return (x >= a - d) & (x <= b + d)


def traction_errors(x: np.ndarray, w: np.ndarray, fe: np.ndarray,
                    an: Callable[[np.ndarray], np.ndarray], keep: np.ndarray,
                    floor: float = 0.0) -> tuple[float, float]:
    """(relative L2, relative max) of nodal FE values against the analytic function."""
    xa, wa, fa = x[keep], w[keep], fe[keep]
    ref = np.asarray(an(xa), float)
    return relative_l2(fa, ref, wa, floor), relative_max(fa, ref)


def observed_order(h: Sequence[float], err: Sequence[float]) -> float:
    """Least-squares slope of ``log err`` against ``log h`` (nan with < 2 usable points)."""
    h, e = np.asarray(h, float), np.asarray(err, float)
    m = (h > 0) & (e > 0) & np.isfinite(e)
    if m.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(h[m]), np.log(e[m]), 1)[0])


#: Richardson extrapolation is refused outside this range of estimated orders.  The FE edges
#: converge at order >= 1 (theory 1; measured 1.3-2.0 on Cattaneo, levels 0-3): a lower estimate
#: means the three levels are not in the asymptotic range (Cattaneo levels 1-3: the finest edge
#: crosses the analytic one at 0.01 element, estimate 0.55, extrapolated error 10x the finest
#: one), and above 3 the sequence converges faster than any term of the FE error (noise).
RICHARDSON_ORDERS = (0.75, 3.0)


def richardson_check(values: Sequence[float], ratio: float = 2.0, order: float | None = None
                     ) -> tuple[float, float, str]:
    """Richardson extrapolation of a sequence on meshes refined by ``ratio``, with its reason.

    With ``order`` None the order is estimated from the last three values,
    ``p = log((f1 - f2) / (f2 - f3)) / log(ratio)``.  Returns ``(extrapolated, order, reason)``;
    ``extrapolated`` is nan and ``reason`` says why when the estimate is refused: fewer than
    three values, a non-monotone sequence (differences of opposite sign or zero: no asymptotic
    power law) or an order outside RICHARDSON_ORDERS.  Never the finest value instead.
    """
    f = np.asarray(values, float)
    nan = float("nan")
    if order is None:
        if f.size < 3 or not np.all(np.isfinite(f[-3:])):
            return nan, nan, "needs three finite values"
        d1, d2 = f[-3] - f[-2], f[-2] - f[-1]
        if d1 == 0 and d2 == 0:
            return nan, nan, "no change over the last three runs (exact, or not refined)"
        if d1 == 0 or d2 == 0 or d1 / d2 <= 0:
            return nan, nan, (f"non-monotone: successive changes {d1:.3g}, {d2:.3g} "
                              "(not in the asymptotic range)")
        order = float(np.log(d1 / d2) / np.log(ratio))
    elif f.size < 2:
        return nan, nan, "needs two values"
    lo, hi = RICHARDSON_ORDERS
    if not lo <= order <= hi:
        return nan, float(order), f"estimated order {order:.2f} outside [{lo:g}, {hi:g}]"
    return float(f[-1] + (f[-1] - f[-2]) / (ratio**order - 1.0)), float(order), ""


def richardson(values: Sequence[float], ratio: float = 2.0, order: float | None = None
               ) -> tuple[float, float]:
    """``(extrapolated, order)`` of :func:`richardson_check` (nan where it is refused)."""
    return richardson_check(values, ratio, order)[:2]


def local_orders(h: Sequence[float], err: Sequence[float]) -> list[float]:
    """Observed order between successive runs, ``log(e_i / e_{i+1}) / log(h_i / h_{i+1})``
    (nan where an error is not positive and finite or h is 0, e.g. the augmented Lagrangian)."""
    h, e = np.asarray(h, float), np.asarray(err, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.log(e[:-1] / e[1:]) / np.log(h[:-1] / h[1:])
    ok = (e[:-1] > 0) & (e[1:] > 0) & np.isfinite(e[:-1]) & np.isfinite(e[1:]) & (h[1:] > 0) \
        & (h[:-1] > 0)
    return [float(v) if k else float("nan") for v, k in zip(out, ok, strict=True)]


def error_ratios(err: Sequence[float]) -> list[float]:
    """Ratios of successive errors ``e_i / e_{i+1}`` (2 = halved; nan where undefined)."""
    e = np.asarray(err, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = e[:-1] / e[1:]
    return [float(v) if np.isfinite(v) else float("nan") for v in r]
