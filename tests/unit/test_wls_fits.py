"""The band estimator's weighted least-squares fits (fem.results._wls_roots and its helpers)
against the exact least-squares solution of the same floating-point data (rational arithmetic,
roots and square roots to 50 digits), and the small helpers that replace numpy calls with the
same arithmetic.

The data are shaped like a band's: t = 0, -1, -2, ... elements from the run's end (stretched and
shifted), y = f**2 falling through a root t0 near the end with a 2 % ripple, weights 1/sig.
"""

from __future__ import annotations

from decimal import Decimal, getcontext
from fractions import Fraction

import numpy as np
import pytest

from fem.results import (
    _median,
    _nearest_root,
    _nested_qr,
    _wls_design,
    _wls_root_lstsq,
    _wls_roots,
    _wls_roots_of,
    quadratic_roots,
    runs,
)

#: Root of a fit (elements of t, or relative beyond |t0| = 1) against the exact least-squares
#: root of the same data: measured 4.2e-14 (random weights) and 1.1e-14 (the band's weights),
#: 300 data sets each; the former per-fit lstsq 4.3e-13.
ROOT_EXACT = 1e-12
#: Relative error of a fit's standard deviation: measured 6.9e-13 / 1.4e-12 (the former
#: pinv of the normal matrix: 3.6e-12 / 5.1e-13).
SD_EXACT = 1e-10
#: Weights spanning six decades (sig = 10**U(-3, 3), design condition numbers up to ~1e6):
#: root 7.2e-10, standard deviation 1.2e-8 relative (the former pinv route: 1.7e-4).
ROOT_ILL, SD_ILL = 1e-8, 1e-6
#: The fits against the former per-fit lstsq and pinv of the normal matrix (the numbers this
#: replaced): measured roots 4.3e-13 elements apart, standard deviations 3.6e-12 relative.
ROOT_LSTSQ, SD_LSTSQ = 1e-11, 1e-10
#: Factor R of the stacked QR: |R^T R - A^T A| / |A|**2, measured 4e-16.
GRAM_EXACT = 1e-13

getcontext().prec = 50


def _solve(G: list, r: list) -> list:
    """Exact solution of G c = r (Fractions, Gauss-Jordan)."""
    n = len(G)
    M = [row[:] + [r[i]] for i, row in enumerate(G)]
    for i in range(n):
        piv = next(j for j in range(i, n) if M[j][i] != 0)
        M[i], M[piv] = M[piv], M[i]
        for j in range(n):
            if j != i and M[j][i] != 0:
                f = M[j][i] / M[i][i]
                M[j] = [a - f * b for a, b in zip(M[j], M[i], strict=True)]
    return [M[i][n] / M[i][i] for i in range(n)]


def _dec(q: Fraction) -> Decimal:
    return Decimal(q.numerator) / Decimal(q.denominator)


def exact_fit(design: np.ndarray) -> tuple[float, float] | None:
    """(root, standard deviation) of the exact least-squares fit _wls_roots makes of ``design``
    (a quadratic with >= 4 rows, else a line; the root nearest 0 where it falls towards +t)."""
    rows = [[Fraction(v) for v in row] for row in design.tolist()]
    m = len(rows)
    p = 3 if m >= 4 else 2
    A, b = [r[:p] for r in rows], [r[3] for r in rows]
    G = [[sum(A[i][a] * A[i][c] for i in range(m)) for c in range(p)] for a in range(p)]
    c = _solve(G, [sum(A[i][a] * b[i] for i in range(m)) for a in range(p)])
    c0, c1, c2 = (_dec(v) for v in c + [Fraction(0)] * (3 - p))
    disc = c1 * c1 - 4 * c0 * c2
    if disc < 0:
        return None
    roots = [-c0 / c1] if c2 == 0 else [(-c1 + s * disc.sqrt()) / (2 * c2) for s in (1, -1)]
    ok = [r for r in roots if c1 + 2 * c2 * r < 0]
    if not ok:
        return None
    t0 = min(ok, key=abs)
    res = [b[i] - sum(A[i][a] * c[a] for a in range(p)) for i in range(m)]
    s2 = sum(r * r for r in res) / (m - p) if m > p else Fraction(0)
    g = [Decimal(1), t0, t0 * t0][:p]
    inv = [_solve(G, [Fraction(int(i == j)) for i in range(p)]) for j in range(p)]
    var = _dec(s2) * sum(g[a] * _dec(inv[a][e]) * g[e] for a in range(p) for e in range(p))
    return float(t0), float(var.sqrt() / abs(c1 + 2 * c2 * t0))


