"""Inputs at the analytic solver's limits get one clear error, quickly (probe findings):
tabulated profiles whose contact would leave the table, A P outside its representable range,
and the argument checks of :func:`analytic.stress` and :func:`analytic.ruiz`."""

from __future__ import annotations

import re
import time
from pathlib import Path

import numpy as np
import pytest

import analytic
from analytic import InputError, profiles
from analytic.errors import TableEndError

X = np.linspace(-1.0, 1.0, 21)


# ---------------------------------------------------------------------------------------------
# tabulated profiles: contact must stay inside the table
# ---------------------------------------------------------------------------------------------
def test_level_table_is_refused_at_once() -> None:
    """A level table touches everywhere up to its ends: it grew 399 first-touch zones and
    0.7 GB before; now one InputError naming the table's ends."""
    start = time.perf_counter()
    with pytest.raises(InputError, match=r"lowest set .* reaches the end of its table at "
                       r"x=-1\.0, x=1\.0.*extend"):
        analytic.solve_normal(profiles.tabulated(X, 0 * X), 0.1, 1.0)
    assert time.perf_counter() - start < 5.0


@pytest.mark.parametrize(("h", "end"), [(X + 1.0, "-1.0"), (1.0 - X, "1.0")])
def test_minimum_at_the_table_end_is_named(h: np.ndarray, end: str) -> None:
    """It touches at the end of the table (it was "never touches: no minimum")."""
    with pytest.raises(TableEndError, match=rf"minimum of h0\(x\) - theta x is at the end of "
                       rf"its table at x={end}"):
        analytic.solve_normal(profiles.tabulated(X, h), 0.1, 1.0)


def test_level_interior_run_starts_one_zone() -> None:
    """An exactly level spline piece between kinks lists every sample as a minimum; the first
    touch takes them as one face (400 zones hung at P = 1e-3 before) and P = 0.1 is unchanged."""
    h = np.where(np.abs(X) < 0.5, 0.0, (np.abs(X) - 0.5) ** 2)
    prof = profiles.tabulated(X, h, kinks=[-0.5, 0.5])
    small = analytic.solve_normal(prof, 1e-3, 1.0)
    assert small.n_zones == 1 and small.zones[0][0] < -0.5 < 0.5 < small.zones[0][1]
    assert analytic.solve_normal(prof, 0.1, 1.0).zones[0][1] == pytest.approx(0.6107649471, 1e-9)


@pytest.mark.parametrize(("h", "P", "where", "near"), [
    (X**2 / 2, 10.0, "x=-1.0, x=1.0", "1.563"),
    ((X - 0.5) ** 2 / 2, 1.0, "x=1.0", "0.387"),
])
def test_contact_running_off_the_table_is_named(h, P, where, near) -> None:
    """The Hertz zone (+-2.5 at P = 10) outgrows the table (+-1): it stalled "against the
    feasible set"; now the table's end and the load where the contact reaches it."""
    with pytest.raises(TableEndError, match=rf"P={P!r} is not allowed.*reaches the end of its "
                       rf"table at {where} near P={near}.*longer table"):
        analytic.solve_normal(profiles.tabulated(X, h), P, 1.0)


def test_moment_mode_names_the_table_end() -> None:
    """In moment mode a trial rotation that runs the contact off the table is a failed solve of
    the search; at the initial rotation the table end is the answer.  Valid loads still solve."""
    prof = profiles.tabulated(X, X**2 / 2)
    assert analytic.solve_normal(prof, 1.0, 1.0, M=0.1).theta == pytest.approx(0.1, abs=1e-3)
    with pytest.raises(TableEndError, match=r"reaches the end of its table at x=1\.0 near "
                       r"P=1\.265.* and theta=0\.1"):
        analytic.solve_normal(prof, 3.0, 1.0, M=0.3)


def test_open_ends_are_the_table_ends_only() -> None:
    assert profiles.tabulated(X, X**2).open_ends == (-1.0, 1.0)
    for prof in (profiles.cylinder(1.0), profiles.flat_punch(-1.0, 1.0),
                 profiles.flat_punch(-1.0, 1.0, 0.5), profiles.wedge(0.1, 0.2),
                 profiles.union(profiles.flat_punch(-2, -1), profiles.cylinder(1.0, 2.0))):
        assert prof.open_ends == ()


# ---------------------------------------------------------------------------------------------
# A P
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("P", "A"), [(1e-300, 1e-300), (1e200, 1e200), (1e-160, 1.0)])
def test_load_scale_outside_its_range_is_refused(P: float, A: float) -> None:
    """A P = 1e-300 * 1e-300 underflowed to 0: a raw ZeroDivisionError in Newton."""
    for call in (lambda: analytic.solve_normal(profiles.cylinder(1.0), P, A),
                 lambda: analytic.load_curve(profiles.cylinder(1.0), [1.0, P], A),
                 lambda: analytic.overlapped(profiles.cylinder(1.0), P, A)):
        with pytest.raises(InputError, match=r"A\*P=.* is not allowed: need 1e-150 <= A\*P "
                           r"<= 1e\+150"):
            call()


