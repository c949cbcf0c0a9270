"""A real external code: Kratos Multiphysics results verified against the analytic solution.

The stored result (tests/data/kratos_cattaneo: Cattaneo at our mesh level 0, written once by
``python -m compare.external.kratos cattaneo OUT --level 0``, Kratos 10.3) keeps the reader path
and the verdict on a foreign code tested without Kratos; the slow test runs the driver itself
where the ``[kratos]`` extra is installed.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from compare.errors import CaseError
from compare.external import kratos
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


@pytest.mark.slow
@pytest.mark.skipif(not kratos.available(), reason="Kratos not installed (pip install .[kratos])")
def test_kratos_driver_hertz(tmp_path):
    out = tmp_path / "hertz"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    with pytest.raises(CaseError, match="notes.txt"):
        kratos.run("hertz", out, level=0)
    manifest = kratos.run("hertz", out, level=0, force=True)
    assert (out / "notes.txt").read_text() == "mine"
    assert (out / "multicontact_fem" / "steps.csv").is_file()
    res = verify("hertz", manifest)
    assert "Kratos" in res.source
    assert_agrees(res)
