"""Verification of the independent discretised solver ``compare.bem`` against closed forms.

Closed forms (plane strain, similar materials, A = 4 (1 - nu^2) / E, p >= 0):
- Hertz line contact, h0 = x^2 / (2R): a^2 = 2 A P R / pi, p0 = a / (A R),
  p = p0 sqrt(1 - x^2 / a^2) (Johnson, Contact Mechanics, 1985, Sec. 5.6).
- Sharp flat punch of half-width b: p = P / (pi sqrt(b^2 - x^2)) (Johnson Sec. 5.2).
- Cattaneo-Mindlin: stage 2 stick half-width c = a sqrt(1 - Q / (mu P)),
  stage 3 c = a sqrt(1 - (Q0 - Q) / (2 mu P)) (Johnson Sec. 7.2, 7.3).
- Applied moment on a cylinder: h0 - theta x is a shifted parabola, theta = M / (P R),
  zone centre at M / P.
"""

from __future__ import annotations

import numpy as np
import pytest

from compare import bem, bem_tangential

A = 1.0
R = 1.0
P = 0.5
MU = 0.3
A_HERTZ = np.sqrt(2 * A * P * R / np.pi)
P0_HERTZ = A_HERTZ / (A * R)

EDGE_ERROR_PANELS = 0.05
"""Contact-edge error bound in panel widths (sqrt_edge: observed <= 0.03 dx on Hertz)."""
STICK_EDGE_PANELS = 0.15
"""Stick-edge error bound in panel widths (observed <= 0.07 dx on Cattaneo-Mindlin)."""
MIN_ORDER = 0.85
"""Lowest accepted observed edge-convergence order (expected 1: the edge panel is binary)."""
PEAK_PRESSURE_REL = 1e-3
"""Relative error of the Hertz peak pressure (observed <= 1e-4 from N = 64)."""
ROUNDOFF = 1e-12
"""Relative tolerance for quantities the solver imposes exactly (loads, moments)."""


def hertz(x: np.ndarray) -> np.ndarray:
    return x**2 / (2 * R)


def hertz_window() -> tuple[float, float]:
    return (-1.5 * A_HERTZ, 1.5 * A_HERTZ)


def slope(dx: list[float], err: list[float]) -> float:
    """Least-squares slope of log(err) against log(dx): the observed order."""
    return float(np.polyfit(np.log(dx), np.log(err), 1)[0])


def check_admissible(sol: bem.BemNormal) -> None:
    scale = sol.A * sol.P
    assert np.all(sol.p >= 0)
    assert np.all(sol.g[~sol.active] >= -bem.GAP_TOL * scale)
    assert np.all(sol.p[~sol.active] == 0)
    assert sum(sol.zone_loads) == pytest.approx(sol.P, rel=ROUNDOFF)


def test_hertz_edge_converges_with_observed_order() -> None:
    # N = 64 * 4^k keeps the exact edge at the same fraction of its panel (1/3), so the
    # error constant is the same on every grid and the slope is the order.
    ns = [64, 256, 1024]
    errors, dxs = [], []
    for n in ns:
        sol = bem.solve_normal_bem(hertz, hertz_window(), n, P, A)
        assert len(sol.zones) == 1
        a, b = sol.zones[0]
        errors.append(max(abs(a + A_HERTZ), abs(b - A_HERTZ)))
        dxs.append(sol.dx)
        assert sol.p.max() == pytest.approx(P0_HERTZ, rel=PEAK_PRESSURE_REL)
        check_admissible(sol)
    assert all(e1 < e0 for e0, e1 in zip(errors, errors[1:], strict=False))
    assert slope(dxs, errors) >= MIN_ORDER


@pytest.mark.parametrize("n", range(64, 161, 8))
def test_hertz_edge_subpanel_for_any_edge_position(n: int) -> None:
    sol = bem.solve_normal_bem(hertz, hertz_window(), n, P, A)
    a, b = sol.zones[0]
    assert abs(a + A_HERTZ) <= EDGE_ERROR_PANELS * sol.dx
    assert abs(b - A_HERTZ) <= EDGE_ERROR_PANELS * sol.dx
    assert sol.singular == ((False, False),)


def flat_punch(b: float):
    return lambda x: np.where(np.abs(x) <= b, 0.0, np.inf)


