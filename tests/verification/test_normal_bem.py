"""Analytic normal solver against the independent discretised solver ``compare.bem``.

``compare.bem`` (influence coefficients with the log kernel, piecewise-constant pressure,
active set; it imports neither ``analytic`` nor ``fem``) is first order in the panel width
dx: its sub-panel sqrt-edge estimator is within ~0.03 dx of a nonsingular edge
(tests/verification/test_bem.py) and a sharp corner sits on a panel boundary.
Here both solve the same asymmetric multi-zone cases; the analytic edges (1e-10 accurate)
serve as the reference and we check

- same topology (number of zones, singular flags) on every grid,
- every nonsingular edge within ``BEM_EDGE_PANELS`` panel widths, singular edges exact,
- zone loads and pressure agree to O(dx),
- convergence: the grid-averaged edge error decreases with N at observed order ~1.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

import analytic
from analytic import profiles
from compare.bem import solve_normal_bem

A = 1.0

BEM_EDGE_PANELS = 0.1
"""Nonsingular edge agreement in BEM panel widths (compare.bem documents <= 0.05 dx on Hertz;
2x margin for multi-zone interaction)."""
MIN_ORDER, MAX_ORDER = 0.7, 1.5
"""Accepted observed order of the grid-averaged edge error (expected 1: the edge panel is
binary and the estimator's error is a fixed fraction of dx)."""
LOAD_SHARE_PANELS = 1.0
"""Zone-load error |F_bem - F_an| / P per panel width relative to the contact span (O(dx))."""
OFFSETS = tuple(range(0, 16, 2))
"""Grids N + offset averaged at each level: the edge error C(f) dx depends on the fraction f of
its panel where the exact edge falls; averaging over f removes that sawtooth from the order."""


def two_cylinders() -> profiles.Profile:
    """Unequal radii and lifts: the right zone starts touching at a higher load."""
    return profiles.union(profiles.cylinder(1.0, center=-1.0),
                          profiles.cylinder(0.5, center=1.2, lift=0.02))


def three_cylinders() -> profiles.Profile:
    return profiles.union(profiles.cylinder(1.0, center=-1.5),
                          profiles.cylinder(0.5, center=0.2, lift=0.01),
                          profiles.cylinder(2.0, center=1.8, lift=0.03))


def punch_and_cylinder() -> profiles.Profile:
    """A sharp flat punch on [-1, -0.4] rigidly connected to a lifted cylinder."""
    return profiles.union(profiles.flat_punch(-1.0, -0.4),
                          profiles.cylinder(1.0, center=0.8, lift=0.01))


CASES = {
    # name: (profile, P, window, n_zones)
    "two_cylinders": (two_cylinders, 0.3, (-2.0, 2.0), 2),
    "three_cylinders": (three_cylinders, 0.5, (-2.6, 3.0), 3),
    # corners at -1.0 and -0.4 are panel boundaries for N divisible by 12
    "punch_and_cylinder": (punch_and_cylinder, 0.3, (-1.2, 1.2), 2),
}


def edge_errors(case: str, N: int, exact) -> tuple[np.ndarray, float, object]:
    """BEM solve at N: |edge error| per edge (nan at singular edges) and the panel width."""
    build, P, window, n_zones = CASES[case]
    prof = build()
    bem = solve_normal_bem(prof.h0, window, N, P, A)
    assert len(bem.zones) == n_zones, f"N={N}: BEM zones {bem.zones} vs {exact.zones}"
    assert [tuple(s) for s in bem.singular] == [tuple(s) for s in exact.singular]
    err = np.abs(np.ravel(bem.zones) - np.ravel(exact.zones))
    singular = np.ravel(exact.singular)
    assert np.all(err[singular] <= 1e-12)
    err = np.where(singular, np.nan, err)
    return err, bem.dx, bem


@functools.cache
def exact_solution(case: str):
    """The analytic reference of a case (solved once per session)."""
    build, P, _window, n_zones = CASES[case]
    sol = analytic.solve_normal(build(), P, A)
    assert len(sol.zones) == n_zones
    return sol


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("N", [192, 768])
def test_bem_agrees_to_its_accuracy(case, N) -> None:
    exact = exact_solution(case)
    err, dx, bem = edge_errors(case, N, exact)
    assert np.nanmax(err) <= BEM_EDGE_PANELS * dx
    span = exact.zones[-1][1] - exact.zones[0][0]
    share = np.abs(np.asarray(bem.zone_loads) - np.asarray(exact.zone_loads)) / exact.P
    assert share.max() <= LOAD_SHARE_PANELS * dx / span
    inner = np.zeros(bem.x.size, bool)
    for a, b in exact.zones:
        inner |= (bem.x > a + 0.2 * (b - a)) & (bem.x < b - 0.2 * (b - a))
    p_exact = exact.pressure(bem.x[inner])
    assert np.max(np.abs(bem.p[inner] - p_exact)) <= 0.02 * np.max(p_exact)


def averaged_error(case: str, N: int, exact) -> tuple[float, float]:
    errs, dxs = [], []
    multiple = 12 if case == "punch_and_cylinder" else 1  # keep corners on panel boundaries
    for off in OFFSETS:
        n = N + off * (N // 64)
        err, dx, _ = edge_errors(case, multiple * -(-n // multiple), exact)
        errs.append(np.nanmean(err))
        dxs.append(dx)
    return float(np.mean(errs)), float(np.mean(dxs))


def observed_order(case: str, levels: list[int], exact) -> tuple[float, list[float]]:
    data = [averaged_error(case, N, exact) for N in levels]
    errs = [e for e, _ in data]
    order = float(np.polyfit(np.log([d for _, d in data]), np.log(errs), 1)[0])
    return order, errs


@pytest.mark.parametrize("case", ["two_cylinders", "three_cylinders"])
def test_bem_edge_error_converges_at_first_order(case) -> None:
    order, errs = observed_order(case, [256, 512, 1024], exact_solution(case))
    assert errs[-1] < errs[0]
    assert MIN_ORDER <= order <= MAX_ORDER, f"order {order:.2f}, errors {errs}"


@pytest.mark.slow
@pytest.mark.parametrize("case", list(CASES))
def test_bem_convergence_study_to_N_2048(case) -> None:
    levels = [192, 384, 768, 1536] if case == "punch_and_cylinder" else \
        [256, 512, 1024, 2048]
    order, errs = observed_order(case, levels, exact_solution(case))
    assert all(e1 < e0 for e0, e1 in zip(errs, errs[1:], strict=False)), errs
    assert MIN_ORDER <= order <= MAX_ORDER, f"order {order:.2f}, errors {errs}"
