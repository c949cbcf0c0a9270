"""Result containers (frozen dataclasses) and zone / edge extraction from nodal data.

Units follow the inputs (forces per unit width, lengths, stresses). Sign conventions
(docs/conventions.md): p >= 0 compressive; q is the shear on body 1 in the direction of Q with
``sum q w = Q``; ``M = sum x p w`` about x = 0; slip is the irreversible relative
tangential displacement of body 1 over body 2 (+x); status 0 open, 1 stick, 2 slip.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

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
    iterations: Newton iterations of the increment (summed over cut-backs / Uzawa);
    edge_uncertainty: per contact zone (u_a, u_b), the edge estimator's own uncertainty of
    each located edge (length; :func:`edge_estimate`); stick_uncertainty: per contact zone
    (u_c, u_d) of its stick-zone edges, or None (full slip).  Empty when not computed.
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
    edge_uncertainty: tuple = ()
    stick_uncertainty: tuple = ()


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Index ranges [i0, i1] (inclusive) of consecutive True entries."""
    m = np.zeros(mask.size + 2, dtype=np.int8)
    m[1:-1] = mask
    d = m[1:] - m[:-1]
    starts = (d == 1).nonzero()[0]
    ends = (d == -1).nonzero()[0] - 1
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
#: smooth, and with >= 4 nodes a quadratic also takes its curvature (exact for Hertz).  The fit
#: takes the outer 1/BAND_OF_RUN of the run (less EDGE_SKIP), at least EDGE_FIT and at most
#: EDGE_FIT_MAX nodes.  Why wider than EDGE_FIT on long runs (issue 28, cattaneo, rings): the FE
#: smears an edge over its outer ~4 nodes, a tail that decays by ~2 per node (f**2 of nodes 3 /
#: 4 / 5 implies edges +0.002 / -0.002 / -0.005 element off against a smooth -0.006 beyond:
#: level 3, Q = Q0 / 2), and a quadratic through nodes 3-7 extrapolates that tail to the edge:
#: 0.017 / 0.029 / 0.036 element at levels 3 / 4 / 5, an O(h) error that stalled the stick-edge
#: error (4.9e-5 / 4.1e-5 / 2.6e-5 of the width; the estimator is exact on the analytic fields
#: at the same nodes, < 1e-15).  The wide band reads through most of it: 3.1e-5 / 1.1e-5 / 5.0e-6
#: at levels 3 / 4 / 5 (0.011 / 0.008 / 0.007 element; 1/12 of the run: 1.0e-5 / 4.3e-6 / 3.9e-6).
#: While the band grows with the run (up to 1008 nodes) its quadratic misses the field's higher
#: terms by a fixed fraction of the width, so the band stays narrow: 1/12 of the run put
#: biquadratic_merged's stage-2 stick edges (level 2) up to 1.9e-3 of the width off instead of
#: 8.0e-4 (a fixed 20 nodes: two_cylinders_far's 3.5e-3 instead of 4.3e-4, level 1); 1/24 moves
#: no library case at its default level but applied_moment (level 3).  Runs of fewer than 168
#: nodes keep EDGE_FIT.
EDGE_FIT = 5
EDGE_FIT_MAX, BAND_OF_RUN = 40, 24
#: Open nodes skipped / fitted on the gap side (g**(2/3) is smooth through a sqrt edge): the
#: first open node is skipped, its gap is off by up to 0.19 element when it is < h/4 outside.
#: A straight line through GAP_FIT nodes; on a contact run of GAP_OF_RUN * GAP_WIDE (320) nodes or
#: more, a quadratic through 1/GAP_OF_RUN of the run's node count (at most GAP_FIT_MAX) after
#: the GAP_SKIP_WIDE first open nodes, past their smeared tail: cattaneo (rings) contact edge
#: 3.6e-5 / 2.2e-5 of the width at levels 3 / 4 with the three nodes (0.013 / 0.016 element:
#: the same O(h) tail as the pressure side's), 3.9e-6 / 2.8e-6 so; applied_moment (level 3)
#: 1.28e-4 -> 4.4e-5.  Shorter runs keep the line: on them a longer line misses the curvature of
#: g**(2/3) (biquadratic_merged, level 2: 2.6e-4 -> 5.2e-4 with 5 nodes).
GAP_SKIP, GAP_FIT = 1, 3
GAP_OF_RUN, GAP_WIDE, GAP_SKIP_WIDE, GAP_FIT_MAX = 32, 10, 3, 20
#: A fit stops before a node where the first difference of the fitted values changes by more than
#: this fraction: a kink (a profile kink, or a former stick edge inside a stage-3 stick zone).
KINK_JUMP = 0.4


def smooth_prefix(y: np.ndarray) -> int:
    """Length of the leading part of ``y`` (ordered away from an edge) before a kink."""
    d = (y[1:] - y[:-1]).tolist()  # Python floats: the same arithmetic, without 0-d arrays
    for j in range(1, len(d)):
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
    scale = float(xs.max() - xs.min()) or 1.0
    deg = min(degree, n - 1)
    c = np.zeros(3)
    c[:deg + 1] = _polyfit((xs - x_end) / scale, ys, deg)
    root = _nearest_root(*c.tolist(), rising)
    if root is None or (skipped is not None and not _near_fit(c, scale, x_end, *skipped)):
        return None
    return x_end + scale * root


