"""A real external code: Kratos Multiphysics results verified against the analytic solution.

The stored result (tests/data/kratos_cattaneo: Cattaneo at our mesh level 0, written once by
``python -m compare.external.kratos cattaneo OUT --level 0``, Kratos 10.3) keeps the reader path
and the verdict on a foreign code tested without Kratos; the slow test runs the driver itself
where the ``[kratos]`` extra is installed.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from compare.cases import load_case
from compare.errors import CaseError
from compare.external import kratos
from compare.external.driver import LANDING_RTOL, DriverError
from compare.stress import STRESS_METRICS
from compare.testing import DisagreementError, assert_agrees
from compare.verify import verify

DATA = Path(__file__).resolve().parents[1] / "data" / "kratos_cattaneo"


def test_stored_kratos_result_verifies():
    res = verify("cattaneo", DATA / "steps.csv")
    assert "Kratos" in res.source and res.fem.n_dofs > 0
    assert len(res.fem.stage(1)) == 10 and res.fem.stage(3)
    # M from reactions, stage-1 steps at the reduced loads: only the body stresses are missing
    assert set(res.unavailable) == set(STRESS_METRICS)
    # element a/23 (linear mortar ALM): edges, pressure, loads and JC agree; the stick edge
    # (1.04 % of the width) misses the tolerance our FE meets at level 0 (issue 14: 1 %), and the
    # verdict says so.  The shear error, 2.44 % of mu ||p|| (our FE on the same mesh and steps:
    # 1.99 %),
    # is within the 3 % of issue 25 (it was 11.9 % of ||q||, dominated by the stage-3 reversal)
    assert {c.name for c in res.checks if not c.passed} == KRATOS_MISSES
    assert res.metrics["shear_l2_error"] == pytest.approx(0.0244, abs=5e-4)
    with pytest.raises(DisagreementError, match="stick"):
        assert_agrees(res)


#: Checks the stored Kratos result (element a/23) fails at the default tolerances.
KRATOS_MISSES = {"stick"}


def test_result_at_other_loads_is_not_this_case():
    """Kratos' Cattaneo result has Q0 = 0.596 mu P: against a case with Q0 = 0.5 mu P it is
    refused (the old 10 % match let it through), and the message says what to do."""
    case = replace(load_case("cattaneo"), Q0=15.0)
    with pytest.raises(CaseError, match="not a result of this case") as exc:
        verify(case, DATA / "steps.csv")
    assert "case file at the result's loads" in str(exc.value)


def test_kratos_cli_errors_are_one_line(tmp_path, capsys, monkeypatch):
    """Kratos failing (or missing) ends in one message and exit 2, never a traceback."""
    def fail(*args, **kwargs):
        raise DriverError("Kratos did not converge at t = 3 (top displacement u = 0, v = -1)")

    monkeypatch.setattr(kratos, "available", lambda: True)
    monkeypatch.setattr(kratos, "run", fail)
    assert kratos.main(["cattaneo", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "did not converge" in err
    monkeypatch.setattr(kratos, "available", lambda: False)
    assert kratos.main(["cattaneo", str(tmp_path / "o")]) == 2
    assert 'pip install ".[kratos]"' in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.skipif(not kratos.available(), reason="Kratos not installed (pip install .[kratos])")
def test_kratos_driver_lands_on_the_case(tmp_path):
    """Targets from the clamped FE model: Kratos lands within 1 % of P and Q0 (measured
    -0.02 % and -0.22 % at level 0), and its edges agree; a file of the user's in OUT is
    refused without --force and kept with it."""
    case = load_case("cattaneo")
    out = tmp_path / "cattaneo"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    with pytest.raises(CaseError, match="notes.txt"):
        kratos.run(case, out, level=0)
    res = verify(case, kratos.run(case, out, level=0, force=True))
    assert (out / "notes.txt").read_text() == "mine"
    assert (out / "multicontact_fem" / "steps.csv").is_file()
    assert "Kratos" in res.source
    assert res.case.P == pytest.approx(case.P, rel=LANDING_RTOL)
    assert res.case.Q0 == pytest.approx(case.Q0, rel=LANDING_RTOL)
    failed = {c.name for c in res.checks if not c.passed}
    # measured at level 0: edge 0.058 %, pressure 0.52 %; stick 1.01 % of the width (tolerance
    # 1 %) -- the stick and shear checks are where Kratos' mortar result differs
    assert "edge" not in failed and "pressure" not in failed and failed <= {"stick", "shear"}


def test_targets_corrected_once_on_the_reactions():
    """One secant step on the measured loads: exact when Kratos' response is our FE's up to
    a linear stiffness ratio (stiffer in v by 1 %, softer in u by 3 %)."""
    v = -np.linspace(0.1, 1.0, 10)
    P = 100 * np.linspace(0.1, 1.0, 10)          # P = -100 v along stage 1
    u = np.r_[np.zeros(10), 0.2, 0.4, 0.6, 0.2, -0.6]
    Q = np.r_[np.zeros(10), 6.0, 12.0, 18.0, 6.0, -18.0]   # Q = 30 u in stages 2-3
    stage = [1] * 10 + [2, 2, 2, 3, 3]
    vv = np.r_[v, [v[-1]] * 5]
    path = list(zip(stage, u, vv, strict=True))
    fe = list(zip(np.r_[P, [100.0] * 5], Q, strict=True))
    measured = [(-101 * b, 0.97 * 30 * a) for _, a, b in path]
    new = kratos.corrected(path, fe, measured)
    assert [s for s, _, _ in new] == stage
    got = [(-101 * b, 0.97 * 30 * a) for _, a, b in new]
    for (Pn, Qn), (Pf, Qf) in zip(got, fe, strict=True):
        assert Pn == pytest.approx(Pf, rel=1e-9) and Qn == pytest.approx(Qf, rel=1e-9, abs=1e-9)