def band_data(rng: np.random.Generator, n: int, weights: str):
    t = -np.arange(float(n)) * rng.uniform(0.5, 1.5) + rng.uniform(-0.3, 0.3)
    y = (rng.uniform(0.05, 0.9) - t) * (1.0 - rng.uniform(0, 0.05) * t) \
        * (1 + 0.02 * rng.uniform(-1, 1, n))
    if weights == "random":
        sig = rng.uniform(0.5, 2.0, n)
    elif weights == "band":  # as band_edge weighs f**2: sig ~ f * max(f, 5 % of max f)
        f = np.sqrt(np.maximum(y, 0.0))
        sig = np.maximum(f, 0.05 * f.max()) ** 2
    else:
        sig = 10.0 ** rng.uniform(-3, 3, n)
    return t, y, sig


def close(fit, ref, root_tol: float, sd_tol: float) -> bool:
    return abs(fit[0] - ref[0]) <= root_tol * max(1.0, abs(ref[0])) and \
        abs(fit[1] - ref[1]) <= sd_tol * ref[1]


@pytest.mark.parametrize(("weights", "root_tol", "sd_tol"), [
    ("random", ROOT_EXACT, SD_EXACT), ("band", ROOT_EXACT, SD_EXACT), ("ill", ROOT_ILL, SD_ILL)])
def test_fits_are_the_exact_least_squares_fits(weights, root_tol, sd_tol):
    """Every fit (k = 0, 1, 2 points dropped; 2 to 32 points: lines and quadratics) is the
    exact weighted least-squares fit of the same data, root and standard deviation."""
    rng = np.random.default_rng(11)
    checked = 0
    for n in (2, 3, 4, 5, 8, 16, 32) * 4:
        t, y, sig = band_data(rng, n, weights)
        design = _wls_design(t, y, sig)
        for k, fit in enumerate(_wls_roots(t, y, sig, 3)):
            ref = exact_fit(design[k:]) if n - k >= 2 else None
            assert (fit is None) == (ref is None), (n, k, fit, ref)
            if ref is not None:
                assert close(fit, ref, root_tol, sd_tol), (n, k, fit, ref)
                checked += 1
    assert checked > 60


@pytest.mark.parametrize("weights", ["random", "band"])
def test_fits_agree_with_the_per_fit_lstsq(weights):
    """The stacked fits against the former route (one lstsq per fit, the covariance from the
    pseudo-inverse of the normal matrix), which stays as the fallback."""
    rng = np.random.default_rng(5)
    for n in (2, 3, 4, 5, 9, 17, 32) * 3:
        t, y, sig = band_data(rng, n, weights)
        design = _wls_design(t, y, sig)
        for k, fit in enumerate(_wls_roots(t, y, sig, 3)):
            m = n - k
            if m < 2:
                assert fit is None
                continue
            deg = 2 if m >= 4 else 1
            ref = _wls_root_lstsq(design[k:, :deg + 1], design[k:, 3], deg)
            assert (fit is None) == (ref is None)
            if ref is not None:
                assert abs(fit[0] - ref[0]) <= ROOT_LSTSQ * max(1.0, abs(ref[0]))
                assert abs(fit[1] - ref[1]) <= SD_LSTSQ * ref[1] + 1e-300


def test_degenerate_sizes():
    """2 points: a line through both (no residual: standard deviation 0), nothing after
    dropping one; 3 points: a line, 4: a quadratic (one degree of freedom each)."""
    t = np.array([0.2, -1.0, -2.0, -3.1])
    y = (0.4 - t) * (1.0 - 0.1 * t) + np.array([0.0, 0.01, -0.02, 0.0])
    sig = np.array([0.5, 1.0, 2.0, 1.0])
    design = _wls_design(t, y, sig)
    for n in (2, 3, 4):
        fits = _wls_roots(t[:n], y[:n], sig[:n], 3)
        assert len(fits) == 3
        for k, fit in enumerate(fits):
            m = n - k
            if m < 2:
                assert fit is None
                continue
            ref = exact_fit(design[k:n])
            assert close(fit, ref, ROOT_EXACT, SD_EXACT), (n, k, fit, ref)
            if m == 2:  # no degree of freedom
                assert fit[1] == 0.0
            else:
                assert fit[1] > 0.0


