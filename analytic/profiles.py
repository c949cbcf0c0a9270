"""Initial-gap profiles ``h0(x) >= 0`` of the upper body (body 1) against the flat body 2.

A profile is a sorted set of *pieces*.  Each piece is the profile on ``[lo, hi]`` and carries an
analytic formula that stays valid a little beyond its interval (``reach``): the singular-integral
solver uses that continuation to remove near-singular Cauchy integrals at the contact edges.

Between two touching pieces the profile is continuous and its slope jumps (a *kink*, e.g. a wedge
apex).  Where a piece ends and the neighbour is higher (``h0 = +inf`` beyond a sharp punch
corner, or a step) the end is a *corner*: a contact edge can sit there as a singular edge.
Units: lengths in any consistent unit, ``h0`` in the same unit, slopes dimensionless.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.optimize import brentq

from analytic import _validate as check

Func = Callable[[np.ndarray], np.ndarray]
INF = float("inf")
MINIMA_MEMO_SIZE = 256  # rotations remembered per profile (a moment solve visits ~50)
FLAT_TILT = 1e-12  # a flat face tilted by less than this (height change / scale) stays flat,
                   # like the first-touch tolerance: its ends touch together (moment searches)


@dataclass(frozen=True)
class Piece:
    """One analytic piece of a profile, the profile on ``[lo, hi]``.

    ``h, dh, d2h`` are vectorised and valid on ``reach`` (which contains ``[lo, hi]``).
    ``flat`` marks ``dh == 0`` identically (a flat punch face).
    """

    lo: float
    hi: float
    h: Func
    dh: Func
    d2h: Func
    reach: tuple[float, float]
    flat: bool = False

    def shifted(self, lift: float) -> Piece:
        """The same piece raised by ``lift``."""
        h = self.h
        return replace(self, h=lambda x: h(x) + lift)

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
    def _features(self) -> np.ndarray:
        return np.array(sorted(set(self.kinks) | set(self.corners)), float)

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
            far = np.array([_far(self, side)])
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
            self._minima_memo[key] = tuple(_dedupe_minima(found, 1e-9 * self.scale))
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
    lo = pc.lo if np.isfinite(pc.lo) else _far(prof, -1)
    hi = pc.hi if np.isfinite(pc.hi) else _far(prof, +1)
    if pc.flat and abs(theta) * (hi - lo) <= FLAT_TILT * prof.scale:
        return [(pc.lo, pc.hi, float(pc.h(np.array([pc.lo]))[0]))]
    xs = np.linspace(lo, hi, 401)
    f = pc.h(xs) - theta * xs
    out = []
    for i in np.flatnonzero((f[1:-1] <= f[:-2]) & (f[1:-1] <= f[2:])) + 1:
        xm = _refine_min(pc, theta, xs[i - 1], xs[i + 1])
        out.append((xm, xm, float(pc.h(np.array([xm]))[0] - theta * xm)))
    for end, x_end, inner in ((0, pc.lo, f[1]), (-1, pc.hi, f[-2])):
        if np.isfinite(x_end) and f[end] <= inner and _end_is_low(prof, k, end):
            xm = _inside_end_min(pc, theta, x_end, xs[1] if end == 0 else xs[-2])
            out.append((xm, xm, float(pc.h(np.array([xm]))[0] - theta * xm)))
    return out


def _inside_end_min(pc: Piece, theta: float, x_end: float, x_next: float) -> float:
    """A piece end that samples lower than its neighbour sample, or the minimum between them
    when ``h0 - theta x`` still falls going inwards from the end (a tilted face meeting a
    rounded corner: the minimum lies on the corner, closer than one sample to the kink)."""
    inward = np.sign(x_next - x_end)
    if inward * (float(pc.dh(np.array([x_end]))[0]) - theta) >= 0:
        return x_end
    return _refine_min(pc, theta, min(x_end, x_next), max(x_end, x_next))


def _far(prof: Profile, side: int) -> float:
    finite = [v for p in prof.pieces for v in (p.lo, p.hi) if np.isfinite(v)]
    centre = 0.5 * (min(finite) + max(finite)) if finite else 0.0
    return centre + side * 50.0 * prof.scale


def _refine_min(pc: Piece, theta: float, a: float, b: float) -> float:
    def g(x: float) -> float:
        return float(pc.dh(np.array([x]))[0]) - theta

    ga, gb = g(a), g(b)
    if ga < 0 < gb:
        return brentq(g, a, b, xtol=1e-15, rtol=1e-15)
    return a if ga >= 0 else b


def _end_is_low(prof: Profile, k: int, end: int) -> bool:
    """A piece end is a candidate minimum only where the profile does not continue lower."""
    x_end = prof.pieces[k].lo if end == 0 else prof.pieces[k].hi
    return x_end in prof.corners or x_end in prof.kinks


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


# ---------------------------------------------------------------------------------------------
# constructors
# ---------------------------------------------------------------------------------------------
def _finite_coeffs(name: str, value: float, coeffs: Sequence[float]) -> None:
    """Refuse parameters whose polynomial coefficients overflow (e.g. ``center = 1e200``)."""
    if not all(np.isfinite(c) for c in coeffs):
        raise check.refuse(name, value, "a magnitude whose profile coefficients stay finite "
                           f"(got {[float(c) for c in coeffs]})")


def _poly_piece(coeffs: Sequence[float], lo: float, hi: float, flat: bool = False,
                shift: float = 0.0) -> Piece:
    """Piece from a polynomial in ``x - shift`` (highest power first); its continuation is
    global.  Centred at its vertex or apex, h0 rounds relative to itself, not to the expanded
    terms (``(x - c)^2 / 2R`` expanded rounds by eps c^2 / R: 5e-5 of A P at A P = 1e-12)."""
    c = np.poly1d(coeffs)
    h, d1, d2 = (_horner(q.coeffs, shift) for q in (c, c.deriv(1), c.deriv(2)))
    return Piece(lo, hi, h, d1, d2, (-INF, INF), flat)


def _horner(coeffs: Sequence[float], shift: float = 0.0) -> Func:
    """Vectorised polynomial in ``x - shift`` (highest power first) by Horner's rule, in place
    (hot path)."""
    head, *rest = (float(v) for v in coeffs)

    def value(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if shift != 0.0 and rest:
            x = x - shift
        y = np.full(x.shape, head)
        for v in rest:
            y *= x
            y += v
        return y

    return value


def _line(slope: float, x0: float, lo: float, hi: float) -> Piece:
    """``h = slope (x - x0)`` on ``[lo, hi]``."""
    return _poly_piece([slope, 0.0], lo, hi, flat=(slope == 0.0), shift=x0)


def cylinder(R: float, center: float = 0.0, lift: float = 0.0) -> Profile:
    """Cylinder (parabolic approximation): ``h0 = (x - center)^2 / (2R) + lift``."""
    R, center, lift = check.positive("R", R), check.real("center", center), check.real("lift", lift)
    with np.errstate(all="ignore"):  # an overflow is refused just below
        coeffs = [0.5 / R, -center / R, np.float64(center)**2 / (2 * R) + lift]
    _finite_coeffs("center", center, coeffs)
    pc = _poly_piece([0.5 / R, 0.0, lift], -INF, INF, shift=center)
    return Profile((pc,), (), (), R, "cylinder", {"R": R, "center": center, "lift": lift})


def _arc(rho: float, x_tan: float, side: int, lo: float, hi: float, lift: float) -> Piece:
    """Circular corner of radius ``rho`` tangent to the flat face at ``x_tan``."""
    def h(x):  # rho - sqrt(rho^2 - t^2) without cancellation (it rounded by eps rho)
        t2 = (x - x_tan) ** 2
        return lift + t2 / (rho + np.sqrt(np.maximum(rho**2 - t2, 0.0)))

    def dh(x):
        return (x - x_tan) / np.sqrt(rho**2 - (x - x_tan) ** 2)

    def d2h(x):
        return rho**2 / (rho**2 - (x - x_tan) ** 2) ** 1.5

    reach = (x_tan - 0.999 * rho, x_tan + 0.999 * rho)
    return Piece(lo, hi, h, dh, d2h, reach)


def flat_punch(left: float, right: float, corner_radius: float = 0.0, lift: float = 0.0,
               corner_shape: str = "circular") -> Profile:
    """Flat punch with its face on ``[left, right]`` at height ``lift``.

    ``corner_radius == 0``: sharp corners (``h0 = +inf`` beyond; singular edges).  Otherwise the
    corners are rounded with radius ``corner_radius``: ``corner_shape="circular"`` (a quarter
    circle, ``h0 = +inf`` beyond it) or ``"parabolic"`` (``h0 = (|x| - b)^2 / (2 rho)``, the
    form used by Ciavarella, Hills & Monno 1998 for the closed-form P(a, b) relation).
    """
    left = check.real("left", left)
    right = check.real("right", right, f"a finite number > left={left!r} (with right - left "
                       "finite)", lambda v: v > left and np.isfinite(v - left))
    corner_radius = check.non_negative("corner_radius", corner_radius)
    lift = check.real("lift", lift)
    corner_shape = check.choice("corner_shape", corner_shape, ("circular", "parabolic"))
    face = _poly_piece([lift], left, right, flat=True)
    params = {"left": left, "right": right, "corner_radius": corner_radius, "lift": lift,
              "corner_shape": corner_shape}
    scale = right - left
    if corner_radius == 0:
        return Profile((face,), (left, right), (), scale, "flat_punch", params)
    rho = float(corner_radius)
    if corner_shape == "parabolic":
        with np.errstate(all="ignore"):  # an overflow is refused just below
            cl = [0.5 / rho, -left / rho, np.float64(left)**2 / (2 * rho) + lift]
            cr = [0.5 / rho, -right / rho, np.float64(right)**2 / (2 * rho) + lift]
        _finite_coeffs("corner_radius", corner_radius, cl + cr)
        lp = _poly_piece([0.5 / rho, 0.0, lift], -INF, left, shift=left)
        rp = _poly_piece([0.5 / rho, 0.0, lift], right, INF, shift=right)
    else:
        lp = _arc(rho, left, -1, left - rho, left, lift)
        rp = _arc(rho, right, +1, right, right + rho, lift)
        ends = (left - rho, right + rho)  # h0 = +inf beyond the quarter circles
        return Profile((lp, face, rp), ends, (left, right), scale, "flat_punch", params)
    return Profile((lp, face, rp), (), (left, right), scale, "flat_punch", params)


def wedge(angle_left: float, angle_right: float, apex: float = 0.0, lift: float = 0.0) -> Profile:
    """Wedge with its apex at ``apex``: ``h0 = tan(angle_left)(apex - x)`` left of the apex and
    ``tan(angle_right)(x - apex)`` right of it (angles in radians, 0 < angle < pi/2)."""
    angle_left, angle_right = check.angle("angle_left", angle_left), check.angle(
        "angle_right", angle_right)
    apex, lift = check.real("apex", apex), check.real("lift", lift)
    tl, tr = np.tan(angle_left), np.tan(angle_right)
    _finite_coeffs("apex", apex, [tl * apex + lift, -tr * apex + lift])
    pl = _poly_piece([-tl, lift], -INF, apex, shift=apex)
    pr = _poly_piece([tr, lift], apex, INF, shift=apex)
    return Profile((pl, pr), (), (apex,), 1.0, "wedge",
                   {"angle_left": angle_left, "angle_right": angle_right, "apex": apex,
                    "lift": lift})


def biquadratic(c: float, R: float) -> Profile:
    """Gladwell's bi-quadratic punch ``h0 = (x^2 - c^2)^2 / (8 R c^2)``: touches at ``x = +-c``
    with curvature radius R there."""
    c, R = check.positive("c", c), check.positive("R", R)
    with np.errstate(all="ignore"):  # an overflow or underflow is refused just below
        c2 = np.float64(c) ** 2
        k = 1.0 / (8 * R * c2)
        coeffs = [k, 0.0, -2 * k * c2, 0.0, k * c2 * c2, 1.0 / k]
    _finite_coeffs("c", c, coeffs)
    coeffs = coeffs[:-1]
    pc = _poly_piece(coeffs, -INF, INF)
    return Profile((pc,), (), (), c, "biquadratic", {"c": c, "R": R})


def double_wedge(c: float, phi_inner: float, phi_outer: float) -> Profile:
    """The paper's Fig. 4: two rigidly connected wedges with apexes at ``+-c``.

    ``h0 = tan(phi_inner)(c - |x|)`` for ``|x| <= c`` and ``tan(phi_outer)(|x| - c)`` beyond.
    """
    c = check.positive("c", c)
    phi_inner, phi_outer = check.angle("phi_inner", phi_inner), check.angle("phi_outer", phi_outer)
    t1, t2 = np.tan(phi_inner), np.tan(phi_outer)
    pieces = (_line(-t2, -c, -INF, -c), _line(t1, -c, -c, 0.0),
              _line(-t1, c, 0.0, c), _line(t2, c, c, INF))
    return Profile(pieces, (), (-c, 0.0, c), c, "double_wedge",
                   {"c": c, "phi_inner": phi_inner, "phi_outer": phi_outer})


def tabulated(x: Sequence[float], h: Sequence[float], kinks: Sequence[float] = ()) -> Profile:
    """Measured profile: C2 cubic splines between the given kinks (and the table ends).

    The profile is undefined outside ``[x[0], x[-1]]``; contact must stay inside the table.
    """
    x = check.vector("x", x, 4, lambda v: bool(np.all(np.diff(v) > 0)),
                     "a strictly increasing 1-D sequence of at least 4 finite numbers")
    h = check.vector("h", h, 4, lambda v: v.size == x.size and bool(np.all(v >= 0)),
                     f"{x.size} finite values h0 >= 0 (one per x)")
    kinks = check.vector("kinks", kinks, 0, need="a 1-D sequence of finite numbers")
    ks = sorted(float(k) for k in kinks if x[0] < k < x[-1])
    cuts = [x[0], *ks, x[-1]]
    pieces = []
    for lo, hi in zip(cuts[:-1], cuts[1:], strict=True):
        m = (x >= lo - 1e-12) & (x <= hi + 1e-12)
        if m.sum() < 2:
            raise check.refuse("kinks", kinks.tolist(), "at least 2 samples of x between "
                               f"consecutive kinks (none between {lo!r} and {hi!r})")
        cs = CubicSpline(x[m], h[m], bc_type="natural" if m.sum() > 2 else "not-a-knot")
        ext = 0.1 * (hi - lo)
        pieces.append(Piece(lo, hi, cs, cs.derivative(1), cs.derivative(2), (lo - ext, hi + ext)))
    return Profile(tuple(pieces), (), tuple(ks), float(x[-1] - x[0]), "tabulated",
                   {"x": x.tolist(), "h": h.tolist(), "kinks": list(ks)})


# ---------------------------------------------------------------------------------------------
# union of rigidly interconnected punches
# ---------------------------------------------------------------------------------------------
def union(*profiles: Profile) -> Profile:
    """Rigidly interconnected punches: ``h0 = min`` of the members.

    The members' lifts are relative heights; the result is shifted so that ``min h0 = 0``.
    """
    if len(profiles) < 1:
        raise check.refuse("profiles", profiles, "at least one analytic.profiles.Profile")
    for i, prof in enumerate(profiles):
        check.instance(f"profiles[{i}]", prof, Profile, "an analytic.profiles.Profile")
    cands = [pc for prof in profiles for pc in prof.pieces]
    cuts = _union_cuts(cands)
    segs: list[Piece] = []
    for lo, hi in zip(cuts[:-1], cuts[1:], strict=True):
        best = _lowest_piece(cands, lo, hi)
        if best is None:
            continue
        if segs and segs[-1] is not None and segs[-1].hi == lo and _same(segs[-1], best):
            segs[-1] = segs[-1].clipped(segs[-1].lo, hi)
        else:
            segs.append(best.clipped(lo, hi))
    pieces = _normalise(tuple(segs))
    kinks, corners = _classify_joints(pieces, profiles)
    scale = min(p.scale for p in profiles)
    return Profile(pieces, corners, kinks, scale, "union",
                   {"members": [(p.name, p.params) for p in profiles]})


def _union_cuts(cands: list[Piece]) -> list[float]:
    pts = {v for pc in cands for v in (pc.lo, pc.hi)}
    finite = sorted(v for v in pts if np.isfinite(v))
    span = (finite[-1] - finite[0]) if len(finite) > 1 else 1.0
    lo_all, hi_all = (finite[0], finite[-1]) if finite else (-1.0, 1.0)
    grid = np.linspace(lo_all - 3 * span - 1.0, hi_all + 3 * span + 1.0, 4001)
    for i, p in enumerate(cands):
        for q in cands[i + 1:]:
            pts.update(_crossings(p, q, grid))
    return sorted(pts)


def _crossings(p: Piece, q: Piece, grid: np.ndarray) -> list[float]:
    lo, hi = max(p.lo, q.lo), min(p.hi, q.hi)
    xs = grid[(grid > lo) & (grid < hi)]
    if xs.size < 2:
        return []
    d = p.h(xs) - q.h(xs)
    out = [float(v) for v in xs[d == 0.0]]  # a crossing exactly on a grid node
    for i in np.flatnonzero(np.sign(d[:-1]) * np.sign(d[1:]) < 0):
        out.append(brentq(lambda t: float(p.h(np.array([t]))[0] - q.h(np.array([t]))[0]),
                          xs[i], xs[i + 1], xtol=1e-15))
    return out


def _lowest_piece(cands: list[Piece], lo: float, hi: float) -> Piece | None:
    if lo == hi:
        return None
    mid = 0.5 * (lo + hi) if np.isfinite(lo + hi) else (hi - 1.0 if np.isfinite(hi) else lo + 1.0)
    best, val = None, INF
    for pc in cands:
        if pc.lo <= mid <= pc.hi:
            v = float(pc.h(np.array([mid]))[0])
            if v < val:
                best, val = pc, v
    return best


def _same(a: Piece, b: Piece) -> bool:
    return a.h is b.h or (a.dh is b.dh and a.reach == b.reach)


def _normalise(pieces: tuple[Piece, ...]) -> tuple[Piece, ...]:
    tmp = Profile(pieces, (), (), 1.0)
    low = min(m[2] for m in _all_minima(tmp))
    return tuple(p.shifted(-low) for p in pieces)


def _all_minima(prof: Profile) -> list[tuple]:
    out = []
    for k, pc in enumerate(prof.pieces):
        lo = pc.lo if np.isfinite(pc.lo) else _far(prof, -1)
        hi = pc.hi if np.isfinite(pc.hi) else _far(prof, +1)
        xs = np.linspace(lo, hi, 401)
        f = pc.h(xs)
        i = int(np.argmin(f))
        xm = _refine_min(pc, 0.0, xs[max(i - 1, 0)], xs[min(i + 1, xs.size - 1)])
        out.append((xm, xm, float(min(f.min(), pc.h(np.array([xm]))[0]))))
        del k
    return out


def _classify_joints(pieces: tuple[Piece, ...], members: tuple[Profile, ...]):
    kinks, corners = [], []
    member_corners = {c for m in members for c in m.corners}
    for i, pc in enumerate(pieces):
        left = pieces[i - 1] if i > 0 and pieces[i - 1].hi == pc.lo else None
        right = pieces[i + 1] if i + 1 < len(pieces) and pieces[i + 1].lo == pc.hi else None
        for x_end, nb in ((pc.lo, left), (pc.hi, right)):
            if not np.isfinite(x_end):
                continue
            own = float(pc.h(np.array([x_end]))[0])
            other = INF if nb is None else float(nb.h(np.array([x_end]))[0])
            if other > own + 1e-12 * max(1.0, abs(own)):
                corners.append(x_end) if (nb is not None or x_end in member_corners) else None
            elif nb is not None and x_end not in kinks:
                kinks.append(x_end)
    return tuple(sorted(set(kinks))), tuple(sorted(set(corners)))
