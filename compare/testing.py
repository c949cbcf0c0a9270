"""Tolerance helpers for users' own tests.

>>> from compare import run_case
>>> from compare.testing import assert_agrees
>>> assert_agrees(run_case("cattaneo"), edge_rtol=0.02)          # doctest: +SKIP

``assert_agrees`` checks the metrics of a :class:`compare.run.CaseResult` against tolerances
(the case's named tolerances unless overridden) and fails with a table listing every metric,
its value, its tolerance and pass/FAIL.
"""

from __future__ import annotations

import math
from numbers import Real

from compare.run import EXACT_CHECKS, CaseResult, Check
from compare.tolerances import METRIC_OF

#: keyword of assert_agrees -> name of the tolerance it overrides
KEYWORDS = {"edge_rtol": "edge", "stick_rtol": "stick", "pressure_rtol": "pressure",
            "shear_rtol": "shear", "load_share_atol": "load_share", "moment_atol": "moment",
            "rotation_rtol": "rotation", "uncoupling_rtol": "uncoupling",
            "jc_rtol": "jaeger_ciavarella", "stress_rtol": "stress",
            "surface_peak_rtol": "surface_peak",
            "surface_peak_location_rtol": "surface_peak_location"}


class DisagreementError(AssertionError):
    """The FE result is farther from the analytic one than the tolerances allow."""


def format_checks(checks, title: str = "") -> str:
    """Aligned table: name, metric, value, tolerance, status (columns as wide as their
    longest entry)."""
    head = ("check", "metric", "value", "tolerance", "status")
    rows = [(c.name, c.metric, "n/a" if math.isnan(c.value) else f"{c.value:.4g}",
             f"{c.tolerance:.4g}", c.status) for c in checks]
    w = [max(len(r[k]) for r in [head, *rows]) for k in range(4)]
    lines = [title] if title else []
    lines += [f"  {r[0]:<{w[0]}}  {r[1]:<{w[1]}}  {r[2]:>{w[2]}}  {r[3]:>{w[3]}}  {r[4]}"
              for r in [head, *rows]]
    return "\n".join(lines)


def _tolerance(key: str, value) -> float:
    """A tolerance keyword's value as a float; ValueError naming it unless a real number >= 0
    (inf: no bound; not a bool, not a string holding a number)."""
    tol = float(value) if isinstance(value, Real) else math.nan
    if isinstance(value, bool) or not tol >= 0:
        raise ValueError(f"assert_agrees: {key}={value!r} is not allowed: need a number >= 0 "
                         "(inf: no bound)")
    return tol


def assert_agrees(result: CaseResult, **tolerances: float) -> None:
    """Assert that FE and analytic solutions agree within the tolerances.

    Keywords (all optional, override the case's named tolerances): ``edge_rtol``,
    ``stick_rtol``, ``pressure_rtol``, ``shear_rtol``, ``load_share_atol``, ``moment_atol``,
    ``rotation_rtol``, ``uncoupling_rtol``, ``jc_rtol``, ``stress_rtol``, ``surface_peak_rtol``,
    ``surface_peak_location_rtol``.  The zone-count and full-slip counts must
    be zero.  NaN metrics (not applicable) pass, except a metric the caller gave a tolerance
    for that the result cannot give (``result.unavailable``, external results): that fails.
    Raises :class:`DisagreementError`.
    """
    bad = sorted(set(tolerances) - set(KEYWORDS))
    if bad:
        raise TypeError(f"assert_agrees: unknown keyword(s) {bad}; allowed {sorted(KEYWORDS)}")
    tol = dict(result.case.tolerances)
    tol.update({KEYWORDS[k]: _tolerance(k, v) for k, v in tolerances.items()})
    checks = [Check(n, METRIC_OF[n], float(result.metrics.get(METRIC_OF[n], math.nan)), t)
              for n, t in tol.items()]
    checks += [Check(n, k, float(result.metrics.get(k, math.nan)), 0.0)
               for n, k in EXACT_CHECKS.items()]
    asked = [METRIC_OF[KEYWORDS[k]] for k in tolerances]
    na = getattr(result, "unavailable", {})  # duck-typed results may lack it
    missing = [f"{m}: {na[m]}" for m in asked if m in na]
    if missing:
        raise DisagreementError(f"case '{result.case.name}': not available from the result: "
                                + "; ".join(missing))
    failed = [c for c in checks if not c.passed]
    if failed:
        names = ", ".join(f"{c.name} ({c.metric}={c.value:.4g} > {c.tolerance:.4g})"
                          for c in failed)
        raise DisagreementError(format_checks(
            checks, f"case '{result.case.name}': FE and analytic solutions disagree: {names}"))
