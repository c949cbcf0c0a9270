"""Stresses in body 2 (the flat lower half-plane ``y <= 0``) under the analytic tractions.

Conventions (README, DESIGN.md), stated once here for the stresses:

* Body 2 occupies ``y <= 0``; its surface ``y = 0`` carries the pressure ``p >= 0`` (compressive,
  pushing body 2 down) and the shear ``q`` of the solution.  ``Q`` pushes body 1 along +x and
  body 1 drags body 2 with it: the tangential traction body 2 receives on its surface is ``+q``
  along +x (``int q dx = Q``; the FE model's ``sxy`` on body 2's contact row is ``+q``).  So the
  surface values are ``syy = -p`` and ``sxy = +q``.  Tension is positive.
* Plane strain: ``szz = nu (sxx + syy)``.  The solutions carry only ``A = 4 (1 - nu^2)/E``, and
  the in-plane stresses of a half-plane under given tractions do not depend on the material, so
  ``nu`` is a required keyword of :func:`stress` (it enters ``szz`` only).
* Body 1 (upper) feels the opposite tractions on the mirrored half-plane; for similar materials
  its field is the mirror image (``x, -y``, with the sign of ``sxy`` and of the shear part of
  ``sxx`` flipped) and is not computed here.

Flamant line-load kernels (Johnson, *Contact Mechanics*, Eq. 2.23, with depth ``z = -y``,
``u = x - s``, ``r^2 = u^2 + z^2``)::

    sxx = -(2/pi) int [ p z u^2 + q u^3 ] / r^4 ds
    syy = -(2/pi) int [ p z^3   + q z^2 u ] / r^4 ds
    sxy = +(2/pi) int [ p z^2 u + q z u^2 ] / r^4 ds

(``sxy = -tau_xz`` of Johnson's downward z).  Every kernel is a combination of the Cauchy
integrals ``F(w) = int f(s) / (s - w) ds`` and ``F'(w)``, ``w = x + i z``: with
``C = -F`` and ``D = F'``, ``z int f u^2/r^4 = (z Re D - Im C)/2``, ``z^3 int f/r^4 =
-(Im C + z Re D)/2``, ``z^2 int f u/r^4 = -z Im D / 2`` and ``int f u^3/r^4 = Re C + z Im D/2``.

Surface (``z -> 0``): ``syy -> -p``, ``sxy -> q`` and

    sxx(x, 0) = -p(x) - (2/pi) PV int q(s) / (x - s) ds                     (surface_stress)

(Johnson Eq. 2.25a; the sign follows from the kernels above: ahead of a shear q > 0 body 2 is
compressed, behind it -- the trailing edge -- stretched).

The stress integrals are taken over the tractions sampled on panels in an angle
(:mod:`analytic._traction_panels`) by Gauss sums refined near every target
(:mod:`analytic._cauchy_integrals`).  On the surface the principal value is the limit
``Re F(x + i e) + e Im F'(x + i e)`` at a tiny lift ``e`` (error O(e^2)).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from analytic import _validate as check
from analytic._cauchy_integrals import cauchy, principal_values
from analytic._traction_panels import Quadrature, normal_of, quadrature, tractions
from analytic.errors import InputError
from analytic.normal import NormalSolution
from analytic.stick import StickSolution

SURFACE_LIFT = 1e-6
"""Surface principal values are taken this fraction of the distance to the nearest sub-interval
end above the surface, with a first-order Taylor correction (see _principal_values)."""
SURFACE_LIFT_MIN = 1e-6
"""Floor of that distance, relative to the contact span: on a sub-interval end the lift is
1e-12 of the span (the error there is O(sqrt(e)) relative, ~1e-6, from the sqrt ends)."""
SURFACE_AXIS_GAP = 1e-5
"""Points at least this fraction of the contact span from every panel end take the panels near
them on the surface itself (no lift error; see _principal_values); the pole then lies >= ~1e-5
panel widths from the neighbouring panels, far above the graded rule's MIN_POLE."""
SURFACE_AXIS_LIFT = 1e-7
"""Their lift as a fraction of that gap (so at least 1e-12 of the span, as above): it serves only
the plain sums of the other panels, whose nearest singularities (the ends of the near panels)
lie at least the gap away, so the O(e^2) remainder is ~1e-14 relative (a lift of 1e-6 of the
distance to a sub-interval end left 6e-13 p0 on the Hertz sliding surface; 1e-8 of the gap
made a target next to a Gauss node 4x worse: 1.4e-12 p0, the plain sums' 1/(s - w))."""