def test_weights_scale_free_and_a_heavy_point_pins_the_fit():
    rng = np.random.default_rng(2)
    t, y, sig = band_data(rng, 12, "random")
    base = _wls_roots(t, y, sig, 3)
    for factor in (2.0**-30, 1e-6, 1e6):
        for fit, ref in zip(_wls_roots(t, y, factor * sig, 3), base, strict=True):
            assert close(fit, ref, ROOT_EXACT, SD_EXACT)
    heavy = sig.copy()
    heavy[0] *= 1e-7  # the end point weighs 1e14 times more: the fit passes through it
    (c0, c1, c2) = np.polynomial.polynomial.polyfit(t, y, 2, w=1 / heavy)
    assert abs(c0 + c1 * t[0] + c2 * t[0] ** 2 - y[0]) < 1e-9 * abs(y[0])
    fit = _wls_roots(t, y, heavy, 1)[0]
    assert close(fit, exact_fit(_wls_design(t, y, heavy)), ROOT_ILL, SD_ILL)


def test_rank_deficient_design_takes_the_minimum_norm_lstsq():
    """Repeated t (two distinct values, a quadratic cannot be fitted): the fit is the former
    minimum-norm lstsq one, to the last bit."""
    t = np.array([0.0, 0.0, -1.0, -1.0, -1.0, 0.0])
    y = np.array([0.1, 0.11, 2.0, 1.95, 2.05, 0.09])
    sig = np.ones(t.size)
    design = _wls_design(t, y, sig)
    fits = _wls_roots(t, y, sig, 2)
    for k in range(2):
        assert fits[k] == _wls_root_lstsq(design[k:, :3], design[k:, 3], 2)
        assert fits[k] is not None


def test_stacked_factors_do_not_depend_on_the_stack():
    """The upper triangle of each stacked R is that of the matrix alone (to the last bit), and
    R^T R is the Gram matrix."""
    rng = np.random.default_rng(8)
    mats = [rng.normal(size=(n, 4)) for n in (5, 32, 2, 9)]
    counts = [3, 3, 2, 1]
    stacked = _nested_qr(mats, counts)
    j = 0
    for a, count in zip(mats, counts, strict=True):
        for k in range(count):
            alone = _nested_qr([a[k:]], [1])[0]
            assert np.array_equal(np.triu(stacked[j]), np.triu(alone))
            r = np.triu(alone)[:min(4, a.shape[0] - k)]
            gram = a[k:].T @ a[k:]
            assert np.abs(r.T @ r - gram).max() <= GRAM_EXACT * np.abs(a[k:]).max() ** 2 * 32
            j += 1


def test_fits_of_several_designs_are_each_designs_own():
    rng = np.random.default_rng(4)
    data = [band_data(rng, n, "band") for n in (32, 16, 8)]
    together = [[fit(k) for k in range(4)] for fit in _wls_roots_of(
        [_wls_design(*d) for d in data], 3)]
    assert together == [_wls_roots(*d, 3) + [None] for d in data]


def _old_nearest(c0: float, c1: float, c2: float, rising: int):
    """The former numpy selection (power_root / _wls_roots)."""
    roots = quadratic_roots(c0, c1, c2)
    ok = roots[(c1 + 2 * c2 * roots) * rising > 0]
    return None if ok.size == 0 else float(ok[np.argmin(np.abs(ok))])


def test_nearest_root_is_the_former_numpy_selection():
    rng = np.random.default_rng(6)
    cases = [tuple(rng.normal(size=3)) for _ in range(400)]
    cases += [(c0, c1, 0.0) for c0, c1, _ in cases[:50]]
    cases += [(0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0),
              (1.0, 2.0, 1.0), (-1.0, 2.0, -1.0), (0.0, -0.0, 2.0), (1.0, 1.0, 1.0)]
    for c in cases:
        for rising in (-1, 1):
            assert _nearest_root(*c, rising) == _old_nearest(*c, rising), (c, rising)


def test_median_is_numpys():
    rng = np.random.default_rng(9)
    for n in (1, 2, 3, 4, 7, 10, 101):
        a = rng.normal(size=n) * 10.0 ** rng.uniform(-5, 5, n)
        assert _median(a) == float(np.median(a))
        a[n // 2] = np.nan
        assert np.isnan(_median(a)) and np.isnan(np.median(a))


def test_runs_are_the_index_ranges_of_true_entries():
    rng = np.random.default_rng(10)
    for n in (0, 1, 2, 5, 40):
        mask = rng.uniform(size=n) < 0.5
        expect, i = [], 0
        while i < n:
            if mask[i]:
                j = i
                while j + 1 < n and mask[j + 1]:
                    j += 1
                expect.append((i, j))
                i = j
            i += 1
        assert runs(mask) == expect
