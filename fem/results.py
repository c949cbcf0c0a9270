"""Result containers (frozen dataclasses) and zone / edge extraction from nodal data.

Units follow the inputs (forces per unit width, lengths, stresses). Sign conventions
(docs/conventions.md): p >= 0 compressive; q is the shear on body 1 in the direction of Q with
``sum q w = Q``; ``M = sum x p w`` about x = 0; slip is the irreversible relative
tangential displacement of body 1 over body 2 (+x); status 0 open, 1 stick, 2 slip.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.polynomial import polynomial as P

from .contact import OPEN, SLIP, STICK


@dataclass(frozen=True)
class FemInterface:
    """Nodal interface data at one increment, sorted by x.

    x: node x; w: tributary length; p: pressure; q: shear (direction of Q);
    status: 0 open / 1 stick / 2 slip; slip: irreversible relative slip;
    penetration: max(0, -gap); gap: deformed gap (inf where h0 is inf).
    """

    x: np.ndarray
    w: np.ndarray
    p: np.ndarray
    q: np.ndarray
    status: np.ndarray
    slip: np.ndarray
    penetration: np.ndarray
    gap: np.ndarray


@dataclass(frozen=True)
class FemStep:
    """One converged load increment.

    stage: 1, 2 or 3; t: load-step parameter (stage 1: P/P0, stage 2: 1 + Q/Q0,
    stage 3: 2 + (Q0 - Q)/(2 Q0)); P, Q, M: applied loads (M computed in
    vertical-indentation mode); contact_zones: ((a, b), ...); stick_zones: one
    (c, d) or None per contact zone; plate: (u, v, theta) of the plate, theta about (0, 0)
    in the analytic convention (the gap seen in contact is h0(x) - theta x, i.e. clockwise);
    reactions: (P, Q, M) recovered from the full-field plate reactions;
    residuals: relative equilibrium residuals (P, Q, M) of those reactions;
    iterations: Newton iterations of the increment (summed over cut-backs / Uzawa).
    """

    index: int
    stage: int
    t: float
    P: float
    Q: float
    M: float
    interface: FemInterface
    contact_zones: tuple
    stick_zones: tuple
    plate: tuple
    reactions: tuple
    residuals: tuple
    iterations: int


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Index ranges [i0, i1] (inclusive) of consecutive True entries."""
    m = np.r_[False, mask, False].astype(np.int8)
    starts = np.flatnonzero(np.diff(m) == 1)
    ends = np.flatnonzero(np.diff(m) == -1) - 1
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


#: Nodes next to an edge whose nodal pressure is smeared by the node-wise contact law, left out
#: of the pressure-side fit: on Cattaneo (size factor 100, levels 1-3) the two outermost nodes
#: imply edges up to 0.18 element off, the third and further ones < 0.03 element.
EDGE_SKIP = 2
#: The skipped nodes must lie within this many elements (along x, at the fit's slope) of the
#: fit, else it is not used: measured on Cattaneo they imply edges <= 0.18 element off, while a
#: kink between them and the fitted nodes (a stage-2 stick edge frozen into a stage-3 stick zone
#: next to its edge, double wedge) puts them ~2 elements off.
SKIP_SHIFT = 0.5
#: Nodes in the pressure-side least-squares fit of f**2 after EDGE_SKIP: f**2 of a sqrt edge is
#: smooth, and with >= 4 nodes a quadratic also takes its curvature (exact for Hertz).
EDGE_FIT = 5
#: Open nodes skipped / fitted on the gap side (g**(2/3) is smooth through a sqrt edge): the
#: first open node is skipped, its gap is off by up to 0.19 element when it is < h/4 outside.
GAP_SKIP, GAP_FIT = 1, 3
#: A fit stops before a node where the first difference of the fitted values changes by more than
#: this fraction: a kink (a profile kink, or a former stick edge inside a stage-3 stick zone).
KINK_JUMP = 0.4


def smooth_prefix(y: np.ndarray) -> int:
    """Length of the leading part of ``y`` (ordered away from an edge) before a kink."""
    d = np.diff(y)
    for j in range(1, d.size):
        if abs(d[j] - d[j - 1]) > KINK_JUMP * abs(d[j - 1]):
            return j + 1
    return y.size


