"""Unit tests of the Newton solver's cheap failures and chord steps (``analytic._newton``) and of
the moment search's choice of warm starts (``analytic._applied_moment._Rotations``), issue 29:
Newton from a topology with no solution nearby crawled for 40 iterations, each with a fresh
Jacobian and a line search after a rejected chord step, and the moment search repeated warm
starts that had already failed from the same side."""

from __future__ import annotations

import numpy as np
import pytest

import analytic
from analytic import _applied_moment, _continuation, _newton, profiles
from analytic._sie import Layout
from compare.audit.cases import make_case

P_836, THETA_836 = 1.1537179482016971e-05, -1.052984e-03
"""Audit seed 100836 (five cylinders, moment mode): at this rotation only the leftmost cylinder
touches, so two zones on the outer cylinders have no solution."""


def _state(edges, P: float, theta: float) -> _newton.State:
    st = _newton.fresh_state(Layout(np.asarray(edges, float), np.zeros(len(edges), bool)),
                             theta, P)
    st.beta = _newton.beta_for(st, 1.0, P)
    return st


def test_newton_on_a_topology_without_a_solution_fails_as_stalled() -> None:
    """It crawled at a residual of 59.28 until NEWTON_MAXIT (0.34 s); now it stops once
    STALL_STEPS steps gained less than STALL_GAIN in all (iteration 18), or sooner once
    WALL_STEPS of them in a row were cut by the feasible set (iteration 14)."""
    st = _state([-3.20221, -3.02466, 2.78643, 2.79297], P_836, THETA_836)
    with pytest.raises(_newton.NewtonFailed, match="stalled|against the feasible set") as err:
        _newton.newton(st, _newton.Mode(P_836, None), make_case(100836).profile, 1.0)
    diag = err.value.diag
    assert diag["iteration"] < _newton.NEWTON_MAXIT
    assert diag["residual"] > (1 - _newton.STALL_GAIN) * diag["residual_steps_before"]


def test_a_converging_crawl_is_not_a_stall() -> None:
    """Every accepted step above the floor records its residual; a reduction by more than
    STALL_GAIN over STALL_STEPS steps passes, less fails, and a residual at the rounding floor
    restarts the count."""
    crawl: list[float] = []
    F = np.ones(1)
    for k in range(3 * _newton.STALL_STEPS):
        norm = 0.99**k
        _newton._check_stall(crawl, norm, 0.99 * norm, F, 1e-10, k)
    crawl.clear()
    with pytest.raises(_newton.NewtonFailed, match="stalled"):
        for k in range(_newton.STALL_STEPS):
            _newton._check_stall(crawl, 1.0 - 1e-3 * k, 1.0 - 1e-3 * (k + 1), F, 1e-10, k)
    crawl[:] = [1.0] * (_newton.STALL_STEPS - 1)
    _newton._check_stall(crawl, 1.0, 1.0, np.full(1, 1e-12), 1e-10, 0)
    assert crawl == []


def test_newton_pushing_an_edge_onto_a_ridge_fails_against_the_feasible_set() -> None:
    """Audit seed 103644 at theta = 0 (three zones where a fourth is due beyond the ridge
    2.0049): Newton drives the cylinder zone's left edge onto that ridge, every line search
    halving to stay feasible; it crawled there until "stalled" at iteration 18 (others of
    its kind until "no descent" at 22-35, 0.5-1.1 s each); now it stops after WALL_STEPS such
    steps in a row (iteration 14)."""
    prof, P = make_case(103644).profile, 0.412613
    st = _state([-0.9718218, 0.9590648, 2.0118573, 2.2303611, 2.2304811, 2.578672], P, 0.0)
    with pytest.raises(_newton.NewtonFailed, match="against the feasible set") as err:
        _newton.newton(st, _newton.Mode(P, None), prof, 1.0)
    diag = err.value.diag
    assert diag["iteration"] < 18
    assert diag["residual"] > (1 - _newton.STALL_GAIN) * diag["residual_steps_before"]


def test_only_steps_cut_by_the_feasible_set_count_towards_the_wall() -> None:
    """A step halved fewer than WALL_HALVINGS times for feasibility, or at the rounding floor,
    restarts the count; WALL_STEPS cut steps gaining less than STALL_GAIN fail, more pass."""
    wall: list[float] = []
    F, cut = np.ones(1), _newton.WALL_HALVINGS
    for k in range(3 * _newton.WALL_STEPS):  # 10 % per step: converging along a wall
        _newton._check_wall(wall, cut, 0.9**k, 0.9 ** (k + 1), F, 1e-10, k)
    wall[:] = [1.0] * (_newton.WALL_STEPS - 1)
    _newton._check_wall(wall, cut - 1, 1.0, 1.0, F, 1e-10, 0)
    assert wall == []
    wall[:] = [1.0] * (_newton.WALL_STEPS - 1)
    _newton._check_wall(wall, cut, 1.0, 1.0, np.full(1, 1e-12), 1e-10, 0)
    assert wall == []
    with pytest.raises(_newton.NewtonFailed, match="against the feasible set"):
        for k in range(_newton.WALL_STEPS):
            _newton._check_wall(wall, cut, 1.0 - 1e-3 * k, 1.0 - 1e-3 * (k + 1), F, 1e-10, k)