def _polyfit(t: np.ndarray, y: np.ndarray, deg: int) -> np.ndarray:
    """Least-squares polynomial coefficients (lowest first) of degree ``deg`` through (t, y):
    the operations of ``numpy.polynomial.polynomial.polyfit`` (Vandermonde columns scaled to
    unit norm, ``np.linalg.lstsq`` with rcond = len(t) eps; the same numbers to the bit) without
    its argument checks and conversions, which cost more than the fit of a few points."""
    v = np.empty((deg + 1, t.size))
    v[0] = t * 0 + 1
    for i in range(1, deg + 1):
        v[i] = v[i - 1] * t
    scl = np.sqrt(np.square(v).sum(1))
    scl[scl == 0] = 1
    return np.linalg.lstsq(v.T / scl, y, t.size * _EPS)[0] / scl


_EPS = float(np.finfo(float).eps)


def _near_fit(c: np.ndarray, scale: float, x_end: float, xk: np.ndarray, yk: np.ndarray
              ) -> bool:
    """Whether the points (xk, yk) lie within SKIP_SHIFT elements (along x) of the polynomial
    ``c`` in ``t = (x - x_end) / scale``; the element is the spacing of the points."""
    c0, c1, c2 = c.tolist()
    xs, x_end = xk.tolist(), float(x_end)
    h = max(max(abs(b - a) for a, b in zip(xs[:-1], xs[1:], strict=True)),
            abs(x_end - xs[-1])) \
        if len(xs) > 1 else abs(xs[0] - x_end) or 1.0
    for t, y in zip(((xk - x_end) / scale).tolist(), yk.tolist(), strict=True):
        slope = (c1 + 2 * c2 * t) / scale
        # Horner, as P.polyval; a zero slope: the shift is infinite (or undefined)
        if slope == 0 or not abs((c0 + (c1 + c2 * t) * t - y) / slope) <= SKIP_SHIFT * h:
            return False
    return True


def quadratic_roots(c0: float, c1: float, c2: float) -> np.ndarray:
    """Real roots of ``c0 + c1 t + c2 t**2`` (stable form; c2 may vanish)."""
    return np.array(_root_list(float(c0), float(c1), float(c2)), dtype=float)


def _root_list(c0: float, c1: float, c2: float) -> list[float]:
    """:func:`quadratic_roots` as a list of Python floats (the same arithmetic)."""
    disc = c1 * c1 - 4 * c0 * c2
    if disc < 0 or (c1 == 0 and c2 == 0):
        return []
    s = -0.5 * (c1 + math.copysign(math.sqrt(disc), c1))
    if s == 0:  # c1 = 0 = c0 c2: a double root at 0
        return [0.0]
    return [c0 / s] + ([s / c2] if c2 != 0 else [])


def _nearest_root(c0: float, c1: float, c2: float, rising: int) -> float | None:
    """The root of ``c0 + c1 t + c2 t**2`` nearest t = 0 (the first on a tie) where the
    polynomial rises in the direction ``rising`` (+-1: slope times rising > 0); None without."""
    best = None
    for r in _root_list(c0, c1, c2):
        if (c1 + 2 * c2 * r) * rising > 0 and (best is None or abs(r) < abs(best)):
            best = r
    return best


