"""Piecewise-analytic gap profiles: :class:`Piece`, :class:`Profile` and the minima search.

A profile is a sorted set of *pieces*.  Each piece is the profile on ``[lo, hi]`` and carries an
analytic formula that stays valid a little beyond its interval (``reach``): the singular-integral
solver uses that continuation to remove near-singular Cauchy integrals at the contact edges.

Between two touching pieces the profile is continuous and its slope jumps (a *kink*, e.g. a wedge
apex).  Where a piece ends and the neighbour is higher (``h0 = +inf`` beyond a sharp punch
corner, or a step) the end is a *corner*: a contact edge can sit there as a singular edge.
:meth:`Profile.local_minima` finds where a rigidly rotated profile ``h0 - theta x`` first
touches.  The constructors users call (cylinder, flat punch, wedge, ..., union) are in
:mod:`analytic.profiles`.  Units: lengths in any consistent unit, ``h0`` in the same unit, slopes
dimensionless.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from analytic import _validate as check
from analytic._roots import brentq

Func = Callable[[np.ndarray], np.ndarray]
INF = float("inf")
MINIMA_MEMO_SIZE = 256  # rotations remembered per profile (a moment solve visits ~50)
FLAT_TILT = 1e-12  # a flat face tilted by less than this (height change / scale) stays flat,
                   # like the first-touch tolerance: its ends touch together (moment searches)

@dataclass(frozen=True)
class Piece:
    """One analytic piece of a profile, the profile on ``[lo, hi]``.

    ``h, dh, d2h`` are vectorised and valid on ``reach`` (which contains ``[lo, hi]``).
    ``flat`` marks ``dh == 0`` identically (a flat punch face).  ``knots``: where the formula
    is only C^2 (a cubic spline's knots, where h0''' jumps): quadratures cut there to converge
    spectrally; ``local``: the analytic (cubic) piece of every interval between ``lo``, the
    knots and ``hi``, each continued as the same polynomial over ``reach``.  Both are empty for
    analytic pieces.
    """

    lo: float
    hi: float
    h: Func
    dh: Func
    d2h: Func
    reach: tuple[float, float]
    flat: bool = False
    knots: tuple[float, ...] = field(default=(), compare=False, repr=False)
    local: tuple[Piece, ...] = field(default=(), compare=False, repr=False)

    def shifted(self, lift: float) -> Piece:
        """The same piece raised by ``lift``."""
        h = self.h
        return replace(self, h=lambda x: h(x) + lift,
                       local=tuple(pc.shifted(lift) for pc in self.local))

    def analytic_at(self, x: float) -> Piece:
        """The analytic piece holding x (``local``, the left one at a knot; x inside
        ``[lo, hi]``): the piece itself when it has no knots."""
        if not self.local:
            return self
        j = int(np.searchsorted(np.array([pc.hi for pc in self.local]), x, side="left"))
        return self.local[min(j, len(self.local) - 1)]

    def clipped(self, lo: float, hi: float) -> Piece:
        """The same formula restricted to ``[lo, hi]``."""
        return replace(self, lo=lo, hi=hi)


@dataclass(frozen=True)
class Profile:
    """Initial gap ``h0(x)`` (``+inf`` where the bodies cannot touch).

    Attributes: ``pieces`` (sorted, non-overlapping), ``corners`` (x of sharp corners: possible
    singular edges), ``kinks`` (x of slope jumps inside the support), ``scale`` (a characteristic
    length, used for tolerances), ``name`` and ``params`` (the constructor and its arguments).
    """

    pieces: tuple[Piece, ...]
    corners: tuple[float, ...]
    kinks: tuple[float, ...]
    scale: float
    name: str = "profile"
    params: dict = field(default_factory=dict, compare=False)

    # -- evaluation -------------------------------------------------------------------------
    def piece_index(self, x: np.ndarray) -> np.ndarray:
        """Index of the piece holding each x (-1 outside the support; the left piece at a
        shared end)."""
        x = np.asarray(x, dtype=float)
        los, his = self._bounds
        k = np.minimum(np.searchsorted(his, x, side="left"), his.size - 1)
        return np.where((x >= los[k]) & (x <= his[k]), k, -1)

    @cached_property
    def _bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return (np.array([pc.lo for pc in self.pieces]), np.array([pc.hi for pc in self.pieces]))

    @cached_property
    def knots(self) -> tuple[float, ...]:
        """x of the spline knots strictly inside the pieces (sorted): h0 is C^2 there, not
        analytic (tabulated profiles); empty for analytic profiles."""
        return tuple(sorted({k for pc in self.pieces for k in pc.knots if pc.lo < k < pc.hi}))

    @cached_property
    def pieces_have_gaps(self) -> bool:
        """True when h0 is +inf somewhere inside the support (pieces do not touch)."""
        return any(a.hi != b.lo for a, b in zip(self.pieces, self.pieces[1:], strict=False))

    @cached_property
    def global_piece(self) -> Piece | None:
        """The only piece when it covers the whole real line (cylinder, bi-quadratic)."""
        pc = self.pieces[0]
        return pc if len(self.pieces) == 1 and pc.lo == -INF and pc.hi == INF else None

    def _eval(self, x: np.ndarray, attr: str, outside: float) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if self.global_piece is not None:
            return np.asarray(getattr(self.global_piece, attr)(x), float)
        idx = self.piece_index(x)
        if idx.size and idx.min() == idx.max() >= 0:  # one piece holds every x: no masking
            return np.asarray(getattr(self.pieces[int(idx.flat[0])], attr)(x), float)
        out = np.full(x.shape, outside)
        for k, pc in enumerate(self.pieces):
            m = idx == k
            if np.any(m):
                out[m] = getattr(pc, attr)(x[m])
        return out

    def h0(self, x: np.ndarray) -> np.ndarray:
        """Initial gap ``h0(x)``; ``+inf`` outside the support.  At a step between two touching
        pieces (a sharp corner of a union) the lower side holds, as ``h0 = min`` of the members."""
        x = np.asarray(x, dtype=float)
        out = self._eval(x, "h", INF)
        for k in self._joints:
            at = x == self.pieces[k].hi
            if np.any(at):
                out[at] = np.minimum(out[at], self.pieces[k + 1].h(x[at]))
        return out

    @cached_property
    def _joints(self) -> tuple[int, ...]:
        """Indices k of pieces whose right end is the left end of piece k + 1."""
        pairs = zip(self.pieces, self.pieces[1:], strict=False)
        return tuple(k for k, (a, b) in enumerate(pairs) if a.hi == b.lo)

    def dh0(self, x: np.ndarray) -> np.ndarray:
        """Slope ``h0'(x)`` (right-continuous at kinks); ``nan`` outside the support."""
        return self._eval(x, "dh", np.nan)

    def d2h0(self, x: np.ndarray) -> np.ndarray:
        """Curvature ``h0''(x)``; ``nan`` outside the support."""
        return self._eval(x, "d2h", np.nan)

    __call__ = h0

    @cached_property
    def ridges(self) -> tuple[float, ...]:
        """Kinks where the slope drops (a ridge of h0, e.g. where two punches of a union meet).

        A contact zone cannot span a ridge (the pressure would be log-singular towards -inf
        there); it can end at one as a singular edge, like at a sharp corner.
        """
        out = []
        for q in self.kinks:
            d = 1e-9 * max(self.scale, abs(q), 1e-300)
            left, right = self.dh0(np.array([q - d, q + d]))
            if np.isfinite(left) and np.isfinite(right) and right < left:
                out.append(q)
        return tuple(out)

    @cached_property
    def vertical_ends(self) -> tuple[float, ...]:
        """Corners where the slope of the piece ending there is infinite (the end of a circular
        corner: ``h0' ~ kappa d^(-1/2)`` a distance d inside).  The pressure of an edge pinned
        there has a term ``kappa ln(d) / (pi A sqrt(d))`` (docs/analytic.md)."""
        out = []
        for q in self.corners:
            for pc in self.pieces:
                if q in (pc.lo, pc.hi):
                    with np.errstate(divide="ignore", invalid="ignore"):
                        slope = pc.dh(np.array([q], float))[0]
                    if not np.isfinite(slope):
                        out.append(q)
                        break
        return tuple(out)

    def vertical_strength(self, q: float) -> float:
        """``kappa = lim sqrt(d) |h0'|`` a distance d inside the vertical end q (from the piece
        at 1e-8 of its length: the piece is smooth in sqrt(d), the limit to ~1e-8)."""
        for pc in self.pieces:
            if q in (pc.lo, pc.hi):
                d = 1e-8 * (pc.hi - pc.lo)
                x = q + d if q == pc.lo else q - d
                return float(math.sqrt(d) * abs(pc.dh(np.array([x]))[0]))
        raise ValueError(f"{q!r} is not the end of a piece")

    @cached_property
    def pin_points(self) -> tuple[float, ...]:
        """Where a contact edge may be singular: sharp corners and ridges."""
        return tuple(sorted(set(self.corners) | set(self.ridges)))

    @cached_property
    def open_ends(self) -> tuple[float, ...]:
        """Finite piece ends where h0 stops without a corner or a neighbouring piece: the ends of
        a tabulated profile's table.  h0 is unknown beyond them (not a punch's ``+inf``), so a
        contact zone may not reach them (sorted; empty for the analytic profiles)."""
        out = set()
        for k, pc in enumerate(self.pieces):
            for end, j in ((pc.lo, k - 1), (pc.hi, k + 1)):
                joined = 0 <= j < len(self.pieces) and end in (self.pieces[j].lo,
                                                                self.pieces[j].hi)
                if math.isfinite(end) and not joined and end not in self.corners:
                    out.add(float(end))
        return tuple(sorted(out))

    @cached_property
    def _features(self) -> np.ndarray:
        return np.array(sorted(set(self.kinks) | set(self.corners)), float)

    @property
    def features(self) -> np.ndarray:
        """x of every kink and corner, sorted (read-only)."""
        out = self._features.view()
        out.flags.writeable = False
        return out

    def feature_distance(self, x: np.ndarray) -> np.ndarray:
        """Distance from each x to the nearest kink or corner (``inf`` if there is none, or where
        x sits on one): the length over which h0 stays smooth around x."""
        x = np.asarray(x, dtype=float)
        if self._features.size == 0:
            return np.full(x.shape, INF)
        d = np.min(np.abs(x[..., None] - self._features), axis=-1)
        return np.where(d > 0, d, INF)

    @cached_property
    def tilt_limits(self) -> tuple[float, float]:
        """Open range of rotations theta for which ``h0 - theta x`` is bounded below and rises
        towards both ends: the slopes of unbounded straight end pieces (a wedge's faces), else
        -inf / +inf.  At a limit an end piece of the tilted profile is flat out to infinity."""
        out = []
        for pc, side in ((self.pieces[0], -1), (self.pieces[-1], +1)):
            end = pc.lo if side < 0 else pc.hi
            far = np.array([far_point(self, side)])
            straight = not np.isfinite(end) and float(pc.d2h(far)[0]) == 0.0
            out.append(float(pc.dh(far)[0]) if straight else side * INF)
        return out[0], out[1]

    def admits_tilt(self, theta: float) -> bool:
        """Whether ``theta`` lies strictly inside :attr:`tilt_limits` (False for nan)."""
        lo, hi = self.tilt_limits
        return bool(lo < theta < hi)

    @property
    def support(self) -> tuple[float, float]:
        """Convex hull of the support."""
        return self.pieces[0].lo, self.pieces[-1].hi

    def local_minima(self, theta: float = 0.0) -> list[tuple[float, float, float]]:
        """Local minima of ``h0(x) - theta x`` as ``(x_lo, x_hi, value)``.

        A flat piece at ``theta == 0`` (or tilted by less than FLAT_TILT) gives an interval;
        every other minimum is a point.
        Memoised per theta (the solver asks for the same rotation many times).
        """
        key = float(theta)
        if key not in self._minima_memo:
            found: list[tuple[float, float, float]] = []
            for k, pc in enumerate(self.pieces):
                found.extend(_piece_minima(self, k, pc, key))
            if len(self._minima_memo) >= MINIMA_MEMO_SIZE:
                self._minima_memo.clear()
            found = _dedupe_minima(found, 1e-9 * self.scale)
            self._minima_memo[key] = tuple(_merge_level_runs(self, key, found))
        return list(self._minima_memo[key])

    @cached_property
    def _minima_memo(self) -> dict[float, tuple[tuple[float, float, float], ...]]:
        return {}

    def with_lift(self, lift: float) -> Profile:
        """The profile raised by ``lift`` (for union members)."""
        lift = check.real("lift", lift)
        return replace(self, pieces=tuple(p.shifted(lift) for p in self.pieces))