def test_chord_step_is_taken_only_when_it_gains_the_refresh_factor() -> None:
    prof, P = profiles.cylinder(1.0), 0.1
    (a, b), = analytic.solve_normal(prof, P, 1.0).zones
    st = _state([a * 1.001, b * 0.999], P, 0.0)  # near the solution: Newton gains ~1e3
    mode = _newton.Mode(P, None)
    z = _newton._pack(st, mode)
    F, _ = _newton.residual(st, mode, prof, 1.0)
    norm = float(np.max(np.abs(F)))
    J = _newton._jacobian(z, F, st, mode, prof, 1.0)
    step = _newton._chord_step(st, z, np.linalg.solve(J, -F), norm, mode, prof, 1.0)
    assert step is not None and step[3] <= _newton.REFRESH_RATIO * norm
    assert _newton._chord_step(st, z, np.zeros_like(z), norm, mode, prof, 1.0) is None
    crossing = np.array([0.5, -0.5])  # edges crossed: not feasible
    assert _newton._chord_step(st, z, crossing, norm, mode, prof, 1.0) is None


def test_warm_starts_skip_a_side_that_already_failed() -> None:
    """The nearest solved rotation on each side, nearest first; one that a warm start failed
    from towards a rotation is not offered again in that direction (only in the other)."""
    rot = _applied_moment._Rotations(profiles.cylinder(1.0), 1.0, 1.0)
    rot.solved = dict.fromkeys([-3.0, -1.0, 2.0, 5.0])
    assert rot._starts(0.0) == [-1.0, 2.0]
    assert rot._starts(1.8) == [2.0, -1.0]
    rot.failed.append((-1.0, 1.5))
    assert rot._starts(0.0) == [2.0]
    assert rot._starts(-2.5) == [-3.0, -1.0]
    assert rot._starts(6.0) == [5.0]


def test_a_rotation_between_two_topologies_straddles() -> None:
    """Between a rotation solved with one zone and one solved with another, the overlap guess
    is tried before the warm starts."""
    rot = _applied_moment._Rotations(profiles.cylinder(1.0), 1.0, 1.0)
    left, right, both = ([-0.3, -0.28], ), ([3.64, 3.66], ), ([-0.3, -0.28], [3.64, 3.66])
    rot.solved = {t: (_state(np.ravel(z), 1.0, t), None, 0.0)
                  for t, z in ((1.0, left), (2.0, right), (3.0, both), (4.0, both))}
    assert rot._straddles(1.5) and rot._straddles(2.5)
    assert not rot._straddles(3.5) and not rot._straddles(0.5) and not rot._straddles(5.0)


def test_moment_search_is_one_newton_where_the_topology_holds(monkeypatch) -> None:
    """Audit seed 101139 (four cylinders, moment mode): the joint Newton from the initial
    rotation's solution reaches the applied moment, so no bracket is searched (it took 14
    fixed-rotation solves, 0.6 s)."""
    case = make_case(101139)
    searched = []
    monkeypatch.setattr(_applied_moment, "_bracket", lambda *a: searched.append(a) or 1 / 0)
    sol = analytic.solve_normal(case.profile, case.P, case.A, case.M)
    assert not searched and sol.n_zones == 4
    assert abs(sol.M - case.M) <= 1e-10 * case.P * (sol.zones[-1][1] - sol.zones[0][0])


def test_no_newton_start_from_zones_recentred_across_each_other(monkeypatch) -> None:
    """Audit seed 101132 (bi-quadratic punch): its two overlap zones re-centred past each other
    (edges -0.433, 0.072, -0.072, 0.433) and Newton took 3.3 s from there to fail."""
    case = make_case(101132)
    starts = []
    converge = _continuation.converge

    def recording(st, *args):
        starts.append(st.layout.edges.copy())
        return converge(st, *args)

    monkeypatch.setattr(_continuation, "converge", recording)
    sol = analytic.solve_normal(case.profile, case.P, case.A)
    assert sol.n_zones == 2 and starts
    assert all(np.all(np.diff(e) > 0) for e in starts)


def test_moment_search_ends_at_the_first_state_with_both_zones(monkeypatch) -> None:
    """Audit seed 101125 (two small zones far apart, moment mode): M(theta) is a step, and the
    joint Newton from the first fixed-rotation state holding both zones ends the search (Brent
    resolved the step with ~16 fixed-rotation solves)."""
    case = make_case(101125)
    ends = []
    joint_at = _applied_moment._joint_at

    def recording(rot, theta, M):
        try:
            joint_at(rot, theta, M)
        except _applied_moment._Found:
            ends.append(rot.solved[theta][0].layout.n)
            raise

    monkeypatch.setattr(_applied_moment, "_joint_at", recording)
    sol = analytic.solve_normal(case.profile, case.P, case.A, case.M)
    assert ends == [2] and sol.n_zones == 2
    assert abs(sol.M - case.M) <= 1e-10 * case.P * (sol.zones[-1][1] - sol.zones[0][0])


def test_continuation_gives_up_on_a_target_it_cannot_reach(monkeypatch) -> None:
    """A target load whose every step fails (a phantom overlap there, issue 29 item 4: minutes
    of retries from ever closer loads) is a ConvergenceError after TARGET_RETRIES attempts."""
    prof, target = profiles.cylinder(1.0), 1e-3
    converge = _continuation.converge
    calls = []

    def failing_at_target(st, *args):
        calls.append(st.P)
        if st.P == target:
            raise _continuation.StepFailed("phantom overlap")
        return converge(st, *args)

    monkeypatch.setattr(_continuation, "converge", failing_at_target)
    monkeypatch.setattr(_continuation, "_try_merge", lambda *a: None)
    start = _continuation.solve_from_guess(prof, 1e-6, 1.0, 0.0)[0]
    with pytest.raises(analytic.ConvergenceError, match="cannot reach P=0.001") as err:
        _continuation.continue_to(start, target, prof, 1.0)
    assert calls.count(target) == _continuation.TARGET_RETRIES
    assert err.value.diagnostics["P_target"] == target