# ---------------------------------------------------------------------------------------------
# results
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class StressField:
    """Plane-strain stress in body 2 (``y <= 0``) at the points ``(x, y)`` (broadcast shape).

    ``sxx, syy, sxy``: in-plane components (force per unit area, tension positive, body 2's
    axes: x along the interface, y up); ``szz = nu (sxx + syy)``; ``nu``: Poisson's ratio used.
    """

    x: np.ndarray
    y: np.ndarray
    sxx: np.ndarray
    syy: np.ndarray
    sxy: np.ndarray
    szz: np.ndarray
    nu: float

    @property
    def max_shear(self) -> np.ndarray:
        """In-plane maximum shear stress ``sqrt(((sxx - syy)/2)^2 + sxy^2)``."""
        return np.hypot(0.5 * (self.sxx - self.syy), self.sxy)

    @property
    def principal(self) -> tuple[np.ndarray, np.ndarray]:
        """In-plane principal stresses ``(s1 >= s2)``."""
        mean = 0.5 * (self.sxx + self.syy)
        return mean + self.max_shear, mean - self.max_shear

    @property
    def von_mises(self) -> np.ndarray:
        """Von Mises equivalent stress (with ``szz``)."""
        d = ((self.sxx - self.syy) ** 2 + (self.syy - self.szz) ** 2 + (self.szz - self.sxx) ** 2)
        return np.sqrt(0.5 * d + 3.0 * self.sxy**2)


@dataclass(frozen=True)
class RuizResult:
    """Ruiz fretting parameter along the surface at one stage-3 state.

    ``x``: surface points; ``value``: ``max(sxx, 0) |q| |slip|`` there (``sxx`` and ``q`` of the
    state, ``slip`` accumulated in stage 3); ``maximum`` and ``x_max``: its largest value and
    where; ``Q``: tangential load of the state.
    """

    x: np.ndarray
    value: np.ndarray
    maximum: float
    x_max: float
    Q: float


# ---------------------------------------------------------------------------------------------
# public API
# ---------------------------------------------------------------------------------------------
def _check_nu(nu: float) -> float:
    return check.real("nu", nu, "Poisson's ratio -1 < nu <= 0.5", lambda v: -1.0 < v <= 0.5)


def _points(x, y) -> tuple[np.ndarray, np.ndarray]:
    xa, ya = check.array("x", x), check.array("y", y)
    try:
        xa, ya = np.broadcast_arrays(xa, ya)
    except ValueError:
        raise check.refuse("y", y, f"an array broadcastable with x (shape {xa.shape})") from None
    if np.any(ya > 0):
        raise InputError(f"y={float(np.max(ya))!r} is not allowed: body 2 is the half-plane "
                         "y <= 0")
    return xa, ya


def surface_stress(solution: NormalSolution | StickSolution, x: np.ndarray | float
                   ) -> np.ndarray:
    """``sxx`` on body 2's surface: ``-p(x) - (2/pi) PV int q(s) / (x - s) ds`` (vectorised).

    Tension positive; see the module docstring for the sign.  The principal value is accurate
    to ~1e-12 of ``max |q|`` (see :func:`_principal_values`), smooth enough to locate its peak.
    At a singular edge (where p and q are unbounded) the value is not meaningful.
    """
    normal_of(solution)
    x = check.array("x", x)
    flat = np.atleast_1d(x).ravel()
    pv = _principal_values(solution, quadrature(solution), flat)
    return (-tractions(solution, flat)[:, 0] + (2.0 / np.pi) * pv[:, 1]).reshape(x.shape)


def _principal_values(solution, quad: Quadrature, x: np.ndarray) -> np.ndarray:
    """``PV int f(s) / (s - x) ds`` for (p, q): ``Re F(x + i e) + e Im F'(x + i e) + O(e^2)``.

    The lift ``e`` is SURFACE_LIFT times the distance to the nearest sub-interval end (at least
    SURFACE_LIFT_MIN of the contact span), so the O(e^2) remainder stays ~1e-12 relative even
    next to a sqrt edge, and the off-surface rule, accurate to rounding at any depth, does the
    rest.  Points SURFACE_AXIS_GAP or more from every panel end take the panels near them on
    the surface itself, a Gauss rule symmetric about the pole (no lift error there, and a few
    sub-panels instead of ~20 graded down to the lift's depth); only the plain sums of the
    panels far from them keep the lift (:func:`analytic._cauchy_integrals.principal_values`).
    """
    pan = quad.panels
    ends = np.unique(np.r_[pan.lo, pan.hi])
    zones = normal_of(solution).zones
    span = zones[-1][1] - zones[0][0]
    dist = np.min(np.abs(x[:, None] - ends[None, :]), axis=1)
    e = SURFACE_LIFT * np.maximum(dist, SURFACE_LIFT_MIN * span)
    off, end = pan.position(np.arange(pan.ta.size), np.r_[[pan.ta], [pan.tb]])
    panel_ends = np.unique(end + off)
    gap = np.min(np.abs(x[:, None] - panel_ends[None, :]), axis=1)
    axis = gap >= SURFACE_AXIS_GAP * span
    return principal_values(quad, x, np.where(axis, SURFACE_AXIS_LIFT * gap, e), axis)