def power_root(xs: np.ndarray, ys: np.ndarray, x_end: float, rising: int, degree: int = 2,
               skipped: tuple[np.ndarray, np.ndarray] | None = None) -> float | None:
    """Root next to ``x_end`` of the least-squares polynomial of ``degree`` (linear with 2
    points) through the smooth prefix of ``ys`` at ``xs``, where it rises in the direction
    ``rising`` (+-1); None with < 2 points or no such root, or if a ``skipped`` point (x, y)
    lies further from the fit than SKIP_SHIFT elements (measured along x at the fit's slope):
    the field between the fitted nodes and the edge is then not the fitted sqrt (a kink)."""
    n = smooth_prefix(ys)
    if n < 2:
        return None
    xs, ys = xs[:n], ys[:n]
    scale = float(np.ptp(xs)) or 1.0
    c = np.r_[P.polyfit((xs - x_end) / scale, ys, min(degree, n - 1)), 0.0, 0.0][:3]
    roots = quadratic_roots(*c)
    ok = roots[(c[1] + 2 * c[2] * roots) * rising > 0]
    if ok.size == 0 or (skipped is not None and not _near_fit(c, scale, x_end, *skipped)):
        return None
    return x_end + scale * float(ok[np.argmin(np.abs(ok))])


def _near_fit(c: np.ndarray, scale: float, x_end: float, xk: np.ndarray, yk: np.ndarray
              ) -> bool:
    """Whether the points (xk, yk) lie within SKIP_SHIFT elements (along x) of the polynomial
    ``c`` in ``t = (x - x_end) / scale``; the element is the spacing of the points."""
    t = (xk - x_end) / scale
    value, slope = P.polyval(t, c), P.polyval(t, P.polyder(c)) / scale
    h = float(np.max(np.abs(np.diff(np.r_[xk, x_end])))) if xk.size > 1 else abs(
        float(xk[0] - x_end)) or 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        shift = np.abs((value - yk) / slope)
    return bool(np.all(shift <= SKIP_SHIFT * h))


def quadratic_roots(c0: float, c1: float, c2: float) -> np.ndarray:
    """Real roots of ``c0 + c1 t + c2 t**2`` (stable form; c2 may vanish)."""
    disc = c1 * c1 - 4 * c0 * c2
    if disc < 0 or (c1 == 0 and c2 == 0):
        return np.empty(0)
    s = -0.5 * (c1 + np.copysign(np.sqrt(disc), c1))
    if s == 0:  # c1 = 0 = c0 c2: a double root at 0
        return np.zeros(1)
    return np.array([c0 / s] + ([s / c2] if c2 != 0 else []))


def sqrt_edge(x: np.ndarray, f: np.ndarray, run: tuple[int, int], step: int) -> float:
    """Zero of f beyond the end of the node run ``run = (i0, i1)`` in direction ``step`` (+-1).

    Near a nonsingular edge f ~ sqrt(distance), so f**2 is smooth through the edge: a polynomial
    (:func:`power_root`) is fitted by least squares to f**2 at up to EDGE_FIT nodes after the
    EDGE_SKIP outermost ones, within the outer third of the run (the field further in need not
    be sqrt-shaped); exact for f**2 linear or quadratic in x, on any grid.  If that is not
    possible (a short run), the skipped nodes are off the fit (a kink) or its root is not
    within :func:`edge_bounds`, the line through f**2 at the two outermost nodes is used
    (clipped to those bounds).
    """
    i0, i1 = run
    end = i1 if step > 0 else i0
    inward = np.arange(end, i0 - 1, -1) if step > 0 else np.arange(end, i1 + 1)
    reach, (lo, hi) = inward.size // 3, edge_bounds(x, end, step)
    nodes, outer = inward[EDGE_SKIP:min(EDGE_SKIP + EDGE_FIT, reach)], inward[:EDGE_SKIP]
    if nodes.size >= 3:
        root = power_root(x[nodes], f[nodes] ** 2, x[end], -step,
                          skipped=(x[outer], f[outer] ** 2))
        if root is not None and lo <= root <= hi:
            return root
    root = power_root(x[inward[:2]], f[inward[:2]] ** 2, x[end], -step)
    return float(np.clip(root, lo, hi)) if root is not None else 0.5 * (x[end] + x[end + step])


