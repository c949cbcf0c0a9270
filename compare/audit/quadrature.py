"""Independent quadratures of a returned pressure ``p(x)`` (and shear ``q(x)``).

Nothing here uses the solver's equations: only the vectorised callables ``pressure(x)`` /
``shear(x)``, the zones and the profile. Each zone is cut at the profile's piece ends inside it
(where ``p`` has a log singularity, e.g. a wedge apex, or a weaker one, e.g. a curvature jump)
and at any extra points asked for (the log kernel's singularity, stick edges). Every piece is
integrated by the tanh-sinh rule, which converges exponentially for integrands with algebraic
or log singularities at the piece ends; the piece next to a zone edge is first mapped by
``x = edge + L u^2``, which turns the edge's ``d^(+-1/2)`` into a smooth function of ``u``.

Each quantity is computed with two steps of the rule (``STEP`` and ``STEP / 2``): the finer
value is returned with their difference as its error estimate.

Conventions (DESIGN.md): ``p >= 0`` compressive; the relative normal displacement of the
surfaces is ``u(x) = -(A/pi) int p(s) ln|x - s| ds`` (the constant of the log is absorbed in the
rigid approach ``delta``), so in contact ``delta = h0(x) - theta x + u(x)`` and outside the
deformed gap is ``g(x) = h0(x) - theta x + u(x) - delta``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from analytic.profiles import Profile

STEP = 1.0 / 8.0
"""Coarse tanh-sinh step (the fine rule halves it): ~51 / ~103 nodes per piece; on the Hertz
and flat-punch closed forms the fine rule is exact to ~1e-15 relative (unit test)."""
T_MAX = 3.2
"""Range of the tanh-sinh variable: the outermost node lies ~1e-17 of a piece from its end."""
CUT_CLEARANCE = 1e-11
"""Nodes closer than this fraction of the piece to a cut inside a zone are dropped (see
:func:`piece_rule`): the solver's pressure can be 0/0 = nan within ~1e-13 of a kink."""
ROUNDING_CLEARANCE = 1e-12
"""Nodes closer than this times max(1, |end|) to a piece end are dropped: their distance to
the end would carry a relative rounding error above 1e-4."""

Field = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Rule:
    """Quadrature nodes ``x`` and weights ``w`` over a set of zones; ``zone`` and ``piece`` map
    each node to its zone and to its piece ``pieces[i] = (lo, hi, edge)``."""

    x: np.ndarray
    w: np.ndarray
    zone: np.ndarray
    piece: np.ndarray
    pieces: tuple[tuple[float, float, int], ...]

    def piece_holding(self, x: float) -> int:
        """Index of the piece with ``lo < x < hi`` (-1 if none)."""
        for i, (lo, hi, _) in enumerate(self.pieces):
            if lo < x < hi:
                return i
        return -1


