"""Section 6 (overlapped extent) against closed forms derived here.

Small-load limit of Fig. 5: each zone of the double wedge becomes a single wedge with slopes
``-t1`` (inner face) and ``+t2`` (outer face); the problem is self-similar, so Pe tends to a
constant.  With ``s = m + r sin(phi)`` on a zone of centre m and half-width r, and the apex at
``phi_k``:

* actual (consistency ``int h'/X = 0``): ``t1 (pi/2 + phi_c) = t2 (pi/2 - phi_c)``, i.e.
  ``phi_c = (pi/2) (t2 - t1)/(t1 + t2)``;
* overlapped (edges on one line): ``t1 (1 + sin phi_o) = t2 (1 - sin phi_o)``, i.e.
  ``sin phi_o = (t2 - t1)/(t1 + t2)``;
* load (1/z term of Phi, valid with or without consistency): ``P = r cos(phi_k)(t1 + t2)/A``.

Hence ``width ~ 1/cos(phi_k)`` at equal load and ``Pe -> 100 (1 - cos phi_c / cos phi_o)``; for
equal angles both vanish (``a b = c^2`` and the overlap coincide, paper Sec. 6).
"""

from __future__ import annotations

import numpy as np
import pytest

import analytic
from analytic import profiles

# the limit is approached linearly in kappa (zone interaction); at kappa ~ 3e-3 the remaining
# difference is below this many percentage points
PE_LIMIT_TOL = 0.05
# Pe from the solver itself (edges ~1e-12): the overlapped load inversion is the weakest link
PE_SOLVER_TOL = 1e-8


def pe_small_load_limit(phi_inner: float, phi_outer: float) -> float:
    """``Pe(kappa -> 0) = 100 (1 - cos phi_c / cos phi_o)`` (derived in the module docstring)."""
    t1, t2 = np.tan(phi_inner), np.tan(phi_outer)
    phi_c = 0.5 * np.pi * (t2 - t1) / (t1 + t2)
    phi_o = np.arcsin((t2 - t1) / (t1 + t2))
    return 100.0 * (1.0 - np.cos(phi_c) / np.cos(phi_o))


@pytest.mark.parametrize("phi1, phi2", [(0.11, 0.07), (0.07, 0.11)])
def test_pe_tends_to_single_wedge_limit(phi1: float, phi2: float) -> None:
    loads = np.array([1e-4, 2e-4])
    data = analytic.fig5_data(phi1, phi2, loads=loads)
    assert data.kappa[0] < 1e-3
    limit = pe_small_load_limit(phi1, phi2)
    # linear extrapolation of Pe(kappa) to kappa = 0
    slope = (data.Pe[1] - data.Pe[0]) / (data.kappa[1] - data.kappa[0])
    pe0 = data.Pe[0] - slope * data.kappa[0]
    assert abs(pe0 - limit) < PE_LIMIT_TOL, (pe0, limit)


def test_equal_angles_error_is_second_order_in_kappa() -> None:
    """Equal angles: actual ``a b = c^2`` vs overlapped ``a + b = 2c`` differ at O(kappa^2)."""
    data = analytic.fig5_data(0.18, 0.18, loads=np.array([1e-3, 1e-2]))
    assert pe_small_load_limit(0.18, 0.18) == 0.0
    assert np.all(data.Pe > 0)
    order = np.log(data.Pe[1] / data.Pe[0]) / np.log(data.kappa[1] / data.kappa[0])
    assert abs(order - 2.0) < 0.01, order


def test_overlapped_zones_lie_on_one_line_and_carry_the_load() -> None:
    prof = profiles.double_wedge(1.0, 0.11, 0.07)
    ovl = analytic.overlapped(prof, 0.02, 1.0)
    edges = np.array(ovl.zones).ravel()
    h = prof.h0(edges)
    assert np.allclose(h, ovl.delta, rtol=0, atol=1e-13)
    assert abs(sum(ovl.zone_loads) - 0.02) < 1e-12


def test_overlap_rejects_bad_load() -> None:
    with pytest.raises(analytic.InputError, match="P="):
        analytic.overlapped(profiles.double_wedge(1.0, 0.1, 0.1), -1.0, 1.0)
