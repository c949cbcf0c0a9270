"""The far-field Gauss sums of analytic._cauchy_integrals: the plain sums, in row blocks whose
size changes no bit of any row (the block size is a memory and speed choice only)."""

from __future__ import annotations

import numpy as np
import pytest

import analytic._cauchy_integrals as ci


def _data(n_nodes: int, n_targets: int):
    rng = np.random.default_rng(7)
    s = np.sort(rng.uniform(-1.0, 1.0, n_nodes))
    WG = rng.normal(size=(n_nodes, 2))
    w = rng.uniform(-2.0, 2.0, n_targets) + 1j * rng.uniform(0.01, 1.0, n_targets)
    return s, WG, w


def test_far_sums_are_the_plain_sums():
    s, WG, w = _data(37, 101)
    F, dF = ci._far(s, WG, w)
    k = 1.0 / (s[None, :, None] - w[:, None, None])
    np.testing.assert_allclose(F, np.sum(k * WG[None], axis=1), rtol=1e-12, atol=0)
    np.testing.assert_allclose(dF, np.sum(k * k * WG[None], axis=1), rtol=1e-12, atol=0)


# rows 2, 3, 5, 110: 1001 targets leave a single row (joined to the block before) for 2 and 5
@pytest.mark.parametrize("entries", [1, 3 * 37, 5 * 37 + 3, 2**12])
def test_far_sums_do_not_depend_on_the_row_block(monkeypatch, entries):
    s, WG, w = _data(37, 1001)
    monkeypatch.setattr(ci, "CHUNK_ENTRIES", 2**30)
    F, dF = ci._far(s, WG, w)  # one block
    monkeypatch.setattr(ci, "CHUNK_ENTRIES", entries)
    Fb, dFb = ci._far(s, WG, w)
    assert Fb.tobytes() == F.tobytes() and dFb.tobytes() == dF.tobytes()


@pytest.mark.parametrize(("n", "rows", "ends"), [
    (0, 4, [0]), (1, 4, [0, 1]), (4, 4, [0, 4]), (5, 4, [0, 5]), (6, 4, [0, 4, 6]),
    (9, 4, [0, 4, 9]), (10, 4, [0, 4, 8, 10]), (3, 2, [0, 3])])
def test_row_blocks_never_leave_a_single_row(n, rows, ends):
    assert ci._row_blocks(n, rows).tolist() == ends


def test_stresses_do_not_depend_on_the_blocks_of_far_and_refined_sums(monkeypatch):
    """analytic.stress below and at the surface (near pairs on graded sub-panels of many
    levels) of a Cattaneo state: the same bits with one pair / two rows per block."""
    import analytic
    from analytic import profiles

    A, P, mu = 4 * (1 - 0.3**2) / 2.0, 1.0, 0.4
    st = analytic.solve_stick(analytic.solve_normal(profiles.cylinder(10.0), P, A), mu,
                              0.5 * mu * P)
    (a, b), = st.normal.zones
    rng = np.random.default_rng(3)
    x = rng.uniform(1.5 * a, 1.5 * b, 600)
    y = -(b - a) * np.concatenate([rng.uniform(0, 1, 300), 10.0 ** rng.uniform(-12, -3, 300)])
    xs = np.linspace(1.2 * a, 1.2 * b, 301)

    def run():
        f = analytic.stress(st, x, y, nu=0.3)
        return np.stack([f.sxx, f.syy, f.sxy]).tobytes(), analytic.surface_stress(st, xs).tobytes()

    ref = run()
    monkeypatch.setattr(ci, "REFINED_NODES", 1)
    monkeypatch.setattr(ci, "CHUNK_ENTRIES", 1)
    assert run() == ref


#: A pair block's sums against its two panels' for targets outside the pair's disc, relative
#: to the panels' sum of |wt G k| (both far rules err by ~RHO_NEAR^-32 and the pair's moments
#: agree to COARSE_TOL = 1e-12; observed 2.2e-14 on these states, 1.1e-6 on a pair refused
#: at the wedge's kink).
PAIR_AGREE = 1e-12


@pytest.fixture(scope="module")
def states():
    import analytic
    from analytic import profiles

    A, P, mu = 4 * (1 - 0.3**2) / 2.0, 1.0, 0.4
    normal = analytic.solve_normal(profiles.cylinder(10.0), P, A)
    wedge = analytic.solve_normal(profiles.wedge(0.1, 0.2), P, A)  # a kink: pairs refused there
    return [normal, analytic.solve_stick(normal, mu, 0.5 * mu * P),
            analytic.solve_stick(normal, mu, -0.2 * mu * P, 0.5 * mu * P), wedge]


def pair_errors(sol, m: int) -> tuple[np.ndarray, int]:
    """Largest |pair sum - panels' sum| / (panels' sum of |wt G k|) of pair block m (F and
    F', per density) over random targets outside its disc, and how many there were."""
    from analytic._traction_panels import quadrature

    quad = quadrature(sol)
    pan, pairs = quad.panels, quad.pairs
    lo, hi = np.min(pan.lo), np.max(pan.hi)
    rng = np.random.default_rng(1)
    w = (rng.uniform(2 * lo - hi, 2 * hi - lo, 4000)
         + 1j * (hi - lo) * 10.0 ** rng.uniform(-3, 0.5, 4000))
    c, r = ci._near_discs(pairs)
    far = w[np.abs(w - c[m]) >= r[m]]
    mine = pairs.nodes(np.array([m])).ravel()
    idx = pan.nodes(np.flatnonzero(quad.pair_of == m)).ravel()
    sums = [ci._far(rule.s[i], rule.wt[i, None] * rule.G[i], far)
            for rule, i in ((pairs, mine), (pan, idx))]
    k = 1.0 / np.abs(pan.s[idx][None, :] - far[:, None])
    wg = np.abs(pan.wt[idx, None] * pan.G[idx])
    err = [np.abs(a - b) / np.maximum(size, 1e-300)
           for a, b, size in zip(*sums, (k @ wg, (k * k) @ wg), strict=True)]
    return np.max(err), far.size


def test_pair_blocks_sum_as_their_panels_for_targets_outside_their_disc(states):
    from analytic._traction_panels import quadrature

    for sol in states:
        for m in np.flatnonzero(quadrature(sol).paired):
            err, n = pair_errors(sol, m)
            assert n > 100 and err <= PAIR_AGREE


def test_pairs_refused_at_a_kink(states):
    """The pair blocks on panels graded towards a kink (density ~ t log t) fail the moment
    check, and rightly: their sums are off; those panels are summed one by one."""
    from analytic._traction_panels import quadrature

    quad = quadrature(states[-1])
    refused = np.flatnonzero(~quad.paired)
    assert refused.size and quad.paired.any()
    assert max(pair_errors(states[-1], m)[0] for m in refused) > 1e3 * PAIR_AGREE


@pytest.mark.parametrize("cols", [0, 1, 5, 62, 63, 70])
def test_patterns_are_the_distinct_rows(cols):
    rng = np.random.default_rng(cols)
    mask = rng.random((300, cols)) < 0.5
    mask[100:200] = mask[0]  # repeated rows
    keys, group = ci._patterns(mask)
    assert np.array_equal(keys[group], mask)
    assert len({k.tobytes() for k in keys}) == len(keys)
