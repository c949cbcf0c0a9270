"""analytic._roots.brentq: Brent's method against known roots and scipy.optimize.brentq."""

import math
import subprocess
import sys

import numpy as np
import pytest

from analytic._roots import MAXITER, brentq

# (f, a, b, root): smooth, nearly flat, steep, one-sided kink, stepped, tiny values
CASES = [
    (lambda x: x * x - 2.0, 0.0, 2.0, math.sqrt(2.0)),
    (lambda x: math.cos(x) - x, 0.0, 1.0, 0.7390851332151607),
    (lambda x: (x - 1.0) ** 3 + 1e-3 * (x - 1.0), -3.0, 2.5, 1.0),
    (lambda x: math.exp(40.0 * x) - 2.0, -1.0, 1.0, math.log(2.0) / 40.0),
    (lambda x: x - 0.3 if x < 0.3 else 1e3 * (x - 0.3), 0.0, 1.0, 0.3),
    (lambda x: -1.0 if x < 1e-3 else 1.0, -1.0, 5.0, 1e-3),
    (lambda x: 1e-300 * (x - 0.25), 0.0, 1.0, 0.25),
]


@pytest.mark.parametrize(("f", "a", "b", "root"), CASES)
@pytest.mark.parametrize("xtol", [2e-12, 1e-15])
def test_root_within_tolerance_either_bracket_order(f, a, b, root, xtol):
    for lo, hi in ((a, b), (b, a)):
        x = brentq(f, lo, hi, xtol=xtol)
        assert abs(x - root) <= 2 * (xtol + 4 * np.finfo(float).eps * abs(root)) + 1e-16


@pytest.mark.parametrize(("f", "a", "b", "root"), CASES)
def test_as_good_as_scipy(f, a, b, root):
    """The same contract as scipy.optimize.brentq and no more evaluations than bisection."""
    scipy_optimize = pytest.importorskip("scipy.optimize")
    calls = []

    def counted(x):
        calls.append(x)
        return f(x)

    x = brentq(counted, a, b, xtol=1e-14)
    ref = scipy_optimize.brentq(f, a, b, xtol=1e-14)
    assert abs(x - ref) <= 4e-14 + 8 * np.finfo(float).eps * abs(ref)
    assert len(calls) <= 2 + math.ceil(math.log2(abs(b - a) / 1e-14)) + 5


def test_root_at_an_end_is_returned_without_iterating():
    assert brentq(lambda x: x - 1.0, 1.0, 3.0) == 1.0
    assert brentq(lambda x: x - 3.0, 1.0, 3.0) == 3.0


def test_same_signs_name_both_values():
    with pytest.raises(ValueError, match=r"different signs: f\(1.0\) = 1.0, f\(2.0\) = 4.0"):
        brentq(lambda x: x * x, 1.0, 2.0)


def test_nan_is_refused_with_its_point():
    with pytest.raises(ValueError, match="NaN"):
        brentq(lambda x: math.nan if x > 0.5 else x - 0.7, 0.0, 1.0)


@pytest.mark.parametrize(("kw", "what"), [({"xtol": 0.0}, "xtol=0.0"),
                                          ({"rtol": 1e-17}, "rtol=1e-17")])
def test_bad_tolerances_are_refused(kw, what):
    with pytest.raises(ValueError, match=what):
        brentq(lambda x: x, -1.0, 1.0, **kw)


def test_no_convergence_raises():
    with pytest.raises(RuntimeError, match="no convergence in 2 iterations"):
        brentq(lambda x: math.cos(x) - x, 0.0, 1.0, xtol=1e-15, maxiter=2)
    assert MAXITER == 100


def test_solving_a_case_does_not_load_scipy_optimize():
    """The reason for this module (issue 28: 13.6 MB of resident memory): importing the three
    packages and solving a library case leave scipy.optimize unloaded."""
    code = ("import sys, compare, compare.run\n"
            "from compare.analytic_side import solve_case\n"
            "from compare.cases import load_case\n"
            "solve_case(load_case('cattaneo'))\n"
            "print(sorted(m for m in ('scipy.optimize', 'scipy.interpolate') "
            "if m in sys.modules))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"
