"""Two contact zones (double wedge) and the applied-moment mode."""

import numpy as np

import fem

E, NU, MU = 1.0, 0.3, 0.5
C, PHI1, PHI2 = 1.0, 0.11, 0.07
R, P = 100.0, 0.01
A_HERTZ = np.sqrt(2 * 4 * (1 - NU**2) / E * P * R / np.pi)


def wedge_gap(x):
    """Double wedge h0 = tan(phi1)(c - |x|) for |x| < c, tan(phi2)(|x| - c) outside."""
    ax = np.abs(x)
    return np.where(ax < C, np.tan(PHI1) * (C - ax), np.tan(PHI2) * (ax - C))


def test_double_wedge_two_symmetric_zones_around_kinks():
    h = fem.solve_history(
        wedge_gap,
        0.02,
        0.005,
        MU,
        E,
        NU,
        window=(-1.6, 1.6),
        kinks=(-C, 0.0, C),
        mesh=fem.MeshSpec(level=0),
        increments=fem.LoadPath(n_normal=5, n_tangential=3),
    )
    s = h.stage(1)[-1]
    (a1, b1), (a2, b2) = s.contact_zones
    assert a1 < -C < b1 < 0 < a2 < C < b2
    assert np.isclose(a1, -b2, atol=1e-9) and np.isclose(b1, -a2, atol=1e-9)
    assert abs(s.M) < 1e-9 * 0.02
    for st in h.stage(2):
        assert all(z is not None for z in st.stick_zones)
        assert max(st.residuals) < 1e-8


def test_applied_moment_mode_balances_moment():
    M = 0.1 * A_HERTZ * P
    h = fem.solve_history(
        lambda x: x**2 / (2 * R),
        P,
        0.25 * P,
        MU,
        E,
        NU,
        M=M,
        window=(-1.5 * A_HERTZ, 1.5 * A_HERTZ),
        mesh=fem.MeshSpec(level=0),
        increments=fem.LoadPath(n_normal=4, n_tangential=2),
    )
    for s in h.steps:
        f = s.interface
        assert abs(np.sum(f.x * f.p * f.w) - s.M) < 1e-9 * P * A_HERTZ
        assert max(s.residuals) < 1e-8
    s = h.stage(1)[-1]
    ((a, b),) = s.contact_zones
    assert b + a > 0.05 * A_HERTZ
    assert s.plate[2] != 0.0


def test_applied_moment_on_a_cylinder_starts_from_a_point_touch():
    """Rotation free, first touch at a single node: one pair cannot balance a moment, so the
    first active set is taken around M/P (the window is centred there, not at the touch).

    Closed form (tilted Hertz): contact centred at ``M/P``, ``theta = M/(P R)`` in the analytic
    convention (the gap in contact is ``h0 - theta x``; FemStep.plate[2]).
    """
    E_, P_, R_ = 2e5, 1e3, 10.0
    a = np.sqrt(2 * 4 * (1 - NU**2) / E_ * P_ * R_ / np.pi)
    M = 0.6 * a * P_
    h = fem.solve_history(
        lambda x: x**2 / (2 * R_),
        P_,
        0.0,
        MU,
        E_,
        NU,
        M=M,
        window=(M / P_ - 1.3 * a, M / P_ + 1.3 * a),  # the loaded contact, as compare sets it
    )
    s = h.steps[-1]
    assert np.isclose(s.plate[2], M / (P_ * R_), rtol=1e-3)
    (lo, hi), = s.contact_zones
    assert abs(0.5 * (lo + hi) - M / P_) < 0.02 * a
    assert max(s.residuals) < 1e-8