def sqrt_edge(x: np.ndarray, f: np.ndarray, run: tuple[int, int], step: int) -> float:
    """Zero of f beyond the end of the node run ``run = (i0, i1)`` in direction ``step`` (+-1).

    Near a nonsingular edge f ~ sqrt(distance), so f**2 is smooth through the edge: a polynomial
    (:func:`power_root`) is fitted by least squares to f**2 at up to EDGE_FIT nodes after the
    EDGE_SKIP outermost ones (more on a long run: BAND_OF_RUN, EDGE_FIT_MAX), within the outer
    third of the run (the field further in need not be sqrt-shaped); exact for f**2 linear or
    quadratic in x, on any grid.  If that is not
    possible (a short run), the skipped nodes are off the fit (a kink) or its root is not
    within :func:`edge_bounds`, the line through f**2 at the two outermost nodes is used
    (clipped to those bounds).
    """
    i0, i1 = run
    end = i1 if step > 0 else i0
    inward = np.arange(end, i0 - 1, -1) if step > 0 else np.arange(end, i1 + 1)
    reach, (lo, hi) = inward.size // 3, edge_bounds(x, end, step)
    fit = min(max(inward.size // BAND_OF_RUN - EDGE_SKIP, EDGE_FIT), EDGE_FIT_MAX)
    nodes, outer = inward[EDGE_SKIP:min(EDGE_SKIP + fit, reach)], inward[:EDGE_SKIP]
    if nodes.size >= 3:
        root = power_root(x[nodes], f[nodes] ** 2, x[end], -step,
                          skipped=(x[outer], f[outer] ** 2))
        if root is not None and lo <= root <= hi:
            return root
    root = power_root(x[inward[:2]], f[inward[:2]] ** 2, x[end], -step)
    return float(np.clip(root, lo, hi)) if root is not None else 0.5 * (x[end] + x[end + step])


#: Band estimator (:func:`band_edge`), for nodal data with node-to-node noise (another code's
#: mortar pressure ripples by 1-2 % per node): a weighted least-squares quadratic of f**2 over
#: the outer BAND_FRACTION of the run (at least BAND_MIN, at most BAND_MAX nodes).  The edge
#: information sits in the outermost nodes (f**2 ~ distance: a relative error eps of f moves the
#: implied edge by 2 eps k elements at node k), so they are weighted by 1 / sigma(f**2) with
#: sigma ~ f * max(f, BAND_NOISE_FLOOR * max f) (relative noise); the far nodes pin the slope
#: and curvature.  Measured on Hertz sampled with +-2 % ripple, h = a/20..a/80, 20 edge phases:
#: edge error <= 0.04 element with half the run (0.053 with 0.4, 0.057 with 8 nodes).
BAND_FRACTION, BAND_MIN, BAND_MAX = 0.5, 5, 32
#: Nodes at a run's end with f below this fraction of the run's largest f are left out of the
#: band: Kratos flags stage-3 nodes "stick" beyond the stick edge where mu p - |q| = 0 to 1e-5.
BAND_TRIM = 0.05

BAND_NOISE_FLOOR = 0.05
#: Outermost nodes the band fit may drop (a code's smeared end nodes): the fit skipping k nodes is
#: used when it agrees with the one skipping k + 1 within BAND_AGREE elements plus their combined
#: 2-sigma; else one more node is skipped (at most BAND_SKIPS - 1).
BAND_SKIPS, BAND_AGREE = 3, 0.02
#: The uncertainty reported with a band edge: BAND_COVER standard deviations of the fit's root
#: (from its residuals) combined with the change when one more end node is skipped; measured
#: coverage of the true error on Hertz with +-2 % ripple 100 %, with 1-2 % random noise >= 97 %.
BAND_COVER = 2.0
#: A band fit is kept when it agrees with the half band's within this many times their combined
#: uncertainty (each already BAND_COVER sigma): 1 loses accuracy on random noise (1 %, h = a/20:
#: 0.30 element), 2 keeps it (0.06).
BAND_HALVE = 2.0
#: A stick edge takes the band fit on noisy data only within this many elements of sqrt_edge
#: (further, the band crossed a kink): on Cattaneo with +-2 % ripple the band is within 0.09
#: element of the truth (h <= c/8) and sqrt_edge 0.4-0.7 element off; on Kratos' stage 3 the
#: band was 2-5 elements off next to the frozen stage-2 stick edge.
BAND_TRUST = 1.0
#: Nodal data are noisy when f**2 over the run (less EDGE_SKIP nodes at each end) is rougher
#: than NOISY_ROUGHNESS: median |third difference| (divided differences in x times 6 h**3: zero
#: for a quadratic on any grid) over the mean |first difference|, i.e. in elements (f**2 of a
#: sqrt edge: ~ (h/a)**2), and the sign of successive third differences flips at more than
#: NOISY_SIGN_FLIPS of them.  Measured: +-2 % ripple roughness > 1, flips 1.0 (period 3: 0.66);
#: 1-2 % random noise flips 0.66-0.94; our own FE (applied_moment, double wedges, full slip
#: first, at default levels) roughness up to 3.6 next to wedge apexes but flips <= 0.33 there:
#: the third differences of a kink or a log singularity keep their sign.
NOISY_ROUGHNESS, NOISY_SIGN_FLIPS = 0.02, 0.5


def _inward(run: tuple[int, int], step: int) -> np.ndarray:
    """Node indices of a run ordered from its end in direction ``step`` inwards."""
    i0, i1 = run
    return np.arange(i1, i0 - 1, -1) if step > 0 else np.arange(i0, i1 + 1)


def _band(run: tuple[int, int], step: int, f: np.ndarray | None = None,
          to_peak: bool = False) -> np.ndarray:
    """The band's nodes from the run's end inwards; with ``f``, leading nodes where f <=
    BAND_TRIM * max f (flagged in the run, but at f = 0 within the noise: e.g. stick flags on
    nodes with |q| = mu p) are left out first; with ``to_peak`` the band ends at the largest f
    (at least BAND_MIN nodes): f**2 is one smooth branch only up to its peak (see
    stick_edge_estimate)."""
    inward = _inward(run, step)
    n = min(max(int(BAND_FRACTION * inward.size), BAND_MIN), BAND_MAX, inward.size)
    if f is None or not inward.size:
        return inward[:n]
    fi = f[inward]
    big = fi > BAND_TRIM * float(fi.max())
    first = int(big.argmax()) if big.any() else 0
    if inward.size - first >= BAND_MIN:
        inward, fi = inward[first:], fi[first:]
    if to_peak:
        n = min(n, max(int(fi[:n].argmax()) + 1, BAND_MIN))
    return inward[:min(n, inward.size)]


def roughness(x: np.ndarray, f: np.ndarray, run: tuple[int, int], step: int
              ) -> tuple[float, float]:
    """(roughness in elements, fraction of sign flips) of the nodal f**2 of a run (see
    NOISY_ROUGHNESS); (0, 0) when the run is too short to tell (< 4 third differences)."""
    nodes = _inward(run, step)[EDGE_SKIP:-EDGE_SKIP or None]
    xs, y = x[nodes], f[nodes] ** 2
    if y.size < 7:
        return 0.0, 0.0
    d = y
    for k in range(1, 4):
        d = (d[1:] - d[:-1]) / (xs[k:] - xs[:-k])
    span = np.abs(xs[3:] - xs[:-3]) / 3.0
    third = 6.0 * d * span**3
    sign = np.sign(third)
    flips = np.count_nonzero(sign[1:] != sign[:-1]) / (sign.size - 1)
    mean1 = float(np.abs(y[1:] - y[:-1]).sum() / (y.size - 1))  # np.mean's sum and division
    return (_median(np.abs(third)) / mean1 if mean1 > 0 else 0.0), flips


def _median(a: np.ndarray) -> float:
    """``np.median`` of a 1-d float array (the same order statistics and mean of the middle
    two; NaN if a holds one), without its generic machinery."""
    v = np.sort(a).tolist()
    n = len(v)
    if v[-1] != v[-1]:  # NaN sorts last
        return math.nan
    return v[n // 2] if n % 2 else (v[n // 2 - 1] + v[n // 2]) / 2


def is_noisy(x: np.ndarray, f: np.ndarray, run: tuple[int, int], step: int) -> bool:
    """Whether f on the run carries node-to-node noise (NOISY_ROUGHNESS)."""
    rough, flips = roughness(x, f, run, step)
    return rough > NOISY_ROUGHNESS and flips > NOISY_SIGN_FLIPS


def _wls_roots(t: np.ndarray, y: np.ndarray, sig: np.ndarray, skips: int
               ) -> list[tuple[float, float] | None]:
    """Per k < ``skips``: root (t < 0 side rising inwards: f**2 falls towards +t) and its
    standard deviation of the weighted least-squares quadratic (linear with 3 points) of y(t)
    through the points after the first k; None without one (see :func:`_wls_roots_of`)."""
    fit = next(_wls_roots_of([_wls_design(t, y, sig)], skips))
    return [fit(k) for k in range(skips)]


def _wls_design(t: np.ndarray, y: np.ndarray, sig: np.ndarray) -> np.ndarray:
    """The weighted least-squares problem ``[1, t, t**2 | y] / sig`` (n x 4) of
    :func:`_wls_roots` (the columns of np.vander(t, 3, increasing=True), then y); one per row
    of ``sig`` (B x n: B x n x 4)."""
    cols = np.empty((t.size, 4))
    cols[:, 0], cols[:, 1], cols[:, 2], cols[:, 3] = 1.0, t, t * t, y
    return cols / sig[..., None]


def _wls_roots_of(designs: list[np.ndarray], skips: int
                  ) -> Iterator[Callable[[int], tuple[float, float] | None]]:
    """:func:`_wls_roots` of each of ``designs`` (:func:`_wls_design`) in turn, as a function
    of k (< ``skips``) that solves fit k when called: every fit's factor from one stacked
    Householder QR (:func:`_nested_qr`), its root and deviation only when asked for.

    The QR of a design less its first k rows gives its triangular factor R, ``Q^T y`` and the
    residual norm: the coefficients are R's back substitution and the root's variance
    ``s**2 |R^-T g|**2`` (g = (1, t0, t0**2); s**2 (R^T R)^-1 is the coefficients' covariance,
    s**2 the residual variance).  A fit whose R is numerically singular (or not finite) is
    :func:`_wls_root_lstsq`'s.  Each fit equals, to the last bit, that of the design without
    the dropped rows and of the design alone, and the exact least-squares fit of the same data
    to ~1e-13 (tests/unit/test_wls_fits.py, test_edge_noise.py)."""
    counts = [min(skips, d.shape[0]) for d in designs]
    factors = _nested_qr(designs, counts).tolist()
    first = 0
    for design, count in zip(designs, counts, strict=True):
        yield functools.partial(_wls_fit_k, factors[first:first + count], design)
        first += count


def _wls_fit_k(factors: list, design: np.ndarray, k: int) -> tuple[float, float] | None:
    """Fit k of a design (:func:`_wls_fit`; None beyond its factors)."""
    return _wls_fit(factors[k], design[k:]) if k < len(factors) else None


def _wls_fit(r: list, design: np.ndarray) -> tuple[float, float] | None:
    """(root, standard deviation) of one fit of :func:`_wls_roots_of` from its R (nested
    lists, 4 x 4 upper triangle of the QR of ``design``); None without a root."""
    m = design.shape[0]
    if m < 2:
        return None
    deg = 2 if m >= 4 else 1
    (r00, r01, r02, r03), (_, r11, r12, r13), (_, _, r22, r23), (_, _, _, r33) = r
    d0, d1, d2 = abs(r00), abs(r11), abs(r22) if deg == 2 else abs(r11)
    if not min(d0, d1, d2) > max(m, deg + 1) * _EPS * max(d0, d1, d2):
        return _wls_root_lstsq(design[:, :deg + 1], design[:, 3], deg)
    c2 = r23 / r22 if deg == 2 else 0.0
    c1 = (r13 - r12 * c2) / r11
    c0 = (r03 - r01 * c1 - r02 * c2) / r00
    t0 = _nearest_root(c0, c1, c2, -1)
    if t0 is None:
        return None
    dof = m - deg - 1
    rss = r33 ** 2 + (r23 ** 2 if deg == 1 else 0.0)
    s2 = rss / dof if dof > 0 else 0.0
    w0 = 1.0 / r00  # R^T w = g by forward substitution
    w1 = (t0 - r01 * w0) / r11
    w2 = (t0 * t0 - r02 * w0 - r12 * w1) / r22 if deg == 2 else 0.0
    var = s2 * (w0 * w0 + w1 * w1 + w2 * w2)
    return t0, math.sqrt(max(var, 0.0)) / abs(c1 + 2 * c2 * t0)


#: Rows of the stacked matrices of :func:`_nested_qr` (zeros below the data): a fixed shape up to
#: BAND_MAX points, so that a fit's factor does not depend on how many points were dropped.
_QR_ROWS = 32


def _nested_qr(mats: list[np.ndarray], counts: list[int]) -> np.ndarray:
    """Triangular factors R (sum(counts), c, c; the upper triangle, below it the reflectors) of
    the Householder QR of ``a[k:]`` for each ``a`` (n x c, n >= 1) of ``mats`` and k = 0 ..
    its count - 1, in that order, from one stacked ``numpy.linalg.qr``: each ``a[k:]`` is padded
    with zero rows (which change no factor) to max(n, c, _QR_ROWS) rows over all ``mats``, the
    same shape for every n <= _QR_ROWS, so the upper triangle of each factor does not depend on
    what else was stacked, nor on whether the dropped rows were there (to the last bit)."""
    c = mats[0].shape[1]
    stack = np.zeros((sum(counts), max(max(a.shape[0] for a in mats), c, _QR_ROWS), c))
    j = 0
    for a, count in zip(mats, counts, strict=True):
        for k in range(count):
            stack[j, :a.shape[0] - k] = a[k:]
            j += 1
    h = np.linalg.qr(stack, mode="raw")[0]  # R^T in the leading c columns of h's rows
    return np.swapaxes(h[..., :c], -1, -2)


def _wls_root_lstsq(basis: np.ndarray, rhs: np.ndarray, deg: int) -> tuple[float, float] | None:
    """One fit of :func:`_wls_roots_of` by minimum-norm least squares (``np.linalg.lstsq``) and
    the pseudo-inverse of its normal matrix: for a design that is numerically rank-deficient
    (e.g. repeated t), where the triangular factor cannot be inverted."""
    c = np.linalg.lstsq(basis, rhs, rcond=None)[0]
    c1, c2 = float(c[1]), float(c[2]) if deg == 2 else 0.0
    t0 = _nearest_root(float(c[0]), c1, c2, -1)
    if t0 is None:
        return None
    dof = rhs.size - deg - 1
    r = rhs - basis @ c
    s2 = float(r @ r) / dof if dof > 0 else 0.0
    g = t0 ** np.arange(deg + 1)
    cov = s2 * np.linalg.pinv(basis.T @ basis)
    return t0, float(np.sqrt(max(g @ cov @ g, 0.0))) / abs(c1 + 2 * c2 * t0)


def band_edge(x: np.ndarray, f: np.ndarray, run: tuple[int, int], step: int,
              scale: np.ndarray | None = None) -> tuple[float, float]:
    """Zero of f beyond the end of the run in direction ``step`` from the weighted band fit of
    f**2 (see BAND_FRACTION .. BAND_COVER), and its uncertainty (both lengths; NaN if no fit).

    The band is halved (down to BAND_MIN nodes) while its fit disagrees with the half band's
    beyond their combined uncertainty: f**2 is smooth only up to the nearest kink (e.g. a former
    stick edge inside a stage-3 stick zone).  ``scale``: the magnitude that carries the nodal
    noise (default f itself: relative noise of the pressure; mu p for a stick edge, where
    mu p - |q| -> 0 but its noise does not)."""
    bands = [_band(run, step, np.maximum(f, 0.0))]
    while bands[-1].size // 2 >= BAND_MIN:
        bands.append(bands[-1][:bands[-1].size // 2])
    fits = _band_fits(x, f, bands, step, scale)  # a half band's fit is taken only when needed
    fit = next(fits)
    for half in fits:
        if math.isfinite(fit[0]) and math.isfinite(half[0]) and abs(fit[0] - half[0]) <= \
                math.hypot(fit[1], half[1]) * BAND_HALVE:
            return fit
        fit = half
    return fit


def _band_fits(x: np.ndarray, f: np.ndarray, bands: list[np.ndarray], step: int,
               scale: np.ndarray | None) -> Iterator[tuple[float, float]]:
    """(edge, uncertainty) of the band fit of each of ``bands`` (nodes from the run's end
    inwards, each a prefix of the first) in turn; their least-squares problems are solved
    together (:func:`_wls_roots_of`)."""
    nodes = bands[0]
    end = nodes[0]
    if nodes.size < 2 or not 0 <= end + step < x.size:
        yield from [(math.nan, math.nan)] * len(bands)
        return
    h = abs(float(x[end + step] - x[end]))
    t = (x[nodes] - x[end]) * step / h
    fn = np.maximum(f[nodes], 0.0)
    sc = np.abs(fn if scale is None else scale[nodes])
    sizes = [band.size for band in bands]
    floor = BAND_NOISE_FLOOR * np.maximum.accumulate(sc)[np.array(sizes) - 1]  # of each band
    floor[floor == 0] = 1.0
    sig = np.maximum(fn, floor[:, None]) * np.maximum(sc, floor[:, None])  # a row per band
    designs = _wls_design(t, fn ** 2, sig)
    for fits in _wls_roots_of([d[:m] for d, m in zip(designs, sizes, strict=True)], BAND_SKIPS):
        yield _band_choice(fits, float(x[end]), step, h)


def _band_choice(fit: Callable[[int], tuple[float, float] | None], x_end: float, step: int,
                 h: float) -> tuple[float, float]:
    """(edge, uncertainty) from a band's fits ``fit(k)`` skipping k = 0, 1, ... end nodes
    (BAND_SKIPS, BAND_AGREE, BAND_COVER); fit k + 1 is solved only when fit k is not taken."""
    fits, k = [fit(0)], None
    for j in range(BAND_SKIPS - 1):
        fits.append(fit(j + 1))
        a, b = fits[j], fits[j + 1]
        if a and b and abs(a[0] - b[0]) <= BAND_COVER * math.hypot(a[1], b[1]) + BAND_AGREE:
            k = j
            break
    if k is None:
        k = next((j for j in range(BAND_SKIPS - 1, -1, -1) if fits[j]), None)
        if k is None:
            return math.nan, math.nan
    t0, sd = fits[k]
    nxt = fits[k + 1][0] if k + 1 < BAND_SKIPS and fits[k + 1] else t0
    return x_end + step * h * t0, h * math.hypot(BAND_COVER * sd, nxt - t0)


def edge_estimate(x: np.ndarray, f: np.ndarray, run: tuple[int, int], step: int,
                  scale: np.ndarray | None = None, trust: float = math.inf,
                  to_peak: bool = False) -> tuple[float, float]:
    """One rule for every code's nodal data: (edge, uncertainty) of the zero of f beyond the
    run's end (``to_peak``: whether it is noisy is judged from the run's end to f's inner peak,
    :func:`_through_peak`).  Noisy data (:func:`is_noisy`) take the band fit and its own
    uncertainty when it lies within ``trust`` elements of :func:`sqrt_edge` (stick edges:
    BAND_TRUST); else, and on smooth data, :func:`sqrt_edge` is the edge, with the uncertainty
    the larger of the band fit's own and the two estimates' distance (smooth data), or of
    ``trust`` elements and the distance to the line through the two outermost nodes (noisy data
    the band does not fit)."""
    e_band, u_band = band_edge(x, f, run, step, scale)
    e = sqrt_edge(x, f, run, step)
    h = 2.0 * _half_element(x, run, step)
    if not math.isfinite(e_band):
        return e, _half_element(x, run, step)
    if is_noisy(x, f, _through_peak(run, step, f) if to_peak else run, step):
        if abs(e - e_band) <= trust * h:
            return e_band, u_band
        return e, max(trust * h, _two_node_spread(x, f, run, step, e))
    return e, max(u_band, abs(e - e_band))


def _through_peak(run: tuple[int, int], step: int, f: np.ndarray) -> tuple[int, int]:
    """The run from its end in direction ``step`` inwards through the last node of its
    ``to_peak`` band when that band ends at an inner peak of f (else the whole run)."""
    fp = np.maximum(f, 0.0)
    band = _band(run, step, fp, to_peak=True)
    if band.size == _band(run, step, fp).size:
        return run
    last = int(band[-1])
    return (run[0], last) if step < 0 else (last, run[1])


def _half_element(x: np.ndarray, run: tuple[int, int], step: int) -> float:
    end = _inward(run, step)[0]
    nb = end + step if 0 <= end + step < x.size else end - step
    return 0.5 * abs(float(x[nb] - x[end]))


def _two_node_spread(x: np.ndarray, f: np.ndarray, run: tuple[int, int], step: int,
                     e: float) -> float:
    """Distance of ``e`` from the root of the line through f**2 at the run's two outermost nodes
    (within :func:`edge_bounds`): an independent estimate; half an element without one."""
    inward = _inward(run, step)
    if inward.size < 2:
        return _half_element(x, run, step)
    root = power_root(x[inward[:2]], f[inward[:2]] ** 2, x[inward[0]], -step)
    if root is None:
        return _half_element(x, run, step)
    lo, hi = edge_bounds(x, int(inward[0]), step)
    return abs(float(np.clip(root, lo, hi)) - e)


def gap_edge(x: np.ndarray, gap: np.ndarray, status: np.ndarray, end: int, step: int,
             run_nodes: int = 0) -> float | None:
    """Edge from the open side: zero of gap**(2/3) (smooth through a sqrt edge, where the gap
    grows like distance**1.5) fitted at the GAP_FIT open nodes after the GAP_SKIP first ones
    beyond node ``end`` in direction ``step`` (more on a long contact run of ``run_nodes``
    nodes: GAP_OF_RUN .. GAP_FIT_MAX); None without enough open nodes of finite gap or if the
    root is not within :func:`edge_bounds`."""
    wide = run_nodes // GAP_OF_RUN >= GAP_WIDE
    fit = min(run_nodes // GAP_OF_RUN, GAP_FIT_MAX) if wide else GAP_FIT
    skip = GAP_SKIP_WIDE if wide else GAP_SKIP
    ahead = end + step * np.arange(1, skip + fit + 1)
    ahead = ahead[(ahead >= 0) & (ahead < x.size)]
    usable = (status[ahead] == OPEN) & np.isfinite(gap[ahead])
    nodes = ahead[skip:usable.size if usable.all() else int(np.argmin(usable))]
    if nodes.size < 2:
        return None
    root = power_root(x[nodes], np.maximum(gap[nodes], 0.0) ** (2 / 3), x[end], step,
                      2 if wide else 1)
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
    """Edges of each contact run (status > OPEN), see :func:`contact_edge_estimates`."""
    return [(a, b) for (a, _), (b, _) in contact_edge_estimates(x, p, status, candidate, gap)]


def contact_edge_estimates(x, p, status, candidate, gap=None) -> list[tuple[tuple, tuple]]:
    """Per contact run (status > OPEN): ((a, u_a), (b, u_b)), each edge with its uncertainty.

    A run bounded by a non-candidate node (beyond a sharp corner) or whose pressure rises to its
    end (a singular edge, p ~ 1/sqrt, at a corner node) ends at its last node (uncertainty 0);
    otherwise the edge is taken from the gap side (:func:`gap_edge`) when ``gap`` is given and
    there are enough open nodes, else from the pressure side (:func:`edge_estimate`); a gap-side
    edge's uncertainty is the larger of the pressure side's and the two sides' distance."""
    return _edge_estimates_of(x, p, status, candidate, gap, runs(status > OPEN))


def _edge_estimates_of(x, p, status, candidate, gap, contact: list[tuple[int, int]]
                       ) -> list[tuple[tuple, tuple]]:
    """:func:`contact_edge_estimates` of the contact runs ``contact``."""
    out = []
    for i0, i1 in contact:
        ends = []
        for end, step in ((i0, -1), (i1, 1)):
            if not 0 <= end + step < x.size or not candidate[end + step] or \
                    rising_to_edge(p, (i0, i1), end, step):
                ends.append((float(x[end]), 0.0))
                continue
            g = gap_edge(x, gap, status, end, step, i1 - i0 + 1) \
                if gap is not None else None
            e, u = edge_estimate(x, p, (i0, i1), step)
            ends.append((e, u) if g is None else (g, max(u, abs(g - e))))
        out.append((ends[0], ends[1]))
    return out


def rising_to_edge(p: np.ndarray, run: tuple[int, int], end: int, step: int) -> bool:
    """True if the pressure rises towards the run's end node (a singular edge: p ~ 1/sqrt)."""
    return run[0] < run[1] and p[end] >= p[end - step]


def stick_edge(x, p, q, mu: float, run: tuple[int, int], step: int) -> float:
    """Edge of a stick run next to a slip node, see :func:`stick_edge_estimate`."""
    return stick_edge_estimate(x, p, q, mu, run, step)[0]


def stick_edge_estimate(x, p, q, mu: float, run: tuple[int, int], step: int
                        ) -> tuple[float, float]:
    """(edge, uncertainty) of a stick run next to a slip node: the zero of ``mu p - s q``,
    s = sign of q in that slip zone (q = s mu p there), which is sqrt-shaped across the stick
    edge (Jaeger-Ciavarella: mu p_S of the reduced problem), also where q changes sign in the
    stick zone; located by :func:`edge_estimate` (noise carried by mu p) trusting the band fit
    only within BAND_TRUST elements of :func:`sqrt_edge`: mu p - s q of a stage-3 stick zone
    peaks at a kink (the frozen stage-2 stick edge) a few nodes in, which the band crosses (on
    Kratos' cattaneo result it put stage-3 stick edges up to 5 elements off); so the noise test
    looks at the nodes from the stick edge to that peak only (``to_peak``): there f is one
    smooth branch (2 mu p0 (c'/a) sqrt(1 - x^2/c'^2)), noise of the stage-2 stick zone beyond it
    does not make it noisy (Kratos level 1: the band was taken, 0.9 element off)."""
    end = run[1] if step > 0 else run[0]
    s = np.sign(q[end + step]) or np.sign(q[end]) or 1.0
    f = np.maximum(mu * p - s * q, 0.0)
    stick = _stick_run(f, p, run, step)
    if stick[1] - stick[0] + 1 < MIN_STICK_FIT:
        return _between_nodes(x, stick[1] if step > 0 else stick[0], step)
    return edge_estimate(x, f, stick, step, scale=mu * p, trust=BAND_TRUST, to_peak=True)


#: A stick run of fewer nodes holds no shape of mu p - s q to fit: its edge lies somewhere
#: between its end node and the next (a two-node stick zone at Q = 0.999 mu P: the fit of two
#: equal values put one edge on the slip node, the other half-way, by the sign of round-off,
#: with an uncertainty of 3e9 lengths).
MIN_STICK_FIT = 3


def _between_nodes(x: np.ndarray, end: int, step: int) -> tuple[float, float]:
    """(the middle between the run's end node and the next one out, half their distance): an
    edge known only to lie between the two."""
    lo, hi = sorted((float(x[end]), float(x[end + step])))
    return 0.5 * (lo + hi), 0.5 * (hi - lo)


#: A node flagged slip next to a stick run still belongs to it when mu p - s q there exceeds
#: this fraction of the run's largest: a slip node has |q| = mu p (Kratos: to 2e-5 of mu p, our
#: FE: to round-off), so only a wrong flag does (then the edge lies beyond it).
STICK_FLAG_SLACK = 0.05


def _stick_run(f: np.ndarray, p: np.ndarray, run: tuple[int, int], step: int
               ) -> tuple[int, int]:
    """The stick run extended in direction ``step`` over contact nodes flagged slip whose f is
    clearly positive (STICK_FLAG_SLACK)."""
    i0, i1 = run
    top = float(np.max(f[i0:i1 + 1]))
    j = i1 if step > 0 else i0
    while 0 <= j + 2 * step < f.size and p[j + 2 * step] > 0 and \
            f[j + step] > STICK_FLAG_SLACK * top:
        j += step
    return (i0, j) if step > 0 else (j, i1)


def contact_and_stick(x, p, q, status, candidate, mu, gap=None) -> tuple[tuple, tuple]:
    """Contact zones (p -> 0) and their stick zones (mu p - |q| -> 0), aligned: per contact
    zone the span of its stick runs (None: full slip); a stick run reaching the end of its
    contact run ends at the contact edge.  See :func:`zones_with_uncertainty`."""
    return zones_with_uncertainty(x, p, q, status, candidate, mu, gap)[:2]


#: A stick run of at most this many nodes is a stray flag (a code's noisy stick/slip flag, or a
#: status derived from |q| vs mu p where both are nearly zero) when the contact zone holds a
#: longer stick run, or when it sits at the zone's end node (a stick zone lies inside its contact
#: zone; at the edge p -> 0 and |q| <= mu p holds within the noise whatever the state): it does
#: not make or extend a stick zone.
STRAY_STICK_NODES = 1


def stick_runs_of_zone(inside: list, run: tuple[int, int]) -> list:
    """The stick runs (index ranges) of one contact run ``run`` that make its stick zone: those
    left when the stray flags (STRAY_STICK_NODES) are dropped."""
    long_runs = [r for r in inside if r[1] - r[0] + 1 > STRAY_STICK_NODES]
    if long_runs:
        return long_runs
    return [r for r in inside if r[0] not in run and r[1] not in run]


#: A node flagged stick whose shear is at the cone to this fraction of mu p counts as slip for
#: the zones: tractions cannot tell the two apart there, the flag is the return mapping's tie
#: (at Q = mu P every node must be at the cone, sum q = mu sum p; our FE flagged two of them
#: stick, at the cone to 4e-14, a stick zone of up to 1.8 elements where there is none).
AT_CONE_RTOL = 1e-9


def effective_sticks(p: np.ndarray, q: np.ndarray, status: np.ndarray, mu: float
                     ) -> list[tuple[int, int]]:
    """Runs of stick nodes whose shear is not at the cone (:data:`AT_CONE_RTOL`)."""
    inside = mu * p - np.abs(q) > AT_CONE_RTOL * mu * p
    return runs((status == STICK) & inside)


def zones_with_uncertainty(x, p, q, status, candidate, mu, gap=None
                           ) -> tuple[tuple, tuple, tuple, tuple]:
    """(contact zones, stick zones, their edges' uncertainties): :func:`contact_and_stick` with
    per contact zone (u_a, u_b) and per stick zone (u_c, u_d) or None (lengths)."""
    contact = runs(status > OPEN)
    est = _edge_estimates_of(x, p, status, candidate, gap, contact)
    sticks = effective_sticks(np.asarray(p, float), np.asarray(q, float), np.asarray(status),
                              mu)
    aligned, unc = [], []
    for ((a, ua), (b, ub)), (i0, i1) in zip(est, contact, strict=True):
        inside = stick_runs_of_zone([r for r in sticks if i0 <= r[0] and r[1] <= i1],
                                    (i0, i1))
        if not inside:
            aligned.append(None)
            unc.append(None)
            continue
        c, uc = (a, ua) if inside[0][0] == i0 else stick_edge_estimate(x, p, q, mu, inside[0],
                                                                         -1)
        d, ud = (b, ub) if inside[-1][1] == i1 else stick_edge_estimate(x, p, q, mu,
                                                                          inside[-1], +1)
        aligned.append((float(c), float(d)))
        unc.append((float(uc), float(ud)))
    zones = tuple((a, b) for (a, _), (b, _) in est)
    return zones, tuple(aligned), tuple((ua, ub) for (_, ua), (_, ub) in est), tuple(unc)


__all__ = ["FemInterface", "FemStep", "band_edge", "contact_and_stick", "edge_estimate",
           "gap_edge", "runs", "sqrt_edge", "zones_with_uncertainty", "OPEN", "STICK", "SLIP"]