def _field(F: np.ndarray, dF: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, ...]:
    """``(sxx, syy, sxy)`` from the Cauchy integrals of p (column 0) and q (column 1)."""
    C, D = -F, dF
    zc = z[:, None]
    J1 = 0.5 * (zc * D.real - C.imag)          # z int f u^2 / r^4
    J2 = -0.5 * (C.imag + zc * D.real)         # z^3 int f / r^4
    J3 = -0.5 * zc * D.imag                    # z^2 int f u / r^4
    J4 = C.real + 0.5 * zc * D.imag            # int f u^3 / r^4
    k = 2.0 / np.pi
    sxx = -k * (J1[:, 0] + J4[:, 1])
    syy = -k * (J2[:, 0] + J3[:, 1])
    sxy = k * (J3[:, 0] + J1[:, 1])
    return sxx, syy, sxy


def stress(solution: NormalSolution | StickSolution, x: np.ndarray | float,
           y: np.ndarray | float, *, nu: float) -> StressField:
    """Plane-strain stress in body 2 at ``(x, y)``, ``y <= 0``, under the solution's p and q.

    ``solution``: a :class:`NormalSolution` (q = 0) or a :class:`StickSolution` of stage 2 or 3
    (its shear); ``x, y``: broadcastable arrays; ``nu``: Poisson's ratio (keyword, needed for
    ``szz = nu (sxx + syy)`` only -- the solutions carry just ``A``).  On ``y = 0`` the surface
    values ``(-p + (2/pi) PV..., -p, q)`` are returned (:func:`surface_stress`).  Conventions
    and the quadrature: module docstring.
    """
    normal_of(solution)
    nu = _check_nu(nu)
    x, y = _points(x, y)
    xf, zf = x.ravel(), -y.ravel()
    quad = quadrature(solution)
    F, dF = cauchy(quad, xf + 1j * zf)
    sxx, syy, sxy = _field(F, dF, zf)
    top = zf == 0
    if np.any(top):
        pq = tractions(solution, xf[top])
        sxx[top] = -pq[:, 0] + (2.0 / np.pi) * _principal_values(solution, quad, xf[top])[:, 1]
        syy[top], sxy[top] = -pq[:, 0], pq[:, 1]
    shape = x.shape
    return StressField(x=x, y=y, sxx=sxx.reshape(shape), syy=syy.reshape(shape),
                       sxy=sxy.reshape(shape), szz=(nu * (sxx + syy)).reshape(shape), nu=nu)


def ruiz(state: StickSolution, x: np.ndarray | float | None = None, n: int = 2001
         ) -> RuizResult:
    """Ruiz fretting parameter ``max(sxx, 0) |q| |slip|`` on body 2's surface (stage-3 state).

    Evaluated with ``sxx`` (:func:`surface_stress`) and ``q`` of ``state`` and the slip
    accumulated in stage 3 (for ``Q = -Q0`` the slip range of a steady cycle).  ``x`` (1-D)
    defaults to ``n`` evenly spaced points from the first zone's left edge to the last zone's
    right edge (``n``: an integer >= 2).
    """
    if not isinstance(state, StickSolution) or state.stage != 3:
        raise InputError("ruiz needs a stage-3 analytic.StickSolution (solve_stick(normal, mu, "
                         "Q, Q0)), the end of a cycle being Q = -Q0")
    n = check.integer("n", n, 2)
    if x is None:
        zones = state.normal.zones
        x = np.linspace(zones[0][0], zones[-1][1], n)
    x = check.vector("x", x, 1, need="None, or a 1-D sequence of at least 1 finite number")
    value = np.maximum(surface_stress(state, x), 0.0) * np.abs(state.shear(x))
    value = value * np.abs(np.nan_to_num(state.slip(x)))
    i = int(np.argmax(value))
    return RuizResult(x=x, value=value, maximum=float(value[i]), x_max=float(x[i]), Q=state.Q)
