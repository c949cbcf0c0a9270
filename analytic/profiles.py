"""Initial-gap profiles ``h0(x) >= 0`` of the upper body (body 1) against the flat body 2.

The constructors users call: :func:`cylinder`, :func:`flat_punch` (sharp or rounded corners),
:func:`wedge`, :func:`biquadratic` (Gladwell), :func:`double_wedge`, :func:`tabulated`, and
:func:`union` of rigidly interconnected punches.  Each returns a :class:`Profile` (defined with
:class:`Piece` in :mod:`analytic.piecewise`) that records its constructor and arguments
(``name``, ``params``).  Units: lengths in any consistent unit, ``h0`` in the same unit, slopes
dimensionless.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from analytic import _validate as check
from analytic._roots import brentq
from analytic.piecewise import (
    INF,
    Func,
    Piece,
    Profile,
    piece_samples,
    refine_minimum,
    sample_span,
)

__all__ = ["Piece", "Profile", "biquadratic", "cylinder", "double_wedge", "flat_punch",
           "tabulated", "union", "wedge"]


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

    # dh, d2h: +-inf at the arc's vertical ends (|x - x_tan| = rho) and NaN beyond them, outside
    # the piece's reach, where a Newton start or trial of the zone edges can put a gap
    # quadrature node (analytic._newton refuses a non-finite residual), by design: no warning
    def dh(x):
        with np.errstate(divide="ignore", invalid="ignore"):
            return (x - x_tan) / np.sqrt(rho**2 - (x - x_tan) ** 2)

    def d2h(x):
        with np.errstate(divide="ignore", invalid="ignore"):
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
    kinks = check.vector("kinks", kinks, 0, lambda v: bool(np.all((v >= x[0]) & (v <= x[-1]))),
                         f"a 1-D sequence of finite numbers within the table "
                         f"[{float(x[0])!r}, {float(x[-1])!r}]")
    from scipy.interpolate import CubicSpline  # here: it loads scipy.optimize (13 MB)

    ks = sorted(float(k) for k in kinks if x[0] < k < x[-1])  # a kink at an end is an end
    cuts = [x[0], *ks, x[-1]]
    pieces = []
    for lo, hi in zip(cuts[:-1], cuts[1:], strict=True):
        m = (x >= lo - 1e-12) & (x <= hi + 1e-12)
        if m.sum() < 2:
            raise check.refuse("kinks", kinks.tolist(), "at least 2 samples of x between "
                               f"consecutive kinks (none between {lo!r} and {hi!r})")
        cs = CubicSpline(x[m], h[m], bc_type="natural" if m.sum() > 2 else "not-a-knot")
        ext = 0.1 * (hi - lo)
        reach = (lo - ext, hi + ext)
        pieces.append(Piece(lo, hi, cs, cs.derivative(1), cs.derivative(2), reach,
                            knots=tuple(float(v) for v in cs.x[1:-1]),
                            local=_cubic_pieces(cs, reach)))
    return Profile(tuple(pieces), (), tuple(ks), float(x[-1] - x[0]), "tabulated",
                   {"x": x.tolist(), "h": h.tolist(), "kinks": list(ks)})


def _cubic_pieces(cs, reach: tuple[float, float]) -> tuple[Piece, ...]:
    """The cubic of every interval of ``cs`` as a polynomial piece continued over ``reach``
    (centred at the interval's left knot, as the spline evaluates it)."""
    return tuple(replace(_poly_piece(cs.c[:, i].tolist(), float(cs.x[i]), float(cs.x[i + 1]),
                                     shift=float(cs.x[i])), reach=reach)
                 for i in range(cs.x.size - 1))


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
    if not (np.isfinite(lo) or np.isfinite(hi)):  # members that never cross (one above all)
        mid = 0.0
    else:
        mid = 0.5 * (lo + hi) if np.isfinite(lo + hi) else (
            hi - 1.0 if np.isfinite(hi) else lo + 1.0)
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
        xs, f = piece_samples(pc, 0.0, *sample_span(prof, pc))
        i = int(np.argmin(f))
        xm = refine_minimum(pc, 0.0, xs[max(i - 1, 0)], xs[min(i + 1, xs.size - 1)])
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
