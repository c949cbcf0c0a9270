"""Penalty vs augmented Lagrangian (Uzawa) normal contact on the Hertz case."""

import numpy as np

import fem

E, NU, R, P, MU = 1.0, 0.3, 100.0, 0.01, 0.5
A_HERTZ = np.sqrt(2 * 4 * (1 - NU**2) / E * P * R / np.pi)


def solve(penalty_factor, augmented, pen_tol=None):
    contact = fem.ContactSettings(
        penalty_factor=penalty_factor, augmented=augmented, pen_tol=pen_tol
    )
    return fem.solve_history(
        lambda x: x**2 / (2 * R),
        P,
        0.0,
        MU,
        E,
        NU,
        window=(-1.3 * A_HERTZ, 1.3 * A_HERTZ),
        mesh=fem.MeshSpec(level=0),
        contact=contact,
        increments=fem.LoadPath(n_normal=3),
    )


def test_augmented_penetration_below_tolerance_and_edges_fixed():
    tol = 1e-7 * A_HERTZ
    soft, stiff = solve(0.1, True, tol), solve(10.0, True, tol)
    for h in (soft, stiff):
        assert max(s.interface.penetration.max() for s in h.steps) <= tol
    al_shift = abs(soft.steps[-1].contact_zones[0][1] - stiff.steps[-1].contact_zones[0][1])
    pen_shift = abs(
        solve(0.1, False).steps[-1].contact_zones[0][1]
        - solve(10.0, False).steps[-1].contact_zones[0][1]
    )
    print(
        f"edge shift with k_n x100: penalty {pen_shift / A_HERTZ:.2e} a, "
        f"augmented {al_shift / A_HERTZ:.2e} a"
    )
    assert pen_shift > 10 * al_shift
    assert al_shift < 1e-4 * A_HERTZ


def test_increment_iterations_are_summed_over_the_uzawa_updates(monkeypatch):
    """FemStep.iterations counts every Newton system of the increment, those of all its Uzawa
    updates (fem.results), not only the last update's."""
    import fem.contact

    calls, inner = [], fem.contact.solve_increment

    def counted(*args, **kw):
        state = inner(*args, **kw)
        calls.append(state.iterations)
        return state

    monkeypatch.setattr(fem.contact, "solve_increment", counted)
    hist = solve(0.1, True, 1e-7 * A_HERTZ)
    assert len(calls) > len(hist.steps)  # some increment needed Uzawa updates
    assert sum(s.iterations for s in hist.steps) == sum(calls)
