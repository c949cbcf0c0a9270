"""Randomised audit of the analytic solver (issue 13): random cases, independent referees.

Each seed is one case of ``compare.audit.cases`` (profile, load, mode). Its solution is checked
by quadratures of the returned pressure (loads, rigid approach, p >= 0, gap >= 0 and equal to the
returned gap; for stick states int q = Q and |q| <= mu p) and against the discretised solver
``compare.bem`` at two resolutions (zone count, edges, zone loads, theta), see
``compare.audit.checks``. A solver error on a case the BEM solves is a disagreement as well.

- The fast sample (seeds 0 .. FAST_SAMPLE - 1) runs in the default suite.
- ``slow``: every seed that ever disagreed (``audit_regressions.json``) and the >= 500-case run
  (also ``python benchmarks/audit.py --n 500``).
A seed that fails because of a known, not yet fixed solver bug is listed as ``open`` in
``audit_regressions.json`` with its reason and is ``xfail(strict=True)``: once fixed it passes,
the strict xfail fails, and the entry is closed (the seed stays as a regression case).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from compare.audit import run
from compare.audit.cases import AuditCase

FAST_SAMPLE = 30
"""Seeds 0..29 run in the default suite (~20 s)."""
SLOW_SAMPLE = 500
"""Seeds 0..499 in the slow run."""
_LIST = json.loads(Path(__file__).with_name("audit_regressions.json").read_text())
REGRESSIONS = {int(r["seed"]): r for r in _LIST["seeds"]}
CASES = [AuditCase(-100 - i, c["family"], tuple(c["spec"]), c["P"], c["A"], c["M"], c["mode"],
                   c["mu"], c["Q"], c["Q0"], tuple(c["core"]))
         for i, c in enumerate(_LIST["cases"])]
"""The explicit cases of ``audit_regressions.json`` (issue 29: a wedge beside a cylinder at six
loads and in stage 2, a sharp punch beside a cylinder and a wedge pair in moment mode, a
301-sample spline of two cylinders vertically and in moment mode, audit seed 103644's profile
vertically; ``open`` as for seeds)."""


def _seed_params(seeds) -> list:
    out = []
    for seed in seeds:
        entry = REGRESSIONS.get(seed)
        marks = ([pytest.mark.xfail(strict=True, reason=f"{entry['reason']} ({entry['ref']})")]
                 if entry and entry["open"] else [])
        out.append(pytest.param(seed, marks=marks, id=f"seed{seed}"))
    return out


def _assert_agrees(result: run.CaseResult) -> None:
    assert not result.disagrees, "\n".join([result.case, *result.findings])


@pytest.mark.parametrize("seed", _seed_params(range(FAST_SAMPLE)))
def test_audit_fast_sample(seed: int) -> None:
    _assert_agrees(run.audit_seed(seed))


FAST_REGRESSIONS = (102518,)
"""Closed regression seeds cheap enough for the default suite (~0.7 s each with the checks)."""


@pytest.mark.parametrize("seed", _seed_params(FAST_REGRESSIONS))
def test_audit_fast_regression_seeds(seed: int) -> None:
    _assert_agrees(run.audit_seed(seed))


B0, RHO = 0.44558171357291565, 0.12406813981921715
ISSUE_CASES = [
    AuditCase(-1, "punch", ("flat_punch", {"left": -0.2013895002861746,
                                           "right": 0.2013895002861746,
                                           "corner_radius": 0.10164068346043335,
                                           "corner_shape": "parabolic"}),
              1e-3, 1.0, None, "vertical", None, None, None, (-0.2, 0.2)),
    AuditCase(-2, "punch", ("union", {"members": [
        ("flat_punch", {"left": -1.0, "right": 1.0}),
        ("cylinder", {"R": 1.0, "center": 4.0, "lift": 0.5})]}),
        1.0, 1.0, 0.45, "moment", None, None, None, (-1.0, 1.0)),
    AuditCase(-3, "punch", ("union", {"members": [
        ("flat_punch", {"left": -B0, "right": B0, "corner_radius": RHO}),
        ("cylinder", {"R": 0.497751415090719, "center": 1.3112607075014848,
                      "lift": 2.8910158260701618e-05}),
        ("cylinder", {"R": 2.09162665941828, "center": 2.9514705388119507})]}),
        2.538619387584285e-4, 1.0, None, "vertical", None, None, None, (-B0, B0)),
]
"""Issue 13's three wrong answers as audit cases: the audit flagged each on the solver of
0616e17 (load_quadrature; rigid_approach and gap_consistency; every quadrature check and
bem_loads); fixed, they pass."""


@pytest.mark.parametrize("case", [pytest.param(c, id=f"wrong_answer_{-c.seed}")
                                  for c in ISSUE_CASES])
def test_audit_passes_the_issue_wrong_answers(case: AuditCase) -> None:
    _assert_agrees(run.audit_case(case))


def _case_marks(entry: dict) -> list:
    """slow, and ``xfail(strict=True)`` for a case listed ``open`` (a known solver bug)."""
    marks = [pytest.mark.slow] if entry["slow"] else []
    if entry.get("open"):
        marks.append(pytest.mark.xfail(strict=True, reason=f"{entry['reason']} ({entry['ref']})"))
    return marks


@pytest.mark.parametrize("case", [pytest.param(c, id=e["name"], marks=_case_marks(e))
                                  for c, e in zip(CASES, _LIST["cases"], strict=True)])
def test_audit_passes_the_listed_cases(case: AuditCase) -> None:
    _assert_agrees(run.audit_case(case))


@pytest.mark.slow
@pytest.mark.parametrize("seed", _seed_params(sorted(REGRESSIONS)))
def test_audit_regression_seeds(seed: int) -> None:
    _assert_agrees(run.audit_seed(seed))


@pytest.mark.slow
def test_audit_500_cases(tmp_path: Path) -> None:
    """Every disagreeing seed of the slow run is a known open regression (listed with its
    reason); the table is written as by benchmarks/audit.py."""
    results = run.run_audit(list(range(SLOW_SAMPLE)), jobs=1)
    head = run.write_table(results, tmp_path)
    assert (tmp_path / "audit.md").exists() and head["cases"] == SLOW_SAMPLE
    open_seeds = {s for s, r in REGRESSIONS.items() if r["open"]}
    unknown = [r for r in results if r.disagrees and r.seed not in open_seeds]
    assert not unknown, "\n".join(line for r in unknown for line in (r.case, *r.findings))


def test_audit_workers_own_their_memory_limit() -> None:
    """A worker's address-space limit (run.WORKER_MEMORY) is its own, whatever the caller holds:
    with forked workers, a caller already past the limit (a test session after FE studies) left
    the 500-case run's workers short of memory."""
    import numpy as np

    reserved = np.empty(run.WORKER_MEMORY + 2**29, dtype=np.uint8)  # address space, never touched
    try:
        (result,) = run.run_audit([0], jobs=1)
    finally:
        del reserved
    _assert_agrees(result)