@pytest.mark.parametrize("window_factor", [1.0, 2.0])
def test_sharp_flat_punch(window_factor: float) -> None:
    b = 0.5
    errors = []
    for n in (64, 256, 1024):
        sol = bem.solve_normal_bem(flat_punch(b), (-window_factor * b, window_factor * b),
                                   n, P, A)
        assert sol.zones == ((-b, b),)
        assert sol.singular == ((True, True),)
        check_admissible(sol)
        inner = np.abs(sol.x) < b / 2
        exact = P / (np.pi * np.sqrt(b**2 - sol.x[inner] ** 2))
        errors.append(np.abs(sol.p[inner] / exact - 1).max())
        # piecewise-constant collocation of a 1/sqrt edge: interior error O(dx / b)
        assert errors[-1] < sol.dx / b
    assert errors[1] < errors[0] / 3 and errors[2] < errors[1] / 3


def cattaneo_shear(x: np.ndarray, c: float) -> np.ndarray:
    """Stage-2 shear mu [p(x; a) - p(x; c)] for the Hertz contact (half-widths a, c)."""
    def hertz_p(half: float) -> np.ndarray:
        return np.sqrt(np.clip(1 - (x / half) ** 2, 0, None)) * half / (A * R)
    return MU * (hertz_p(A_HERTZ) - hertz_p(c))


@pytest.mark.parametrize("ratio", [0.3, 0.8])
def test_cattaneo_mindlin_stages_2_and_3(ratio: float) -> None:
    sol = bem.solve_normal_bem(hertz, hertz_window(), 512, P, A)
    q0_total = ratio * MU * P
    stage2 = bem_tangential.solve_tangential_bem(sol, MU, q0_total)
    c = A_HERTZ * np.sqrt(1 - q0_total / (MU * P))
    check_stick(stage2, (-c, c))
    inner = np.abs(sol.x) < 0.95 * A_HERTZ
    shear_err = np.abs(stage2.q - cattaneo_shear(sol.x, c))[inner].max()
    assert shear_err < 0.01 * MU * P0_HERTZ  # O(sqrt(dx)) at the stick edge kink
    for q_end in (0.5 * q0_total, -0.5 * q0_total, -q0_total):
        stage3 = bem_tangential.solve_tangential_bem(sol, MU, q_end, q_start=stage2.q,
                                          Q_start=q0_total)
        c3 = A_HERTZ * np.sqrt(1 - (q0_total - q_end) / (2 * MU * P))
        check_stick(stage3, (-c3, c3))


def check_stick(shear: bem_tangential.BemShear, exact: tuple[float, float]) -> None:
    normal = shear.normal
    c, d = shear.stick_zones[0]
    assert abs(c - exact[0]) <= STICK_EDGE_PANELS * normal.dx
    assert abs(d - exact[1]) <= STICK_EDGE_PANELS * normal.dx
    assert normal.dx * shear.q.sum() == pytest.approx(shear.Q, abs=ROUNDOFF * MU * P)
    bound = shear.mu * normal.p
    assert np.all(np.abs(shear.q) <= bound * (1 + bem_tangential.SLIP_TOL) + 1e-300)
    slipping = normal.active & ~shear.stick
    assert np.all(shear.slip[shear.stick] == 0)
    assert np.allclose(shear.q[slipping], bound[slipping] * np.sign(shear.slip[slipping]))


def test_applied_moment_on_cylinder() -> None:
    M = 0.1 * P * A_HERTZ
    for n in (256, 1024):
        sol = bem.solve_normal_bem(hertz, (-2 * A_HERTZ, 2 * A_HERTZ), n, P, A, M=M)
        a, b = sol.zones[0]
        assert sol.theta == pytest.approx(M / (P * R), rel=1e-3)
        assert (a + b) / 2 == pytest.approx(M / P, abs=EDGE_ERROR_PANELS * sol.dx)
        assert b - a == pytest.approx(2 * A_HERTZ, abs=2 * EDGE_ERROR_PANELS * sol.dx)
        assert sol.M == pytest.approx(M, rel=ROUNDOFF)
        check_admissible(sol)


def two_cylinders(x: np.ndarray) -> np.ndarray:
    """Cylinders R = 1 at x = -1 and R = 0.5 at x = 1.2, the second lifted by 0.02."""
    return np.minimum((x + 1) ** 2 / 2, (x - 1.2) ** 2 + 0.02)


@pytest.mark.parametrize(("load", "moment", "n_zones"),
                         [(0.01, None, 1), (0.2, None, 2), (0.3, -0.05, 2)])
