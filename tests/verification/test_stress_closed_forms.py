"""Verification of ``analytic.stress`` / ``analytic.surface_stress`` against closed forms.

Body 2 (``y <= 0``, depth ``z = -y``) under p >= 0 and the shear q it receives along +x.
Closed forms (Johnson, *Contact Mechanics*, 1985; ``m + i n = sqrt(a^2 - x^2 + z^2 + 2 i x z)``):
- Hertz pressure ``p0 sqrt(1 - x^2/a^2)`` (McEwen 1949; Johnson Eq. 7.6 with q = 0):
  ``sxx = -(p0/a)[m (1 + (z^2 + n^2)/(m^2 + n^2)) - 2z]``, ``syy = -(p0/a) m (1 - (z^2 + n^2)/
  (m^2 + n^2))``, ``tau_xz = -(p0/a) n (m^2 - z^2)/(m^2 + n^2)`` (``sxy = -tau_xz``); on the
  axis ``sxx = -p0 [(1 + 2 z^2/a^2)/sqrt(1 + z^2/a^2) - 2 z/a]``, ``syy = -p0/sqrt(1 + z^2/a^2)``,
  whose half-difference peaks at ``0.300 p0`` at ``z = 0.786 a``.
- Hertz shear ``q0 sqrt(1 - x^2/a^2)`` (Smith & Liu 1953; Johnson Eq. 7.7):
  ``sxx = (q0/a)[n (2 - (z^2 - m^2)/(m^2 + n^2)) - 2x]``,
  ``syy = -(q0/a) n (m^2 - z^2)/(m^2 + n^2)``,
  ``tau_xz = -(q0/a)[m (1 + (z^2 + n^2)/(m^2 + n^2)) - 2z]``.  Full sliding: ``q0 = mu p0``;
  Cattaneo by superposition: the sliding shear minus the one of the stick half-width c with
  ``q0 c/a``.  On the surface of the sliding contact ``sxx = -p - 2 mu p0 x / a`` (|x| < a).
- Sharp flat punch ``p = P / (pi sqrt(a^2 - x^2))``: the Flamant integrals done independently by
  QUADPACK's algebraic-weight rule (``weight='alg'``, exact for the 1/sqrt ends), and the
  surface ``sxx = -p`` (q = 0) inside, ``0`` outside.
- Equilibrium: the tractions on the faces of a box around the contact balance P and Q.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import minimize_scalar

import analytic
from analytic import profiles as pr
from analytic.errors import InputError

A, R, P, MU, NU = 1.0, 1.0, 0.5, 0.3, 0.3
A_HERTZ = np.sqrt(2 * A * P * R / np.pi)
P0 = A_HERTZ / (A * R)

FIELD_TOL = 1e-10
"""Stress error / p0 against the closed forms (observed <= 1.2e-11 down to depth 1e-6 a)."""
SURFACE_TOL = 1e-10
"""Surface sxx error / p0 from the principal value (observed ~1e-13)."""
PEAK_TOL = 1e-7
"""Depth of the maximum shear / a (optimiser tolerance on a flat maximum)."""
LIMIT_TOL = 1e-7
"""|stress(x, -1e-9 a) - surface values| / p0 (the field's own slope gives ~1e-9)."""
EDGE_LIMIT_TOL = 2e-6
"""|stress(c, -z) - surface value| / |sxx| at a stick edge c, z <= 1e-12: the field varies like
sqrt(z) there and the surface value's lift errs by O(sqrt(1e-12)) (observed 7e-7)."""
EQUILIBRIUM_TOL = 1e-9
"""Box face traction integrals vs (P, Q), relative to P (Gauss-Legendre on the faces)."""
KINK_EQUILIBRIUM_TOL = 1e-8
"""The same with apex kinks: the solver's pressure itself integrates to P only within 6e-9
relative here (scipy.integrate.quad of NormalSolution.pressure: 1.5e-9 short per zone, the
contour zone loads are exact); the box sees 5.7e-9."""


def mn(x: np.ndarray, z: np.ndarray, a: float) -> tuple[np.ndarray, np.ndarray]:
    """McEwen's m, n from the stable complex square root (m >= 0, n with the sign of x)."""
    c = np.sqrt((a * a - x * x + z * z) + 2j * x * z)
    return c.real, c.imag


def mcewen_normal(x, z, a, p0):
    """(sxx, syy, sxy) under the Hertz pressure (Johnson Eq. 7.6)."""
    m, n = mn(x, z, a)
    r = m * m + n * n
    sxx = -(p0 / a) * (m * (1 + (z * z + n * n) / r) - 2 * z)
    syy = -(p0 / a) * m * (1 - (z * z + n * n) / r)
    tau = -(p0 / a) * n * (m * m - z * z) / r
    return np.array([sxx, syy, -tau])


def smith_liu(x, z, a, q0):
    """(sxx, syy, sxy) under the Hertz-shaped shear q0 sqrt(1 - x^2/a^2) (Johnson Eq. 7.7)."""
    m, n = mn(x, z, a)
    r = m * m + n * n
    sxx = (q0 / a) * (n * (2 - (z * z - m * m) / r) - 2 * x)
    syy = -(q0 / a) * n * (m * m - z * z) / r
    tau = -(q0 / a) * (m * (1 + (z * z + n * n) / r) - 2 * z)
    return np.array([sxx, syy, -tau])


def components(f: analytic.StressField) -> np.ndarray:
    return np.array([f.sxx, f.syy, f.sxy])


@pytest.fixture(scope="module")
def hertz() -> analytic.NormalSolution:
    return analytic.solve_normal(pr.cylinder(R), P, A)


@pytest.fixture(scope="module")
def grid() -> tuple[np.ndarray, np.ndarray]:
    xs = np.r_[np.linspace(-2, 2, 81), -0.999999, 0.9999999, 1.0000001, 1.001] * A_HERTZ
    zs = np.r_[1e-6, 1e-4, 1e-2, np.linspace(0.05, 2.0, 30)] * A_HERTZ
    return np.meshgrid(xs, zs)


def test_hertz_axis_mcewen(hertz):
    z = np.r_[1e-8, 1e-5, 1e-3, np.linspace(0.01, 5, 200)] * A_HERTZ
    f = analytic.stress(hertz, 0.0, -z, nu=NU)
    t = z / A_HERTZ
    sxx = -P0 * ((1 + 2 * t**2) / np.sqrt(1 + t**2) - 2 * t)
    syy = -P0 / np.sqrt(1 + t**2)
    assert np.max(np.abs(f.sxx - sxx)) / P0 < FIELD_TOL
    assert np.max(np.abs(f.syy - syy)) / P0 < FIELD_TOL
    assert np.max(np.abs(f.sxy)) / P0 < FIELD_TOL
    assert np.allclose(f.szz, NU * (f.sxx + f.syy), rtol=0, atol=1e-14 * P0)


def test_hertz_max_shear_depth(hertz):
    """The classic 0.30 p0 at 0.78 a (Johnson Sec. 4.2), against the closed form's optimum."""
    def tau(z):
        return -float(analytic.stress(hertz, 0.0, -z * A_HERTZ, nu=NU).max_shear[()]) / P0

    def tau_ref(z):
        return -0.5 * abs((1 + 2 * z**2) / np.sqrt(1 + z**2) - 2 * z - 1 / np.sqrt(1 + z**2))

    got = minimize_scalar(tau, bounds=(0.5, 1.1), method="bounded", options={"xatol": 1e-9})
    ref = minimize_scalar(tau_ref, bounds=(0.5, 1.1), method="bounded", options={"xatol": 1e-9})
    assert abs(got.x - ref.x) < PEAK_TOL
    assert abs(got.fun - ref.fun) < FIELD_TOL
    assert round(-got.fun, 2) == 0.30 and round(got.x, 2) == 0.79


def test_hertz_field_mcewen(hertz, grid):
    X, Z = grid
    err = np.abs(components(analytic.stress(hertz, X, -Z, nu=NU)) -
                 mcewen_normal(X, Z, A_HERTZ, P0))
    assert np.max(err) / P0 < FIELD_TOL


def test_full_sliding_smith_liu(hertz, grid):
    X, Z = grid
    sliding = analytic.solve_stick(hertz, MU, MU * P, allow_full_slip=True)
    ref = mcewen_normal(X, Z, A_HERTZ, P0) + smith_liu(X, Z, A_HERTZ, MU * P0)
    assert np.max(np.abs(components(analytic.stress(sliding, X, -Z, nu=NU)) - ref)) / P0 < FIELD_TOL


@pytest.mark.parametrize("ratio", [0.3, 0.8])
def test_cattaneo_superposition(hertz, grid, ratio):
    X, Z = grid
    st = analytic.solve_stick(hertz, MU, ratio * MU * P)
    c = A_HERTZ * np.sqrt(1 - ratio)
    ref = (mcewen_normal(X, Z, A_HERTZ, P0) + smith_liu(X, Z, A_HERTZ, MU * P0)
           - smith_liu(X, Z, c, MU * P0 * c / A_HERTZ))
    assert np.max(np.abs(components(analytic.stress(st, X, -Z, nu=NU)) - ref)) / P0 < FIELD_TOL


def test_stage3_end_is_the_mirror_of_stage2(hertz, grid):
    """At Q = -Q0 the shear is -q0: the shear part of the field flips, the normal part stays."""
    X, Z = grid
    Q0 = 0.6 * MU * P
    s2, s3 = analytic.solve_stick(hertz, MU, Q0), analytic.solve_stick(hertz, MU, -Q0, Q0)
    normal = mcewen_normal(X, Z, A_HERTZ, P0)
    f2 = components(analytic.stress(s2, X, -Z, nu=NU)) - normal
    f3 = components(analytic.stress(s3, X, -Z, nu=NU)) - normal
    assert np.max(np.abs(f2 + f3)) / P0 < FIELD_TOL


def test_surface_stress_sliding(hertz):
    """Surface sxx = -p - 2 mu p0 x / a inside, -(2 mu p0/a)(x - sign(x) sqrt(x^2 - a^2)) out."""
    sliding = analytic.solve_stick(hertz, MU, MU * P, allow_full_slip=True)
    x = np.r_[np.linspace(-1.6, 1.6, 321), 0.0, -0.7071067811865476, -0.999999, 1.000001]
    x = x[np.abs(np.abs(x) - 1) > 1e-7] * A_HERTZ  # the solver's edge is 1e-14 from a: sqrt(1e-14)
    t = x / A_HERTZ
    out = t - np.sign(t) * np.sqrt(np.clip(t**2 - 1, 0, None))
    ref = np.where(np.abs(t) < 1, -P0 * np.sqrt(np.clip(1 - t**2, 0, None)) - 2 * MU * P0 * t,
                   -2 * MU * P0 * out)
    assert np.max(np.abs(analytic.surface_stress(sliding, x) - ref)) / P0 < SURFACE_TOL


def test_surface_peak_at_the_trailing_edge(hertz):
    """Cattaneo: the tensile peak sits at the trailing edge x = -a (Johnson Fig. 7.5)."""
    st = analytic.solve_stick(hertz, MU, 0.5 * MU * P)
    x = np.linspace(-1.5, 1.5, 3001) * A_HERTZ
    s = analytic.surface_stress(st, x)
    assert abs(x[np.argmax(s)] + A_HERTZ) <= 1e-3 * A_HERTZ
    assert np.max(s) > 0 > np.min(s)


def test_surface_limit_of_the_field(hertz):
    st = analytic.solve_stick(hertz, MU, 0.5 * MU * P)
    x = np.r_[np.linspace(-1.5, 1.5, 151), 0.0] * A_HERTZ
    edges = np.r_[hertz.zones[0], st.stick_zones[0]]
    x = x[np.min(np.abs(x[:, None] - edges), axis=1) > 0.02 * A_HERTZ]  # sqrt ends: ~sqrt(z)
    deep = analytic.stress(st, x, -1e-9 * A_HERTZ, nu=NU)
    top = analytic.stress(st, x, 0.0, nu=NU)
    assert np.max(np.abs(top.sxx - analytic.surface_stress(st, x))) == 0.0
    assert np.max(np.abs(components(deep) - components(top))) / P0 < LIMIT_TOL
    assert np.allclose(top.syy, -hertz.pressure(x), rtol=0, atol=1e-13 * P0)
    assert np.allclose(top.sxy, st.shear(x), rtol=0, atol=1e-13 * P0)


#: The reference quadrature's own error bound in units of P / half, a tenth of FIELD_TOL
#: (measured at most 4.5e-12: QUADPACK's round-off notice at a zero xy component is harmless).
QUAD_ERR = 1e-11


def flamant(x: float, z: float, p) -> np.ndarray:
    """(sxx, syy, sxy) of p(s) = P/(pi sqrt(a^2 - s^2)) by QUADPACK with the 1/sqrt weight."""
    def f(kind, s):
        u = x - s
        r4 = (u * u + z * z) ** 2
        return {"xx": z * u * u, "yy": z**3, "xy": -z * z * u}[kind] / r4

    w = {"weight": "alg", "wvar": (-0.5, -0.5), "epsabs": 0, "epsrel": 1e-11, "limit": 200,
         "full_output": 1}
    out = []
    for k in ("xx", "yy", "xy"):  # QUADPACK's round-off notice: judged here by its error bound
        val, err = quad(lambda s, k=k: f(k, s), -p, p, **w)[:2]
        assert (2 / np.pi**2) * p * err <= QUAD_ERR, (x, z, k, val, err)  # in units of P / p
        out.append(val)
    return -(2 / np.pi) * (P / np.pi) * np.array(out)


def test_sharp_flat_punch():
    half = 0.4
    punch = analytic.solve_normal(pr.flat_punch(-half, half), P, A)
    assert punch.singular == [(True, True)]
    pts = [(0.0, 0.3), (0.2, 0.05), (-0.39, 0.02), (0.45, 0.1), (0.0, 2.0), (-0.7, 0.4)]
    x, z = np.array(pts).T
    got = components(analytic.stress(punch, x, -z, nu=NU))
    ref = np.array([flamant(xi, zi, half) for xi, zi in pts]).T
    assert np.max(np.abs(got - ref)) / (P / half) < FIELD_TOL
    xs = np.r_[np.linspace(-0.39, 0.39, 41), 0.5, -0.8]
    ref = np.where(np.abs(xs) < half, -P / (np.pi * np.sqrt(np.abs(half**2 - xs**2))), 0.0)
    assert np.max(np.abs(analytic.surface_stress(punch, xs) - ref)) / (P / half) < SURFACE_TOL


def box_resultant(sol, x1: float, x2: float, depth: float, n: int = 400) -> np.ndarray:
    """Force on the box [x1, x2] x [-depth, 0] through its bottom and side faces."""
    u, w = np.polynomial.legendre.leggauss(n)
    xb, wx = 0.5 * (x1 + x2) + 0.5 * (x2 - x1) * u, 0.5 * (x2 - x1) * w
    ys, wy = -0.5 * depth * (1 + u), 0.5 * depth * w
    bot = analytic.stress(sol, xb, -depth, nu=NU)
    left, right = (analytic.stress(sol, xv, ys, nu=NU) for xv in (x1, x2))
    fx = -wx @ bot.sxy + wy @ (right.sxx - left.sxx)
    fy = -wx @ bot.syy + wy @ (right.sxy - left.sxy)
    return np.array([fx, fy])


@pytest.mark.parametrize("case", ["cattaneo", "two_zones_stage3"])
def test_box_equilibrium(hertz, case):
    """Face tractions + surface load (Q, -P) = 0 for a box around every zone."""
    if case == "cattaneo":
        sol = analytic.solve_stick(hertz, MU, 0.5 * MU * P)
    else:
        two = pr.union(pr.cylinder(1.0, center=-0.6), pr.cylinder(0.7, center=0.5, lift=0.01))
        normal = analytic.solve_normal(two, P, A)
        assert normal.n_zones == 2
        sol = analytic.solve_stick(normal, MU, 0.2 * MU * P, 0.7 * MU * P)
    zones = sol.normal.zones
    lo, hi = zones[0][0], zones[-1][1]
    span = hi - lo
    force = box_resultant(sol, lo - 0.5 * span, hi + 0.5 * span, span)
    assert np.max(np.abs(force + np.array([sol.Q, -P]))) / P < EQUILIBRIUM_TOL


def test_bad_input(hertz):
    with pytest.raises(InputError, match="y="):
        analytic.stress(hertz, 0.0, 0.1, nu=NU)
    with pytest.raises(InputError, match="nu="):
        analytic.stress(hertz, 0.0, -0.1, nu=0.7)
    with pytest.raises(InputError, match="NormalSolution or StickSolution"):
        analytic.surface_stress("hertz", 0.0)
    with pytest.raises(InputError, match="stage-3"):
        analytic.ruiz(analytic.solve_stick(hertz, MU, 0.1))


def test_box_equilibrium_with_kinks():
    """The double wedge: an apex kink inside each zone (log-singular p there)."""
    wedge = pr.double_wedge(1.0, 0.01, 0.02)
    normal = analytic.solve_normal(wedge, P, A)
    assert sum(a < k < b for k in wedge.kinks for a, b in normal.zones) == 2
    lo, hi = normal.zones[0][0], normal.zones[-1][1]
    span = hi - lo
    force = box_resultant(normal, lo - 0.5 * span, hi + 0.5 * span, span, n=200)
    assert np.max(np.abs(force + np.array([0.0, -P]))) / P < KINK_EQUILIBRIUM_TOL


def test_steep_stick_pressure_is_resolved():
    """Gladwell's punch just merged, its reduced problem near the split: p_S rises within 1e-4
    of the zone width at the stick edge.  The panels adapt: the field tends to the surface
    value there (it did not with four fixed panels: 1 % off, diverging as z -> 0)."""
    normal = analytic.solve_normal(pr.biquadratic(1.0, 10.0), 8000.0, 4 * (1 - 0.09) / 2e5)
    assert normal.n_zones == 1
    st = analytic.solve_stick(normal, MU, 600.0)
    c = st.stick_zones[0][1]
    top = float(analytic.surface_stress(st, c))
    deep = analytic.stress(st, c, -np.array([1e-13, 1e-12]), nu=NU).sxx
    assert np.max(np.abs(deep - top)) / abs(top) < EDGE_LIMIT_TOL