# ---------------------------------------------------------------------------------------------
# minima search
# ---------------------------------------------------------------------------------------------
def _piece_minima(prof: Profile, k: int, pc: Piece, theta: float) -> list[tuple]:
    lo, hi = sample_span(prof, pc)
    if pc.flat and abs(theta) * (hi - lo) <= FLAT_TILT * prof.scale:
        if any(_continues_lower(prof, k, end, theta) for end in (0, -1)):
            return []  # a flat face on a union's flank (h0 lower beside it): no minimum
        return [(pc.lo, pc.hi, float(pc.h(np.array([pc.lo]))[0]))]
    xs, f = piece_samples(pc, theta, lo, hi)
    out = []
    for i in np.flatnonzero((f[1:-1] <= f[:-2]) & (f[1:-1] <= f[2:])) + 1:
        xm = refine_minimum(pc, theta, xs[i - 1], xs[i + 1])
        out.append((xm, xm, float(pc.h(np.array([xm]))[0] - theta * xm)))
    for end, x_end, inner in ((0, pc.lo, f[1]), (-1, pc.hi, f[-2])):
        if not (np.isfinite(x_end) and f[end] <= inner):
            continue
        xm = _inside_end_min(pc, theta, x_end, xs[1] if end == 0 else xs[-2])
        if xm != x_end or _end_is_low(prof, k, end, theta):
            out.append((xm, xm, float(pc.h(np.array([xm]))[0] - theta * xm)))
    return out