def test_two_cylinders_unequal_lift(load: float, moment: float | None, n_zones: int) -> None:
    edges = []
    for n in (256, 1024):
        sol = bem.solve_normal_bem(two_cylinders, (-2.5, 2.5), n, load, A, M=moment)
        assert len(sol.zones) == n_zones
        check_admissible(sol)
        assert sol.P == pytest.approx(load, rel=ROUNDOFF)
        assert sol.M == pytest.approx(sol.dx * (sol.x * sol.p).sum(), rel=ROUNDOFF)
        if moment is not None:
            assert sol.M == pytest.approx(moment, rel=ROUNDOFF)
        edges.append(np.array(sol.zones))
    assert np.abs(edges[1] - edges[0]).max() < 2.5 / 256  # self-convergence within a coarse dx


def test_two_cylinders_one_zone_in_full_slip() -> None:
    sol = bem.solve_normal_bem(two_cylinders, (-2.5, 2.5), 512, 0.05, A)
    assert len(sol.zones) == 2 and sol.zone_loads[1] < 0.5 * sol.zone_loads[0]
    # stick at the reduced load P* = P - Q / mu: only the first zone still touches
    shear = bem_tangential.solve_tangential_bem(sol, MU, 0.8 * MU * sol.P)
    assert shear.full_slip_zones == (1,)
    assert shear.stick_zones[1] is None and shear.stick_zones[0] is not None
    assert sol.dx * shear.q.sum() == pytest.approx(shear.Q, abs=ROUNDOFF)


def test_sharp_punch_beside_two_cylinders() -> None:
    def profile(x: np.ndarray) -> np.ndarray:
        punch = np.where((x >= -1.25) & (x <= -0.75), 0.0, np.inf)
        return np.minimum.reduce([punch, (x - 0.8) ** 2 / 2 + 0.01, x**2 + 0.03])

    sol = bem.solve_normal_bem(profile, (-1.5, 1.5), 768, 1.0, A)  # corners on panel edges
    check_admissible(sol)
    assert len(sol.zones) == 3
    assert sol.zones[0] == pytest.approx((-1.25, -0.75), abs=1e-12)
    assert sol.singular == ((True, True), (False, False), (False, False))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"P": -1.0}, "P=-1.0"), ({"A": 0.0}, "A=0.0"), ({"N": 4}, "N=4"),
     ({"window": (1.0, -1.0)}, "window"), ({"M": 10.0}, "M=10.0"),
     ({"h0": lambda x: np.full_like(x, np.inf)}, "inf on every panel")],
)
def test_bad_normal_inputs(kwargs: dict, match: str) -> None:
    args = {"h0": hertz, "window": hertz_window(), "N": 64, "P": P, "A": A} | kwargs
    with pytest.raises(ValueError, match=match):
        bem.solve_normal_bem(**args)


def test_window_too_small_raises() -> None:
    with pytest.raises(RuntimeError, match="window boundary"):
        bem.solve_normal_bem(hertz, (-0.5 * A_HERTZ, 0.5 * A_HERTZ), 64, P, A)


def test_bad_tangential_inputs() -> None:
    sol = bem.solve_normal_bem(hertz, hertz_window(), 64, P, A)
    with pytest.raises(ValueError, match="mu=0"):
        bem_tangential.solve_tangential_bem(sol, 0.0, 0.01)
    with pytest.raises(ValueError, match="gross sliding"):
        bem_tangential.solve_tangential_bem(sol, MU, MU * P)
    with pytest.raises(ValueError, match="Q_start"):
        bem_tangential.solve_tangential_bem(sol, MU, 0.01, q_start=np.zeros(64), Q_start=0.05)


def test_cattaneo_mindlin_in_applied_moment_mode() -> None:
    # rotation fixed during the tangential stages: the stick zone is the Hertz zone of the
    # reduced load about the same shifted centre M / P (theta = M / (P R))
    M = -0.2 * P * A_HERTZ
    sol = bem.solve_normal_bem(hertz, (-2 * A_HERTZ, 2 * A_HERTZ), 512, P, A, M=M)
    q_total = 0.6 * MU * P
    c = A_HERTZ * np.sqrt(1 - q_total / (MU * P))
    check_stick(bem_tangential.solve_tangential_bem(sol, MU, q_total), (M / P - c, M / P + c))


@pytest.mark.parametrize("n", [8, 100, 1024])
def test_influence_matrix_symmetric_positive_definite(n: int) -> None:
    K = bem.Grid(-3.0, 7.0, n).influence(A)
    assert np.array_equal(K, K.T)
    assert np.linalg.eigvalsh(K).min() > 0
