"""Bad inputs to the analytic normal solver: one clear ``InputError`` naming the bad value.

Standards: "Bad input -> ONE clear error naming the bad value and what is allowed". Each case
checks the exception type (``analytic.InputError``, a ``ValueError``) and that the message
contains ``name=value``.
"""

from __future__ import annotations

import numpy as np
import pytest

import analytic
from analytic import InputError, profiles

A, P = 1.0, 0.5


@pytest.mark.parametrize(("call", "named"), [
    (lambda: profiles.cylinder(-1.0), "R=-1.0"),
    (lambda: analytic.solve_normal(profiles.cylinder(1.0), P, -2.0), "A=-2.0"),
    (lambda: analytic.solve_normal(profiles.cylinder(1.0), P, 0.0), "A=0.0"),
    (lambda: analytic.solve_normal(profiles.cylinder(1.0), P, float("nan")), "A=nan"),
    (lambda: analytic.solve_normal(profiles.cylinder(1.0), 0.0, A), "P=0.0"),
    (lambda: analytic.solve_normal(profiles.cylinder(1.0), -0.3, A), "P=-0.3"),
    (lambda: analytic.solve_normal(profiles.cylinder(1.0), float("inf"), A), "P=inf"),
    (lambda: analytic.load_curve(profiles.cylinder(1.0), [0.1, -0.2], A),
     r"loads=\[0.1, -0.2\]"),
    (lambda: profiles.wedge(-0.1, 0.2), "angle_left=-0.1"),
    (lambda: profiles.wedge(0.1, 0.0), "angle_right=0.0"),
], ids=["R<0", "A<0", "A=0", "A=nan", "P=0", "P<0", "P=inf", "curve P<0", "wedge<0",
        "wedge=0"])
def test_bad_value_raises_one_input_error_naming_it(call, named: str) -> None:
    with pytest.raises(InputError, match=named) as info:
        call()
    assert isinstance(info.value, ValueError)
    assert "allowed" in str(info.value) or "need" in str(info.value)


def test_profile_that_touches_at_the_table_end() -> None:
    """A tabulated profile falling monotonically to the table end touches there first, where
    h0 ends: the error names that end (it said "never touches")."""
    x = np.linspace(0.0, 1.0, 11)
    prof = profiles.tabulated(x, 1.0 - x + 0.1)
    with pytest.raises(InputError, match=r"minimum of h0\(x\) - theta x is at the end of its "
                       r"table at x=1\.0.*longer table"):
        analytic.solve_normal(prof, P, A)


def test_moment_that_tips_a_punch_off() -> None:
    """The load centre M/P = 0.8 lies beyond the punch face [-0.5, 0.5]."""
    with pytest.raises(InputError, match=r"M=0\.4") as info:
        analytic.solve_normal(profiles.flat_punch(-0.5, 0.5), P, A, M=0.4)
    assert "tips" in str(info.value)


def test_moment_that_tips_a_union_off() -> None:
    prof = profiles.union(profiles.flat_punch(-1.0, -0.4),
                          profiles.flat_punch(0.4, 1.0))
    with pytest.raises(InputError, match=r"M=-0\.6"):
        analytic.solve_normal(prof, P, A, M=-0.6)


def test_not_a_profile() -> None:
    with pytest.raises(InputError, match="Profile"):
        analytic.solve_normal(lambda x: x**2, P, A)


def test_load_curve_rejects_both_M_and_theta() -> None:
    with pytest.raises(InputError, match="not both"):
        analytic.load_curve(profiles.cylinder(1.0), [0.1], A, M=0.0, theta=0.0)