def _inside_end_min(pc: Piece, theta: float, x_end: float, x_next: float) -> float:
    """A piece end that samples lower than its neighbour sample, or the minimum between them
    when ``h0 - theta x`` still falls going inwards from the end (a tilted face meeting a
    rounded corner: the minimum lies on the corner, closer than one sample to the kink). That
    inner minimum is the piece's own, kept even where the end is a ridge (a union's cylinder
    whose lowest point lay 0.08 from the ridge, within one sample of its 50-scale infinite
    piece, was missed and the first touch started on the next cylinder: audit seed 102518)."""
    inward = np.sign(x_next - x_end)
    if inward * (float(pc.dh(np.array([x_end]))[0]) - theta) >= 0:
        return x_end
    return refine_minimum(pc, theta, min(x_end, x_next), max(x_end, x_next))


def far_point(prof: Profile, side: int) -> float:
    """A finite stand-in for the infinite end of a piece: 50 scales beyond the profile's centre."""
    finite = [v for p in prof.pieces for v in (p.lo, p.hi) if np.isfinite(v)]
    centre = 0.5 * (min(finite) + max(finite)) if finite else 0.0
    return centre + side * FAR_SCALES * prof.scale


#: How far (in scales) the stand-in of an infinite end lies beyond the profile's centre, and at
#: least beyond the piece's finite end.
FAR_SCALES = 50.0
#: Samples of a piece in the minima search.
PIECE_SAMPLES = 401
#: Doublings of an infinite piece's sampled span at most, while ``h0 - theta x`` still falls at
#: its far end (2^60 spans: beyond any profile the solver accepts).
MAX_DOUBLINGS = 60