def test_load_scale_at_its_range_ends_solves() -> None:
    punch = profiles.flat_punch(-1.0, 1.0)
    assert analytic.solve_normal(punch, 1e-150, 1.0).zones == [(-1.0, 1.0)]
    assert analytic.solve_normal(punch, 1.0, 1e150).zones == [(-1.0, 1.0)]


# ---------------------------------------------------------------------------------------------
# stress and ruiz arguments
# ---------------------------------------------------------------------------------------------
_STATES: dict = {}


def _hertz() -> analytic.NormalSolution:
    if "normal" not in _STATES:
        _STATES["normal"] = analytic.solve_normal(profiles.cylinder(1.0), 1.0, 1.0)
    return _STATES["normal"]


def _stage3() -> analytic.StickSolution:
    if "stage3" not in _STATES:
        _STATES["stage3"] = analytic.solve_stick(_hertz(), 0.5, -0.2, 0.2)
    return _STATES["stage3"]


@pytest.mark.parametrize("nu", ["a", None, [0.3, 0.2], float("nan"), 0.6, -1.0, True])
def test_stress_nu_is_checked(nu) -> None:
    with pytest.raises(InputError, match=r"nu=.* is not allowed: need Poisson's ratio"):
        analytic.stress(_hertz(), 0.0, -0.5, nu=nu)


@pytest.mark.parametrize(("x", "y", "name"), [
    ("a", -0.5, "x"), (0.0, "a", "y"), (None, -0.5, "x"), ([0.0, float("inf")], -0.5, "x"),
    (0.0, [1j], "y"), ([0, 1, 2], [-0.5, -1], "y"),
])
def test_stress_points_are_checked(x, y, name: str) -> None:
    with pytest.raises(InputError, match=rf"^{name}=.* is not allowed: need "):
        analytic.stress(_hertz(), x, y, nu=0.3)


def test_surface_stress_x_is_checked() -> None:
    with pytest.raises(InputError, match=r"^x='a' is not allowed"):
        analytic.surface_stress(_hertz(), "a")


def test_stress_accepts_a_one_element_nu_and_int_points() -> None:
    a = analytic.stress(_hertz(), [0, 1], -1, nu=np.array([0.3]))
    b = analytic.stress(_hertz(), [0.0, 1.0], -1.0, nu=0.3)
    assert np.array_equal(a.sxx, b.sxx) and a.nu == 0.3


@pytest.mark.parametrize("n", [0, -5, 1, 2.5, "a", None, float("nan")])
def test_ruiz_n_is_checked(n) -> None:
    with pytest.raises(InputError, match=r"^n=.* is not allowed: need an integer >= 2"):
        analytic.ruiz(_stage3(), n=n)


@pytest.mark.parametrize("x", [[], "a", [[0.0, 0.1]], [0.0, float("nan")]])
def test_ruiz_x_is_checked(x) -> None:
    with pytest.raises(InputError, match=r"^x=.* is not allowed"):
        analytic.ruiz(_stage3(), x)


def test_ruiz_with_two_points_and_given_x() -> None:
    r = analytic.ruiz(_stage3(), n=2)
    assert r.x.size == 2
    assert analytic.ruiz(_stage3(), [0.0, 0.5]).x.tolist() == [0.0, 0.5]


# ---------------------------------------------------------------------------------------------
# docs/analytic.md
# ---------------------------------------------------------------------------------------------
def test_documented_small_load_limit_of_fig5() -> None:
    """docs/analytic.md gives Pe(kappa -> 0) for (0.11, 0.07) rounded to 0.01 % (it said 3.65 %
    for 3.658 %); the closed form and the solver at P = 1e-6 agree."""
    text = (Path(__file__).parents[2] / "docs" / "analytic.md").read_text(encoding="utf-8")
    stated = float(re.search(r"which is ([0-9.]+) % for \(0\.11, 0\.07\)", text).group(1))
    t1, t2 = np.tan(0.11), np.tan(0.07)
    r = (t2 - t1) / (t1 + t2)
    limit = 100.0 * (1.0 - np.cos(0.5 * np.pi * r) / np.cos(np.arcsin(r)))
    assert stated == round(limit, 2) == 3.66
    assert analytic.fig5_data(0.11, 0.07, loads=[1e-6]).Pe[0] == pytest.approx(limit, abs=1e-3)


def test_level_run_is_one_minimum_for_every_caller():
    """The level run is merged where the minima are found (Profile.local_minima, memoised), so
    the guess, admissibility and overlap see one interval too, not one point per sample."""
    import numpy as np

    from analytic import profiles as pr

    x = np.linspace(-1.0, 1.0, 41)
    h = np.where(np.abs(x) <= 0.5, 0.0, np.abs(x) - 0.5)  # linear sides: no spline undershoot
    level = pr.tabulated(x, h, kinks=[-0.5, 0.5])
    assert level.local_minima() == [(-0.5, 0.5, 0.0)]  # was 400 point minima
    twins = pr.union(pr.cylinder(R=1.0, center=-1.0), pr.cylinder(R=1.0, center=1.0))
    assert len(twins.local_minima()) == 2  # two minima of one height, a ridge between: two
