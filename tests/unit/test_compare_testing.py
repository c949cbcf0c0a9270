"""assert_agrees on synthetic results: messages list every metric, value and tolerance."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from compare.testing import DisagreementError, assert_agrees
from compare.tolerances import DEFAULTS


def fake(**metrics):
    base = {"edge_error_max": 0.001, "stick_edge_error_max": 0.002, "pressure_l2_error": 0.01,
            "shear_l2_error": 0.02, "load_share_error_max": 0.0, "moment_error": 0.0,
            "rotation_error": float("nan"), "uncoupling_error": 0.0, "jc_error": 0.01,
            "zone_count_mismatch": 0.0, "full_slip_mismatches": 0.0}
    base.update(metrics)
    return SimpleNamespace(case=SimpleNamespace(name="fake", tolerances=dict(DEFAULTS)),
                           metrics=base)


def test_passes_within_tolerances():
    assert_agrees(fake())


def test_failure_message_lists_metric_value_tolerance():
    with pytest.raises(DisagreementError) as exc:
        assert_agrees(fake(edge_error_max=0.05), edge_rtol=0.02)
    msg = str(exc.value)
    assert "edge (edge_error_max=0.05 > 0.02)" in msg
    for name in ("stick_edge_error_max", "pressure_l2_error", "shear_l2_error"):
        assert name in msg
    assert "FAIL" in msg and "n/a" in msg


def test_zone_count_mismatch_fails():
    with pytest.raises(DisagreementError, match="zone_count"):
        assert_agrees(fake(zone_count_mismatch=1.0))


def test_unknown_keyword():
    with pytest.raises(TypeError, match="edge_tol"):
        assert_agrees(fake(), edge_tol=0.1)



@pytest.mark.parametrize("value", ["abc", "0.1", None, float("nan"), -0.01, True, [0.1]])
def test_bad_tolerance_value_named(value):
    """A tolerance that is no number >= 0 (a NaN one failed every check without saying why, a
    string raised float()'s bare ValueError): one error naming the keyword and the value."""
    with pytest.raises(ValueError, match=r"assert_agrees: edge_rtol=.* is not allowed: need a "
                       r"number >= 0"):
        assert_agrees(fake(), edge_rtol=value)


def test_infinite_tolerance_is_no_bound():
    assert_agrees(fake(edge_error_max=5.0), edge_rtol=float("inf"), stick_rtol=0.002)

def test_check_table_columns_align_on_long_names():
    """Every column starts (text) or ends (numbers) at one offset, also past a long name."""
    from compare.run import Check
    from compare.testing import format_checks

    checks = [Check("surface_peak_location", "surface_peak_location_error", 0.0107, 0.1),
              Check("edge", "edge_error_max", 3.6e-4, 0.005),
              Check("rotation", "rotation_error", float("nan"), 0.03)]
    lines = format_checks(checks, "title").splitlines()[1:]
    rows = [("metric", "value", "tolerance", "status")] + [
        (c.metric, "n/a" if c.status == "n/a" else f"{c.value:.4g}", f"{c.tolerance:.4g}",
         c.status) for c in checks]
    assert len({ln.index(r[0]) for ln, r in zip(lines, rows, strict=True)}) == 1
    assert len({ln.rindex(r[3]) for ln, r in zip(lines, rows, strict=True)}) == 1
    for k in (1, 2):  # numbers right-aligned: they end where their header ends
        ends = {ln.index(r[k], ln.index(r[0]) + len(r[0])) + len(r[k])
                for ln, r in zip(lines, rows, strict=True)}
        assert len(ends) == 1, "\n".join(lines)


def test_stress_tolerances_can_be_overridden():
    """The stress checks have keywords too (they were checked but could not be overridden)."""
    res = fake(stress_l2_error=0.05, surface_peak_error=0.3, surface_peak_location_error=0.2)
    with pytest.raises(DisagreementError, match="stress"):
        assert_agrees(res)
    assert_agrees(res, stress_rtol=0.06, surface_peak_rtol=0.4, surface_peak_location_rtol=0.25)