def piece_samples(pc: Piece, theta: float, lo: float, hi: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """``(xs, h0(xs) - theta xs)`` on PIECE_SAMPLES points from lo to hi, the span doubled
    outwards at an infinite end of the piece while the values still fall there: a union member
    whose lowest point lies beyond the profile's far stand-in (a cylinder 53 scales from a narrow
    punch: its minimum, 0.25 below the punch, was missed)."""
    for _ in range(MAX_DOUBLINGS):
        xs = np.linspace(lo, hi, PIECE_SAMPLES)
        f = pc.h(xs) - theta * xs
        if not np.isfinite(pc.lo) and f[0] < f[1]:
            lo = hi - 2.0 * (hi - lo)
        elif not np.isfinite(pc.hi) and f[-1] < f[-2]:
            hi = lo + 2.0 * (hi - lo)
        else:
            break
    return xs, f


def sample_span(prof: Profile, pc: Piece) -> tuple[float, float]:
    """Finite ends of a piece for sampling it: its own, or for an infinite end the profile's
    :func:`far_point`, but at least FAR_SCALES scales beyond the piece's finite end (a profile
    wider than 100 scales, e.g. a union whose cylinders cross 10 widths away, put the far point
    of its last piece behind the piece's start, and the piece's function sampled outside the
    piece gave a minimum that is none)."""
    reach = FAR_SCALES * prof.scale
    lo = pc.lo if np.isfinite(pc.lo) else min(far_point(prof, -1), pc.hi - reach)
    hi = pc.hi if np.isfinite(pc.hi) else max(far_point(prof, +1), pc.lo + reach)
    return lo, hi


def refine_minimum(pc: Piece, theta: float, a: float, b: float) -> float:
    """Minimum of ``h - theta x`` on the piece between samples a < b (root of the slope), or
    the lower end when the slope does not change sign."""
    def g(x: float) -> float:
        return float(pc.dh(np.array([x]))[0]) - theta

    ga, gb = g(a), g(b)
    if ga < 0 < gb:
        return brentq(g, a, b, xtol=1e-15, rtol=1e-15)
    return a if ga >= 0 else b


def _end_is_low(prof: Profile, k: int, end: int, theta: float) -> bool:
    """A piece end is a candidate minimum only at a corner or kink where the profile does not
    continue lower beyond it (:func:`_continues_lower`): at a kink where ``h0 - theta x`` keeps
    rising or falling through the joint (a union's concave kink on a flank: 257 of 740 random
    unions listed one) the end is no minimum (issue 29)."""
    pc = prof.pieces[k]
    x_end = pc.lo if end == 0 else pc.hi
    if x_end not in prof.corners and x_end not in prof.kinks:
        return False
    return not _continues_lower(prof, k, end, theta)


def _continues_lower(prof: Profile, k: int, end: int, theta: float) -> bool:
    """Whether ``h0 - theta x`` goes lower beyond the end ``end`` (0: lo, -1: hi) of piece k:
    a touching neighbour lower there (a step down: a union member's face below this piece's
    end, e.g. a lifted flat punch inside a cylinder's flank), or at the same height with a
    tilted slope that falls going away from the joint (no neighbour: ``h0 = +inf`` beyond; a
    step up: a sharp corner)."""
    pc = prof.pieces[k]
    x_end = pc.lo if end == 0 else pc.hi
    j = k - 1 if end == 0 else k + 1
    if not np.isfinite(x_end) or not 0 <= j < len(prof.pieces):
        return False
    nb = prof.pieces[j]
    if (nb.hi if end == 0 else nb.lo) != x_end:
        return False
    at = np.array([x_end])
    own, other = float(pc.h(at)[0]), float(nb.h(at)[0])
    step = 1e-12 * max(prof.scale, abs(own))
    if other > own + step:
        return False  # a step up (a sharp corner beside a lower piece)
    if other < own - step:
        return True  # a step down: lower beyond the joint
    with np.errstate(invalid="ignore", divide="ignore"):  # an arc's vertical end: nan, kept
        outward = float(nb.dh(at)[0]) - theta  # slope of h0 - theta x, neighbour, at the joint
    return outward > 0 if end == 0 else outward < 0


#: Points (ends included) that must lie at two neighbouring minima's level between them for
#: the two to be one level run.
LEVEL_SAMPLES = 9


def _merge_level_runs(prof: Profile, theta: float, minima: list[tuple]) -> list[tuple]:
    """Neighbouring minima (sorted by x) of one value joined by a level run of ``h0 - theta x``
    (every one of LEVEL_SAMPLES points between them at that value, to rounding) merged into one
    interval: a spline through equal heights is level, and the search lists every sample (a
    level table gave 399 point minima and as many first-touch zones: the solve grew to
    0.7 GB)."""
    out = minima[:1]
    for m in minima[1:]:
        level = max(out[-1][2], m[2])
        tol = 1e-12 * (prof.scale + abs(level))
        xs = np.linspace(out[-1][1], m[0], LEVEL_SAMPLES)
        if abs(m[2] - out[-1][2]) <= tol and np.all(prof.h0(xs) - theta * xs <= level + tol):
            out[-1] = (out[-1][0], m[1], min(out[-1][2], m[2]))
        else:
            out.append(m)
    return out


def _dedupe_minima(found: list[tuple], tol: float) -> list[tuple[float, float, float]]:
    found = sorted(found)
    out: list[tuple[float, float, float]] = []
    for m in found:
        if out and abs(m[0] - out[-1][1]) <= tol:
            prev = out[-1]
            out[-1] = (prev[0], max(prev[1], m[1]), min(prev[2], m[2]))
        else:
            out.append(m)
    return out
