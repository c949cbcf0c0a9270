"""Independent a-posteriori check of a normal solution (issue 13).

It uses only what a solution returns - its zones, singular flags, zone loads, P, M, theta,
``pressure(x)`` - and the profile ``h0``; none of the solved equations (consistency,
interconnection, the contour loads or the gap integrals).  From the pressure alone:

- ``int p dx`` over every zone equals the reported zone load, their sum equals P, and
  ``int x p dx`` equals M;
- the rigid approach ``delta(x) = h0(x) - theta x + u(x)`` with the relative normal
  displacement ``u(x) = -(A/pi) int p(s) ln|x - s| ds`` is the same at points inside every zone
  (contact condition and rigid interconnection, paper Eq. 17, together);
- ``p >= 0`` at every quadrature node, and the deformed gap ``g = h0 - theta x - delta + u >= 0``
  outside the zones on a grid graded towards every edge and kink;
- no zone holds a point where h0 is infinite or a corner where h0 steps, and a singular edge
  sits at a corner or ridge of the profile.

One quadrature serves every integral: each zone is cut at its edges, at the profile's kinks and
at the approach targets, every piece is halved, and on each half ``t = L u^2`` (distance t from
its end): the edge factors ``d^(1/2)`` and ``d^(-1/2)`` of p become smooth in u and the log
singularities (p at a wedge apex, the kernel at a target) become ``u ln u``.  The Gauss-Legendre
panels in u are graded geometrically (ratio ``GRADING``) towards the end, down to the scale of
the nearest other feature.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from analytic.errors import ConvergenceError
from analytic.profiles import Profile

LOAD_TOL = 2e-9
"""|int p - reported| per zone and in total, relative to P.  Measured worst 4.3e-10: a
circular-cornered punch whose free edges lie 2e-8 short of its arcs' vertical ends
(tests/verification/test_corner_end.py), a margin of 4.6; 1.1e-10 on the next (a tilted sharp
punch beside a cylinder), <= 4.4e-11 on the rest.  Measured over the solves of the analytic
test files of the fast suite (785 checks with EDGE_ROUNDING < 1e-12), the 16 library cases, the
audit regression list and audit seeds 0-599 and 100000-100299 (927 solves).  It was 1e-8 until
the double wedge of 0.01 / 0.02 rad at P = 0.5 (two zones 12.6 wide, 6.4e-3 apart across the
ridge) stopped reaching 5.2e-9: the local pressure rule beside its apexes and the zone loads'
contour rule now resolve the close neighbour (analytic._zone_quadrature.NEIGHBOUR_REACH,
analytic._contour.CONTOUR_MAX; 9.4e-12 now).  The wrong answers of issue 13 were off by 1e-6 ..
6e-4, tabulated splines before their knot cuts by 6.5e-8."""
MOMENT_TOL = 1e-9
"""|int x p - M| relative to P times the largest |x| of an edge (the load's lever arm).
Measured worst 4.3e-11 (audit seed 386; 3.4e-11 on seed 100153): a margin of 23."""
APPROACH_TOL = 2e-8
"""Spread of delta over all targets, relative to A P.  Measured worst 1.4e-9 where
HEIGHT_ROUNDING adds < 2e-10 (audit seed 515, a parabolic punch beside cylinders), 6.4e-10 on
Hertz zones (the check's own log-kernel quadrature, LOG_DEPTH): a margin of 14.  The wrong
answers of issue 13 spread by 1e-3 .. 1e-1."""
PRESSURE_TOL = 1e-9
"""min p relative to the mean pressure P / (sum of zone widths) (rounding near an edge; the
measured figure is 0 on every solve above: p >= 0 at every node)."""
GAP_TOL = 1e-8
"""min deformed gap outside the zones relative to A P (measured worst 1.4e-10, Gladwell's
zones about to merge: a margin of 70)."""
EDGE_ROUNDING = 10.0
"""Load and moment are also allowed this times ``eps max|x| / l`` (l the shortest piece between
a zone's edges and kinks): an edge stored as x rounds by eps |x|, which is a relative error
eps |x| / l of a piece l long (the solver's Newton stops there, :mod:`analytic._newton`).  A
rounded punch's edge 4e-9 past its corner's kink at P = 1e-12 reaches 0.1 of eps |x| / l, at
P = 1e-11 (parabolic) 0.7: int p off P by 5e-9 and 8e-9, both confirmed by the audit's
independent quadrature."""
HEIGHT_ROUNDING = 1e-12
"""The approach and the gap are also allowed this times ``|h'| span / (A P)`` (``|h'|`` the mean
slope of h0 - theta x in the zones, span the hull of the zones): the profile's relief between
zones far apart, across which the rigid interconnection (paper Eq. 17) is solved to a relative
1e-13 of it (its Newton row is scaled by A P + |h'| span).  The double wedge at P = 1e-6 (zones
1e-5 wide, 2 apart, |h'| ~ 0.1) spreads delta by 3.1e-8 A P = 1.5e-13 |h'| span."""
LOAD_CEILING = 1e-8
"""Load and moment tolerances with their allowance never exceed this (the tolerance before
issue 29: the allowances tighten the check where rounding permits, they never loosen it)."""
HEIGHT_CEILING = 1e-7
"""The same for the approach and the gap."""
GRADING = 4.0
"""Ratio of neighbouring panels of the graded rule."""
PANEL_NODES = 8
"""Gauss nodes per panel (loads to ~4e-12 P, delta to ~6e-10 A P on cylinders) ..."""
KINKED_PANEL_NODES = 10
"""... and in a zone with kinks (8 left 4e-10 P on a rounded punch whose edge lies 1e-3 of the
face width beyond the corner's kink; 10 give 6e-12 P)."""
LOG_DEPTH = 4
"""Graded u-panels at least towards an approach target (innermost u < 4^-4, t < 4e-6 of the
half; the kernel is log-singular there: delta to ~4e-10 A P on cylinders)."""
KINK_DEPTH = 6
"""... and towards a kink, where p itself may be log-singular (a wedge apex: loads to 1e-11 P;
4 levels left 6e-10 P)."""
VERTICAL_DEPTH = 8
"""... and towards an edge pinned at a vertical end (the end of a circular corner), where
``p ~ (K + c ln d) d^(-1/2)`` is log-singular in u (loads off by 5e-7 P with 4 levels on the
punch pinned at its arcs' ends).  The rest, ``d < delta = 4^-16`` of the half (~2e-10), is the
closed form ``int_0^delta p = 2 delta p(delta) - 4 c sqrt(delta)`` (error ~delta^(3/2)): Gauss
nodes there round in x (a node 1 ulp from the end put 5e-8 P into the load)."""
FINEST = 1e-11
"""Innermost panel at least this times |x|: its nodes stay ~1e-12 |x| from the point (p itself
is not computable closer to a kink, where x rounds)."""
GAP_POINTS = (1e-3, 0.03, 0.2, 0.5, 0.8, 0.97, 0.999)
"""Gap samples across every gap (fractions), and beyond the outer edges (times the span)."""


@dataclass(frozen=True)
class Rule:
    """Nodes ``x`` and weights ``w`` with ``int_zone f dx ~ sum w f(x)``; ``zone`` per node."""

    x: np.ndarray
    w: np.ndarray
    zone: np.ndarray
    tails: tuple[tuple[float, float, float, int], ...] = ()
    """(end, delta, direction, zone) of every half whose part ``d < delta`` at a vertical end
    is left to the closed form (:func:`with_tails`)."""


@lru_cache(maxsize=8)
def _legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    t, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (t + 1.0), 0.5 * w


@lru_cache(maxsize=64)
def _graded_reference(depth: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes u in (0, 1) and weights of ``int_0^1 2 u f(u^2) du`` on Gauss-Legendre panels
    ``[GRADING^-(m+1), GRADING^-m]``, m < depth, and ``[0, GRADING^-depth]``."""
    bounds = np.append(GRADING ** -np.arange(depth + 1.0), 0.0)
    u, w = _legendre(n)
    lo, hi = bounds[1:], bounds[:-1]
    uu = (lo[:, None] + (hi - lo)[:, None] * u).ravel()
    return uu * uu, 2.0 * uu * ((hi - lo)[:, None] * w).ravel()


def graded_half(end: float, length: float, direction: float, finest: float,
                n: int = PANEL_NODES, tail: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights on ``[end, end + direction length]`` after ``t = length u^2``: an edge
    factor ``t^(+-1/2)`` times ``dt = 2 length u du`` is smooth in u, a log singularity becomes
    ``u ln u``.  Gauss-Legendre panels of n nodes in u shrink geometrically towards ``u = 0``
    until the innermost is at most ``sqrt(finest / length)`` (``finest`` in x); ``tail``:
    without the innermost panel (``t < length GRADING^(-2 depth)``)."""
    t, w = _graded_reference(graded_depth(length, finest), n)
    if tail:
        t, w = t[:-n], w[:-n]
    return end + direction * length * t, length * w


def graded_depth(length: float, finest: float) -> int:
    """Levels of :func:`graded_half` for its innermost panel to reach ``finest``."""
    u_min = math.sqrt(max(finest, 1e-300) / length)
    return max(1, math.ceil(-math.log(min(u_min, 1.0)) / math.log(GRADING)))


def zone_rule(zones: list[tuple[float, float]], cuts: list[list[float]],
              kinks: list[list[float]], span: float, vertical: tuple[float, ...] = (),
              marks: tuple[float, ...] = ()) -> Rule:
    """The graded rule on every zone cut at ``cuts[k]`` (kinks and targets inside zone k), each
    piece halved, each half graded towards its end (deeper at the ``kinks`` and at edges on a
    ``vertical`` end of the profile; towards an edge as deep as the nearest zone or profile
    ``marks`` beyond it)."""
    xs, ws, zs, tails = [], [], [], []
    for k, (a, b) in enumerate(zones):
        pts = [a, *cuts[k], b]
        outside = _outside_clearance(zones, k, span, marks)
        n = KINKED_PANEL_NODES if kinks[k] else PANEL_NODES
        for i in range(len(pts) - 1):
            half = 0.5 * (pts[i + 1] - pts[i])
            for j, direction in ((i, 1.0), (i + 1, -1.0)):
                at_end = pts[j] in vertical and j in (0, len(pts) - 1)
                depth = (VERTICAL_DEPTH if at_end else
                         KINK_DEPTH if pts[j] in kinks[k] else LOG_DEPTH)
                finest = _finest(pts, j, half, outside, depth)
                x, w = graded_half(pts[j], half, direction, finest, n, at_end)
                if at_end:
                    delta = half * GRADING ** (-2 * graded_depth(half, finest))
                    tails.append((pts[j], delta, direction, k))
                xs.append(x)
                ws.append(w)
                zs.append(np.full(x.size, k))
    return Rule(np.concatenate(xs), np.concatenate(ws), np.concatenate(zs), tuple(tails))


def with_tails(rule: Rule, profile: Profile, A: float) -> tuple[Rule, np.ndarray]:
    """The rule with one node at ``end + delta`` per tail (weight ``2 delta``) and the constants
    ``-4 c sqrt(delta)`` (``c = kappa / (pi A)``) that complete ``int_0^delta p``: with
    ``p = (K + c ln d) d^(-1/2)`` that integral is ``2 delta p(delta) - 4 c sqrt(delta)``."""
    if not rule.tails:
        return rule, np.zeros(rule.x.size)
    end, delta, direction, zone = (np.array(v) for v in zip(*rule.tails, strict=True))
    c = np.array([profile.vertical_strength(e) for e in end.tolist()]) / (np.pi * A)
    x = np.concatenate([rule.x, end + direction * delta])
    w = np.concatenate([rule.w, 2.0 * delta])
    const = np.concatenate([np.zeros(rule.x.size), -4.0 * c * np.sqrt(delta)])
    return Rule(x, w, np.concatenate([rule.zone, zone.astype(int)])), const


def _outside_clearance(zones: list[tuple[float, float]], k: int, span: float,
                       marks: tuple[float, ...] = ()) -> float:
    """Distance from zone k to the nearest other zone (the span for a single zone) or profile
    mark (kink or corner) outside it: p varies on that scale at the edge (a rounded punch's
    edge 1e-8 short of its arc's end: loads 1.5e-8 P off when graded to the span only)."""
    a, b = zones[k]
    d = [zones[k][0] - zones[k - 1][1]] if k > 0 else []
    d += [zones[k + 1][0] - zones[k][1]] if k + 1 < len(zones) else []
    d += [a - q for q in marks if q < a] + [q - b for q in marks if q > b]
    return min(d) if d else span


def _finest(pts: list[float], j: int, half: float, outside: float, depth: int) -> float:
    """Innermost panel towards ``pts[j]`` (x scale): a quarter of the piece beyond it (of the
    distance to the next zone at an edge), and ``depth`` levels in u at least."""
    beyond = [pts[j] - pts[j - 1]] if j > 0 else [outside]
    beyond += [pts[j + 1] - pts[j]] if j + 1 < len(pts) else [outside]
    finest = min(0.25 * min(beyond + [half]), half * GRADING ** (-2 * depth))
    return max(finest, FINEST * abs(pts[j]), 1e-300)


def approach_targets(zones: list[tuple[float, float]], singular: list[tuple[bool, bool]],
                     kinks: list[list[float]]) -> list[list[float]]:
    """Per zone: its nonsingular edges, its kinks and the middle of every piece between its
    edges and kinks (at a singular edge ``p ln|x - s| ~ ln(u)/u^0`` needs a far deeper rule)."""
    out = []
    for (a, b), sing, ks in zip(zones, singular, kinks, strict=True):
        pts = [a, *ks, b]
        mids = [0.5 * (lo + hi) for lo, hi in zip(pts[:-1], pts[1:], strict=True)]
        ends = [e for e, s in ((a, sing[0]), (b, sing[1])) if not s]
        if len(ends) + len(ks) + len(mids) < 3:  # e.g. a punch pinned at both corners
            lo, hi = max(zip(pts[:-1], pts[1:], strict=True), key=lambda z: z[1] - z[0])
            mids += [0.75 * lo + 0.25 * hi, 0.25 * lo + 0.75 * hi]
        out.append(sorted([*ends, *ks, *mids]))
    return out


def log_potential(rule: Rule, wp: np.ndarray, x: np.ndarray, A: float) -> np.ndarray:
    """``u(x) = -(A/pi) int p(s) ln|x - s| ds`` by the rule.  A node that rounds onto its
    target (zones a few ulps wide) has a negligible weight; its distance is floored at an ulp."""
    ulp = 4 * np.finfo(float).eps * np.maximum(np.abs(x), np.max(np.abs(rule.x)))
    kernel = np.log(np.maximum(np.abs(x[:, None] - rule.x[None, :]), ulp[:, None]))
    return -(A / np.pi) * (kernel @ wp)


def gap_points(zones: list[tuple[float, float]], profile: Profile, span: float) -> np.ndarray:
    """Samples outside the zones: across every gap, beyond the outer edges (geometric in the
    span), and either side of every kink and corner that lies outside the zones."""
    f = np.asarray(GAP_POINTS)
    e = np.ravel(zones)
    pts = [e[1:-1:2, None] + (e[2::2] - e[1:-1:2])[:, None] * f[None, :]]
    pts += [e[-1] + span * f, e[0] - span * f]
    marks = np.asarray([*profile.kinks, *profile.pin_points], float)
    d = 1e-7 * max(profile.scale, 1e-300)
    pts += [marks - d, marks + d]
    x = np.concatenate([np.ravel(q) for q in pts])
    inside = np.any((x[:, None] >= e[0::2]) & (x[:, None] <= e[1::2]), axis=1)
    return x[~inside & np.isfinite(profile.h0(x))]


def _h_zone_side(profile: Profile, zones: list[tuple[float, float]],
                 targets: list[list[float]]) -> np.ndarray:
    """h0 at the targets from the piece on the zone's side (at a corner edge the piece beyond
    it may be another member of a union, or absent)."""
    x = np.concatenate([np.asarray(t, float) for t in targets])
    mid = np.repeat([0.5 * (a + b) for a, b in zones], [len(t) for t in targets])
    idx = profile.piece_index(x + 1e-9 * (mid - x))
    out = np.full(x.shape, np.inf)
    for i in np.unique(idx[idx >= 0]).tolist():
        out[idx == i] = profile.pieces[i].h(x[idx == i])
    return out


def _inner_marks(profile: Profile, zones: list[tuple[float, float]]) -> list[list[float]]:
    return [[q for q in profile.kinks if a < q < b] for a, b in zones]


@dataclass(frozen=True)
class Figures:
    """The check's figures (all relative; see the tolerances above)."""

    load: float
    moment: float
    approach: float
    min_pressure: float
    min_gap: float
    nodes: int

    def as_residuals(self) -> dict[str, float]:
        return {"selfcheck_load": self.load, "selfcheck_moment": self.moment,
                "selfcheck_approach": self.approach,
                "selfcheck_min_pressure": self.min_pressure, "selfcheck_min_gap": self.min_gap}


def check_normal(profile: Profile, zones: list[tuple[float, float]],
                 singular: list[tuple[bool, bool]], zone_loads: list[float], P: float,
                 M: float | None, theta: float, A: float,
                 pressure: Callable[[np.ndarray], np.ndarray]) -> Figures:
    """Check a normal solution from its pressure and the profile only; raise
    :class:`ConvergenceError` with the figures when any exceeds its tolerance.  ``M`` None:
    the moment is not checked."""
    span = max(zones[-1][1] - zones[0][0], 1e-300)
    kinks = _inner_marks(profile, zones)
    targets = approach_targets(zones, singular, kinks)
    rule = zone_rule(zones, [sorted({t for t in (*ts, *profile.knots) if a < t < b}) for ts, (a, b)
                             in zip(targets, zones, strict=True)], kinks, span,
                     profile.vertical_ends, (*profile.kinks, *profile.corners))
    _check_topology(profile, zones, singular, rule)
    rule, const = with_tails(rule, profile, A)
    p = pressure(rule.x)
    figs = _figures(profile, zones, zone_loads, P, M, theta, A, rule, p, const, targets, span,
                    _log_terms(profile, zones, singular, kinks, A, rule.x))
    bad = _failures(figs, _allowances(profile, zones, theta, A, P, rule.x))
    if bad:
        raise ConvergenceError(f"the self-check of the solution failed: {', '.join(bad)}",
                               {**figs.as_residuals(), "zones": zones})
    return figs


def _log_terms(profile: Profile, zones: list[tuple[float, float]],
               singular: list[tuple[bool, bool]], kinks: list[list[float]], A: float,
               x: np.ndarray) -> np.ndarray:
    """The log term ``c ln(d / l) d^(-1/2)``, ``c = kappa / (pi A)``, of the pressure a distance
    ``d < l`` inside an edge pinned at a vertical end (``h0' ~ kappa d^(-1/2)``; l the distance
    to the nearest kink or edge of the zone), zero elsewhere.  In half-plane theory it leaves a
    tensile sliver ``d < l exp(-K/c)`` (K the stress intensity) that the small-slope model cannot
    resolve; p >= 0 is checked on ``p - log term`` (i.e. K >= 0, the sliver inside l)."""
    out = np.zeros_like(x)
    for (a, b), sing, ks in zip(zones, singular, kinks, strict=True):
        for end, s, cut in ((a, sing[0], min([*ks, b])), (b, sing[1], max([a, *ks]))):
            if not (s and end in profile.vertical_ends):
                continue
            ell = abs(cut - end)
            d = np.where((x - end) * (cut - end) > 0, np.abs(x - end), np.inf)
            c = profile.vertical_strength(end) / (np.pi * A)
            with np.errstate(divide="ignore", invalid="ignore"):
                out += np.where(d < ell, c * np.log(d / ell) / np.sqrt(d), 0.0)
    return out


def _figures(profile, zones, zone_loads, P, M, theta, A, rule, p, const, targets, span,
             log_terms) -> Figures:
    """``const``: per node, added to ``w p`` (the closed-form tails at vertical ends)."""
    wp = rule.w * p + const
    per_zone = np.bincount(rule.zone, wp, minlength=len(zones))
    load = max(np.max(np.abs(per_zone - np.asarray(zone_loads))), abs(per_zone.sum() - P)) / P
    arm = max(abs(zones[0][0]), abs(zones[-1][1]))
    moment = 0.0 if M is None else abs(np.sum(wp * rule.x) - M) / (P * arm)
    xt = np.concatenate([np.asarray(t, float) for t in targets])
    delta = _h_zone_side(profile, zones, targets) - theta * xt + log_potential(rule, wp, xt, A)
    ref = 0.5 * (delta.max() + delta.min())
    xo = gap_points(zones, profile, span)
    g = profile.h0(xo) - theta * xo - ref + log_potential(rule, wp, xo, A)
    mean_p = P / sum(b - a for a, b in zones)
    return Figures(float(load), float(moment), float(np.ptp(delta) / (A * P)),
                   float(min(np.min(p - log_terms) / mean_p, 0.0)),
                   float(min(np.min(g, initial=0.0) / (A * P), 0.0)), int(rule.x.size))


@dataclass(frozen=True)
class Allowances:
    """What the tolerances add for the floating-point limits of one solution (relative, in the
    units of :class:`Figures`): ``load`` for load and moment (EDGE_ROUNDING), ``height`` for the
    approach and the gap (HEIGHT_ROUNDING)."""

    load: float
    height: float


def _allowances(profile: Profile, zones: list[tuple[float, float]], theta: float, A: float,
                P: float, x: np.ndarray) -> Allowances:
    """EDGE_ROUNDING ``eps max|x| / l`` and HEIGHT_ROUNDING ``|h'| span / (A P)`` (see there);
    ``x`` the rule's nodes (for the mean slope)."""
    cuts = [np.array([a, *(q for q in profile.kinks if a < q < b), b]) for a, b in zones]
    shortest = min(float(np.min(np.diff(c))) for c in cuts)
    reach = max(abs(zones[0][0]), abs(zones[-1][1]))
    edge = float(np.finfo(float).eps) * reach / max(shortest, 1e-300)
    with np.errstate(invalid="ignore", divide="ignore"):  # nan beyond the support, inf at an
        dh = np.abs(profile.dh0(x) - theta)                # arc's vertical end: left out
    dh = dh[np.isfinite(dh)]
    slope = float(np.mean(dh)) if dh.size else 0.0
    height = slope * (zones[-1][1] - zones[0][0]) / (A * P)
    return Allowances(EDGE_ROUNDING * edge, HEIGHT_ROUNDING * height)


def tolerances(allow: Allowances) -> dict[str, float]:
    """The tolerance of every figure for a solution with these allowances (see the constants)."""
    load = min(LOAD_CEILING, LOAD_TOL + allow.load)
    height = min(HEIGHT_CEILING, APPROACH_TOL + allow.height)
    return {"load": load, "moment": min(LOAD_CEILING, MOMENT_TOL + allow.load),
            "approach": height, "min_pressure": PRESSURE_TOL,
            "min_gap": min(HEIGHT_CEILING, GAP_TOL + allow.height)}


def _failures(f: Figures, allow: Allowances = Allowances(0.0, 0.0)) -> list[str]:
    out = []
    tol = tolerances(allow)
    for name, value in (("load", f.load), ("moment", f.moment), ("approach", f.approach),
                        ("min_pressure", -f.min_pressure), ("min_gap", -f.min_gap)):
        if not value <= tol[name]:
            out.append(f"{name} {value:.3g} > {tol[name]:.3g}")
    return out


def _check_topology(profile: Profile, zones: list[tuple[float, float]],
                    singular: list[tuple[bool, bool]], rule: Rule) -> None:
    """No zone over infinite h0 (at the rule's nodes) or a step of h0; singular edges only at
    corners or ridges."""
    pins = set(profile.pin_points)
    lo, hi = profile.support
    if zones[0][0] < lo or zones[-1][1] > hi or (
            profile.pieces_have_gaps and not np.all(np.isfinite(profile.h0(rule.x)))):
        raise ConvergenceError("the self-check failed: a zone lies where h0 is infinite",
                               {"zones": zones})
    for (a, b), sing in zip(zones, singular, strict=True):
        steps = [q for q in profile.corners if a < q < b and h0_steps(profile, q)]
        if steps:
            raise ConvergenceError("the self-check failed: a zone spans a sharp corner "
                                   "(contact beyond it)", {"zone": (a, b), "corners": steps})
        for x, s in zip((a, b), sing, strict=True):
            if s and x not in pins:
                raise ConvergenceError("the self-check failed: a singular edge is not at a "
                                       "corner or ridge", {"edge": x})


def h0_steps(profile: Profile, q: float) -> bool:
    """Whether h0 jumps at the corner q."""
    d = 1e-9 * max(profile.scale, abs(q))
    lo, hi = profile.h0(np.array([q - d, q + d]))
    return not (np.isfinite(lo) and np.isfinite(hi)) or abs(hi - lo) > 1e-6 * profile.scale