def tanh_sinh(step: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tanh-sinh rule on (0, 1): nodes ``u``, ``1 - u`` (to full relative precision) and
    weights. ``u = 1 / (1 + exp(-pi sinh t))``, ``du/dt = pi cosh t u (1 - u)``."""
    t = np.arange(-T_MAX, T_MAX + 0.5 * step, step)
    s = np.pi * np.sinh(t)
    u = 1.0 / (1.0 + np.exp(-s))
    v = 1.0 / (1.0 + np.exp(s))
    return u, v, step * np.pi * np.cosh(t) * u * v


def piece_rule(lo: float, hi: float, edge: int, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights on ``[lo, hi]``; ``edge`` = -1 / +1 maps ``lo`` / ``hi`` as a zone edge
    (``x = lo + L u^2`` / ``x = hi - L (1 - u)^2``), 0 maps linearly. Nodes are formed from the
    nearer end, so nodes within 1e-17 of an end keep their distance to it.

    Nodes closer to an end than ROUNDING_CLEARANCE (or, at a cut inside the zone, than
    CUT_CLEARANCE of the piece) are dropped and their weights in the mapped variable lumped onto
    the kept node nearest that end: there the mapped integrand is smooth (zone edge) or at most
    log-singular (cut), so this costs ~1e-12 (edge) or ~CUT_CLEARANCE (cut) of the integral,
    where keeping them would evaluate ``p`` at distances with a large relative rounding error.
    """
    u, v, w = tanh_sinh(step)
    L = hi - lo
    if edge < 0:
        near_lo, near_hi, dw = u * u, v * (1 + u), 2 * u
    elif edge > 0:
        near_lo, near_hi, dw = u * (1 + v), v * v, 2 * v
    else:
        near_lo, near_hi, dw = u, v, np.ones_like(u)
    x = np.where(u < 0.5, lo + L * near_lo, hi - L * near_hi)
    keep = ((L * near_lo > _clearance(lo, L, edge < 0))
            & (L * near_hi > _clearance(hi, L, edge > 0)))
    kept = np.flatnonzero(keep)
    if kept.size == 0:  # a piece shorter than the clearances: nothing measurable
        return x[kept], w[kept]
    low = ~keep & (u < 0.5)
    w = w.copy()
    w[kept[0]] += w[low].sum()
    w[kept[-1]] += w[~keep & ~low].sum()
    return x[kept], (L * w * dw)[kept]


def _clearance(end: float, L: float, zone_edge: bool) -> float:
    rounding = ROUNDING_CLEARANCE * max(1.0, abs(end))
    return rounding if zone_edge else max(CUT_CLEARANCE * L, rounding)


def zone_pieces(a: float, b: float, cuts: Sequence[float]) -> list[tuple[float, float, int]]:
    """Pieces ``(lo, hi, edge)`` of zone ``[a, b]`` cut at ``cuts`` inside it (at its midpoint
    when there are none, so that no piece holds both edges)."""
    inner = sorted({float(c) for c in cuts if a < c < b})
    pts = [a, *(inner or [0.5 * (a + b)]), b]
    out = []
    for i, (lo, hi) in enumerate(zip(pts[:-1], pts[1:], strict=True)):
        edge = -1 if i == 0 else (1 if i == len(pts) - 2 else 0)
        out.append((lo, hi, edge))
    return out


def profile_cuts(profile: Profile) -> list[float]:
    """Where ``p`` may be non-smooth inside a zone: every finite piece end of the profile and
    every spline knot (h0's third derivative jumps there: p has a ``(x - k)^2 ln|x - k|``
    term, and a rule across knots converged algebraically, 6e-8 P on audit seed 360)."""
    ends = {v for pc in profile.pieces for v in (pc.lo, pc.hi) if np.isfinite(v)}
    return sorted(ends | set(profile.kinks) | set(profile.knots))


def zones_rule(zones: Sequence[tuple[float, float]], cuts: Sequence[float], step: float) -> Rule:
    """Rule over all ``zones``, each cut at ``cuts``."""
    xs, ws, ks, js, pieces = [], [], [], [], []
    for k, (a, b) in enumerate(zones):
        for lo, hi, edge in zone_pieces(a, b, cuts):
            x, w = piece_rule(lo, hi, edge, step)
            xs.append(x)
            ws.append(w)
            ks.append(np.full(x.size, k))
            js.append(np.full(x.size, len(pieces)))
            pieces.append((lo, hi, edge))
    return Rule(np.concatenate(xs), np.concatenate(ws), np.concatenate(ks), np.concatenate(js),
                tuple(pieces))


def split_piece(rule: Rule, i: int, x: float, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of piece ``i`` of ``rule`` cut in two at ``x`` (inside it)."""
    lo, hi, edge = rule.pieces[i]
    left = piece_rule(lo, x, min(edge, 0), step)
    right = piece_rule(x, hi, max(edge, 0), step)
    return np.concatenate([left[0], right[0]]), np.concatenate([left[1], right[1]])


def zone_integrals(rule: Rule, values: np.ndarray, n_zones: int) -> np.ndarray:
    """``sum w f`` per zone for ``values = f(rule.x)``."""
    return np.bincount(rule.zone, weights=rule.w * values, minlength=n_zones)


def log_potential(s: np.ndarray, wp: np.ndarray, x: np.ndarray, A: float) -> np.ndarray:
    """``-(A/pi) sum wp ln|x - s|`` at points ``x`` away from the nodes ``s`` (``wp``: weights
    times pressure)."""
    out = np.empty(x.size)
    for i in range(0, x.size, 64):  # chunks keep the (points x nodes) matrix small
        d = np.abs(x[i:i + 64, None] - s[None, :])
        out[i:i + 64] = np.log(d) @ wp
    return -(A / np.pi) * out