def gap_edge(x: np.ndarray, gap: np.ndarray, status: np.ndarray, end: int, step: int
             ) -> float | None:
    """Edge from the open side: zero of gap**(2/3) (smooth through a sqrt edge, where the gap
    grows like distance**1.5) fitted at the GAP_FIT open nodes after the GAP_SKIP first ones
    beyond node ``end`` in direction ``step``; None without enough open nodes of finite gap or
    if the root is not within :func:`edge_bounds`."""
    nodes = []
    j = end + step
    while 0 <= j < x.size and status[j] == OPEN and np.isfinite(gap[j]) and \
            len(nodes) < GAP_SKIP + GAP_FIT:
        nodes.append(j)
        j += step
    nodes = np.array(nodes[GAP_SKIP:], dtype=int)
    if nodes.size < 2:
        return None
    root = power_root(x[nodes], np.maximum(gap[nodes], 0.0) ** (2 / 3), x[end], step, 1)
    lo, hi = edge_bounds(x, end, step)
    return root if root is not None and lo <= root <= hi else None


def edge_bounds(x: np.ndarray, end: int, step: int) -> tuple[float, float]:
    """Where an edge may lie: from half-way between the run's end node ``end`` and the node
    before it (the end node may hold a small smeared pressure just outside the edge) to the
    first node outside (direction ``step``)."""
    inner = end - step if 0 <= end - step < x.size else end
    lo, hi = sorted((0.5 * (x[inner] + x[end]), x[end + step]))
    return float(lo), float(hi)


def contact_edges(x, p, status, candidate, gap=None) -> list[tuple[float, float]]:
    """Edges of each contact run (status > OPEN).  A run bounded by a non-candidate node (beyond
    a sharp corner) or whose pressure rises to its end (a singular edge, p ~ 1/sqrt, at a
    corner node) ends at its last node; otherwise the edge is taken from the gap side
    (:func:`gap_edge`) when ``gap`` is given and there are enough open nodes, else from the
    pressure side (:func:`sqrt_edge`)."""
    out = []
    for i0, i1 in runs(status > OPEN):
        ends = []
        for end, step in ((i0, -1), (i1, 1)):
            if not 0 <= end + step < x.size or not candidate[end + step] or \
                    rising_to_edge(p, (i0, i1), end, step):
                ends.append(float(x[end]))
                continue
            g = gap_edge(x, gap, status, end, step) if gap is not None else None
            ends.append(g if g is not None else sqrt_edge(x, p, (i0, i1), step))
        out.append((ends[0], ends[1]))
    return out


def rising_to_edge(p: np.ndarray, run: tuple[int, int], end: int, step: int) -> bool:
    """True if the pressure rises towards the run's end node (a singular edge: p ~ 1/sqrt)."""
    return run[0] < run[1] and p[end] >= p[end - step]


def stick_edge(x, p, q, mu: float, run: tuple[int, int], step: int) -> float:
    """Edge of a stick run next to a slip node: the zero of ``mu p - s q``, s = sign of q in
    that slip zone (q = s mu p there), which is sqrt-shaped across the stick edge (Jaeger-
    Ciavarella: mu p_S of the reduced problem), also where q changes sign in the stick zone."""
    end = run[1] if step > 0 else run[0]
    s = np.sign(q[end + step]) or np.sign(q[end]) or 1.0
    return sqrt_edge(x, np.maximum(mu * p - s * q, 0.0), run, step)


def contact_and_stick(x, p, q, status, candidate, mu, gap=None) -> tuple[tuple, tuple]:
    """Contact zones (p -> 0) and their stick zones (mu p - |q| -> 0), aligned: per contact
    zone the span of its stick runs (None: full slip); a stick run reaching the end of its
    contact run ends at the contact edge."""
    contact = contact_edges(x, p, status, candidate, gap)
    sticks = runs(status == STICK)
    aligned = []
    for (a, b), (i0, i1) in zip(contact, runs(status > OPEN), strict=True):
        inside = [r for r in sticks if i0 <= r[0] and r[1] <= i1]
        if not inside:
            aligned.append(None)
            continue
        c = a if inside[0][0] == i0 else stick_edge(x, p, q, mu, inside[0], -1)
        d = b if inside[-1][1] == i1 else stick_edge(x, p, q, mu, inside[-1], +1)
        aligned.append((float(c), float(d)))
    return tuple(contact), tuple(aligned)


__all__ = ["FemInterface", "FemStep", "contact_and_stick", "gap_edge", "runs", "sqrt_edge",
           "OPEN", "STICK", "SLIP"]
