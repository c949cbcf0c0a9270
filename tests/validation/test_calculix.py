"""CalculiX end to end: the driver writes the deck, runs ccx, reads the .frd and verifies.

Slow (2.5 and 7 minutes at level 0 on a loaded 2-core machine); skipped where ``ccx`` is not
on PATH (Debian: ``apt-get install calculix-ccx``; ``.ci/sysdeps.sh`` installs it as root).
"""

from __future__ import annotations

import pytest

from compare.cases import load_case
from compare.external import calculix as ccx
from compare.external.driver import LANDING_RTOL
from compare.testing import DisagreementError, assert_agrees
from compare.verify import verify

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(not ccx.available(),
                                 reason="ccx not on PATH (apt-get install calculix-ccx)")]

#: Checks ccx's Cattaneo result at level 0 (h = a/15, node-to-surface penalty) fails: the stick
#: edge (measured 1.6 % of the width, tolerance 1 %) and the shear (18 %, tolerance 5 %).
CCX_MISSES_LEVEL0 = {"stick", "shear"}


def _landed(res, case) -> None:
    assert res.case.P == pytest.approx(case.P, rel=LANDING_RTOL)
    assert res.case.Q0 == pytest.approx(case.Q0, rel=LANDING_RTOL)


def test_ccx_hertz_level0(tmp_path):
    case = load_case("hertz")
    res = verify(case, ccx.run(case, tmp_path, level=0))
    assert "CalculiX" in res.source
    _landed(res, case)
    assert_agrees(res)  # edges (0.27 %) and pressure (1.6 %) within the tolerances


def test_ccx_cattaneo_level0(tmp_path):
    case = load_case("cattaneo")
    res = verify(case, ccx.run(case, tmp_path, level=0))
    _landed(res, case)
    assert res.fem.stage(2) and res.fem.stage(3)
    failed = {c.name for c in res.checks if not c.passed}
    assert "edge" not in failed and "zone_count" not in failed
    assert failed == CCX_MISSES_LEVEL0
    with pytest.raises(DisagreementError, match="stick"):
        assert_agrees(res)
