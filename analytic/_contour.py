"""Per-zone loads of a solved system by contour integrals of ``Phi = W Psi``.

``Phi(z) = (1/2 pi i) int_L p(s)/(s - z) ds`` is analytic off the zones, so the load of zone k
is ``-oint_{C_k} Phi dz`` over an ellipse around that zone only, evaluated by nested
trapezoidal rules (geometric convergence; the kinks and edges on the real axis are never
touched).
"""

from __future__ import annotations

import math

import numpy as np

from analytic._sie import Layout, System
from analytic.errors import ConvergenceError

CONTOUR_START = 32        # nodes per ellipse of the coarsest rule (compared with twice as many)
CONTOUR_TOL = 1e-14       # accept when a doubling changes every zone integral by less (x total)
CONTOUR_MAX = 65536
"""Nodes per ellipse beyond which the doubling stops.  The rule converges like
``rho^-n``, ``rho ~ 1 + sqrt(d / (2 r))`` for zones of half-width r a gap d apart: 16384 nodes
reach CONTOUR_TOL at d / r ~ 2e-5 (the double wedge of 0.01 / 0.02 rad at P = 1.5, zones 37.5
wide 3.6e-4 apart, needs 8192; the former cap of 4096 left its zone loads 5.9e-10 P off)."""
CONTOUR_FLOOR = 1e-12
"""Still accepted at CONTOUR_MAX when the last doubling changed no zone integral by more than
this (x total), two orders below selfcheck.LOAD_TOL; else :func:`zone_loads` refuses."""


def zone_loads(sys_: System) -> list[float]:
    """``int_{L_k} p dx`` per zone.

    With ``Phi(z) = (1/2 pi i) int_L p(s)/(s - z) ds = W(z) Psi(z)`` analytic off L, the load of
    zone k is ``-oint_{C_k} Phi dz`` over an ellipse around that zone only.  The trapezoidal rule
    converges geometrically and never touches the kinks or edges on the real axis; the node count
    is doubled (reusing every node) until a doubling changes no zone load by more than
    ``CONTOUR_TOL`` times the total (close zones need squeezed ellipses and more nodes); a
    :class:`ConvergenceError` when CONTOUR_MAX nodes do not reach CONTOUR_FLOOR.
    """
    return [float(v.real) for v in _zone_contour_integrals(sys_, 0)]


def _zone_contour_integrals(sys_: System, power: int) -> list[complex]:
    """``-oint_{C_k} Phi z^power dz`` for every zone k (nested trapezoidal rules)."""
    ellipses = _zone_ellipses(sys_.layout)
    n = 2 * CONTOUR_START
    terms = _contour_terms(sys_, ellipses, power, 2 * np.pi * np.arange(n) / n)
    total = terms.sum(1)
    estimate = terms[:, ::2].sum(1) * (4 * np.pi / n)  # the coarse rule: every other node
    while True:
        refined = total * (2 * np.pi / n)
        change = np.max(np.abs(refined - estimate))
        scale = np.sum(np.abs(refined)) + 1e-300
        if change <= CONTOUR_TOL * scale or (n >= CONTOUR_MAX and change <= CONTOUR_FLOOR * scale):
            return list(-refined)
        if n >= CONTOUR_MAX:
            raise ConvergenceError(
                f"zone loads: the contour integrals changed by {change / scale:.2e} of the total "
                f"at {n} nodes per ellipse (at most {CONTOUR_FLOOR:g} allowed): zones too close "
                "for the contour rule", {"zones": sys_.layout.edges.reshape(-1, 2).tolist(),
                                         "contour_change": float(change / scale)})
        estimate = refined
        total = total + _contour_sums(sys_, ellipses, power, 2 * np.pi * (np.arange(n) + 0.5) / n)
        n *= 2


RHO_ISOLATED = 2.0 + math.sqrt(3.0)  # ellipse parameter around a zone without neighbours


def _zone_ellipses(lay: Layout) -> list[tuple[float, float, float]]:
    """Centre and semi-axes of an ellipse around each zone only: the Bernstein ellipse of the
    zone (foci at its edges) whose parameter ``rho`` is the geometric mean of 1 (the zone's own
    cut) and ``rho_out``, that of the nearest edge of a neighbouring zone.  Phi is analytic
    between the two, so the trapezoidal rule converges like ``sqrt(rho_out)^-n`` (the fastest
    rate for both sides at once)."""
    e = lay.edges.tolist()
    out = []
    for k in range(lay.n):
        a, b = e[2 * k], e[2 * k + 1]
        rx = 0.5 * (b - a)
        d = min(a - e[2 * k - 1] if k > 0 else math.inf,
                e[2 * k + 2] - b if k + 1 < lay.n else math.inf)
        rho = RHO_ISOLATED
        if d < math.inf:
            rho_out = (rx + d + math.sqrt(d * (2 * rx + d))) / rx
            rho = min(math.sqrt(rho_out), RHO_ISOLATED)
        out.append((0.5 * (a + b), 0.5 * rx * (rho + 1 / rho), 0.5 * rx * (rho - 1 / rho)))
    return out


def _contour_terms(sys_: System, ellipses: list, power: int, t: np.ndarray) -> np.ndarray:
    """``Phi z^power dz/dt`` at the parameters t on every ellipse, one row per zone."""
    cos, sin = np.cos(t), np.sin(t)
    z = np.concatenate([c + ax * cos + 1j * ay * sin for c, ax, ay in ellipses])
    dz = np.concatenate([-ax * sin + 1j * ay * cos for _, ax, ay in ellipses])
    return (_phi(sys_, z) * z**power * dz).reshape(len(ellipses), t.size)


def _contour_sums(sys_: System, ellipses: list, power: int, t: np.ndarray) -> np.ndarray:
    """Sum over the parameters t of ``Phi z^power dz/dt`` on every ellipse (one Phi call)."""
    return _contour_terms(sys_, ellipses, power, t).sum(1)


def _phi(sys_: System, z: np.ndarray) -> np.ndarray:
    """``Phi(z) = W(z) Psi(z)`` off the real axis (principal branches; analytic off L)."""
    lay = sys_.layout
    roots = np.sqrt(z[:, None] - lay.edges[None, :])
    W = np.prod(roots[:, ~lay.pinned], axis=1)
    if lay.e < lay.pinned.size:
        W /= np.prod(roots[:, lay.pinned], axis=1)
    sq = sys_.sq
    zh = z - sys_.xc
    # sum f/(s - z) in real arithmetic: 1/(s - z) = (s - x + i y)/((s - x)^2 + y^2), z = x + iy
    dx = sq.s[None, :] - zh.real[:, None]
    inv = dx * dx
    inv += (zh.imag**2)[:, None]
    np.reciprocal(inv, out=inv)
    f = sq.dh * sq.Omega
    dx *= inv
    cauchy = dx @ f + 1j * zh.imag * (inv @ f)
    T = np.polyval(sys_.beta[::-1], zh) if sys_.beta.size else 0.0
    return W * (cauchy + T) / (2j * np.pi * sys_.A)
