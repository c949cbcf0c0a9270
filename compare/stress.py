"""FE stresses against the analytic field in body 2 (issue 17).

Body 2 is the flat lower body (``y <= 0``); ``analytic.stress`` integrates the Flamant kernels
over the analytic tractions, ``fem.FemHistory.stress`` gives the L2-projected nodal stresses.
Both use tension positive and body 2's axes, and the FE shear on body 2's contact row is
``+q`` (``analytic/stress.py`` docstring).  Metrics (dimensionless; NaN = not applicable):

- ``stress_l2_error``: max over the stage-1 end and the sampled Q of the relative L2 error of
  ``(sxx, syy, sqrt(2) sxy)`` over the body-2 nodes strictly below the surface inside a box
  around every zone (``BOX_PAD`` zone widths to each side, ``BOX_DEPTH`` deep), leaving out a
  disc of ``STRESS_EXCLUSION`` zone widths around every singular point (sharp-corner edge,
  kink inside a zone: the stresses are unbounded there); nodal weights are the lumped mass.
- ``stress_shape_error``: the same with the weighted mean of the difference removed.  Finite
  clamped FE bodies add a nearly uniform sxx (Hertz level 0: 0.047 / 0.026 / 0.014 for size
  factors 25 / 50 / 100); the half-plane far-field boundary of the FE model removes it (library
  at default levels: stress_l2_error 0.0007-0.011, within ~20 % of stress_shape_error).
- ``surface_peak_error``: max over the sampled Q and the zones of |peak FE sxx - peak
  analytic sxx| on the surface near the zone (the zone widened by BOX_PAD widths, cut half-way
  to its neighbours; the singular discs left out), divided by the largest regular |analytic
  sxx| of the state (the tensile peaks, at a trailing edge or a stick edge, are where fretting
  cracks start);
- ``surface_peak_location_error``: max over the sampled Q and the zones of the distance
  between the two peaks divided by the zone width (from the nearest analytic point tied with
  the analytic peak to rounding, PEAK_TIE: a plateau has no one peak).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import analytic
import fem
from compare import metrics as mt
from compare._memo import memo
from compare.analytic_side import AnalyticResult, stick_solution
from compare.cases import Case
from compare.fem_side import kinks

NAN = float("nan")
#: The metrics of :func:`stress_metrics`.
STRESS_METRICS = ("stress_l2_error", "stress_shape_error", "surface_peak_error",
                  "surface_peak_location_error")
#: Box around a zone: this many zone widths beyond each edge (the field decays like 1/r^2).
BOX_PAD = 0.5
#: Box depth in zone widths (the Hertz maximum shear sits at 0.39 widths).
BOX_DEPTH = 1.0
#: Radius of the disc left out around a singular point, in zone widths: the analytic stress
#: is unbounded there (1/sqrt at a sharp corner, log at a kink) and no nodal field follows it.
STRESS_EXCLUSION = 0.1
#: Analytic surface samples per zone (plus every stick edge) for the peak of sxx.
PEAK_SAMPLES = 401
#: A zone whose analytic surface peak lies within this many exclusion radii of a singular point
#: has no peak metric: the supremum is the (unbounded) singular point itself.
PEAK_MARGIN = 1.5
#: Pad of the surface window around the contact span, in span widths.
SURFACE_PAD = 0.25
#: Analytic surface sxx within this fraction of the state's scale of the peak ties with it:
#: where exact values are equal the computed ones agree to rounding (sharp_punch after Q returns
#: to 0: full stick, q = 0, sxx = 0 on the whole surface outside the zone, computed 1.2e-16 of
#: 52), and the FE peak's location is measured from the nearest tied point (the FE, picking
#: its largest rounding noise on that plateau, had been 1.5 zone widths from the first one).
PEAK_TIE = 1e-9


@dataclass(frozen=True)
class StressRow:
    """Comparison at one state: ``stage`` 1 (end of stage 1), 2 or 3 and its ``Q``.

    ``l2_error``, ``shape_error`` (see module docstring); ``peak_analytic``/``x_peak_analytic`` and
    ``peak_fem``/``x_peak_fem``: surface sxx peak of the zone with the largest analytic peak,
    and where; ``peak_error`` and ``peak_location_error``: worst zone, as in the module
    docstring (NaN at the stage-1 end).
    """

    stage: int
    Q: float
    l2_error: float
    shape_error: float
    peak_analytic: float
    x_peak_analytic: float
    peak_fem: float
    x_peak_fem: float
    peak_error: float
    peak_location_error: float


# ---------------------------------------------------------------------------------------------
# FE body-2 nodes
# ---------------------------------------------------------------------------------------------
def body2_xy(hist: fem.FemHistory) -> tuple[np.ndarray, np.ndarray]:
    """``(x, y)`` of body 2's stress nodes (no assembly: for callers that need no weights)."""
    xy = hist.fields.disc.scalar_bases.doflocs(1)
    return xy[0], xy[1]


def body2_nodes(hist: fem.FemHistory) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(x, y, w)`` of body 2's stress nodes, ``w`` the lumped-mass (area) weights."""
    w = hist.fields.lumped_mass(1)
    return (*body2_xy(hist), w)


def box_mask(x: np.ndarray, y: np.ndarray, zones, points) -> np.ndarray:
    """Nodes strictly below the surface in a box around a zone, outside the singular discs."""
    keep = np.zeros(x.shape, bool)
    for a, b in zones:
        w = b - a
        keep |= (x >= a - BOX_PAD * w) & (x <= b + BOX_PAD * w) & (y < 0) & (y >= -BOX_DEPTH * w)
    for s in points:
        keep &= np.hypot(x - s, y) > STRESS_EXCLUSION * mt.zone_width_at(zones, s)
    return keep


def _tensor(sxx, syy, sxy) -> np.ndarray:
    return np.array([sxx, syy, np.sqrt(2.0) * sxy])


def subsurface_error(fe: np.ndarray, an: analytic.StressField, w: np.ndarray
                     ) -> tuple[float, float]:
    """Relative L2 of the in-plane tensors (FE rows sxx, syy, sxy) with weights w, and the same
    with the weighted mean of the difference removed (a uniform stress, the leading effect of
    the finite FE bodies, is itself an elastic state)."""
    ref = _tensor(an.sxx, an.syy, an.sxy)
    d = _tensor(*fe[:3]) - ref
    shape = d - (d @ w)[:, None] / np.sum(w)
    den = np.sqrt(np.sum(w * ref * ref))
    if not den > 0:
        return NAN, NAN
    return float(np.sqrt(np.sum(w * d * d)) / den), float(np.sqrt(np.sum(w * shape**2)) / den)


# ---------------------------------------------------------------------------------------------
# surface sxx
# ---------------------------------------------------------------------------------------------
def surface_window(normal: analytic.NormalSolution) -> tuple[float, float]:
    lo, hi = normal.zones[0][0], normal.zones[-1][1]
    pad = SURFACE_PAD * (hi - lo)
    return lo - pad, hi + pad


def peak_windows(zones) -> list[tuple[float, float]]:
    """Per zone: the zone widened by BOX_PAD widths, cut half-way to its neighbours."""
    out = []
    for k, (a, b) in enumerate(zones):
        lo, hi = a - BOX_PAD * (b - a), b + BOX_PAD * (b - a)
        if k > 0:
            lo = max(lo, 0.5 * (zones[k - 1][1] + a))
        if k + 1 < len(zones):
            hi = min(hi, 0.5 * (b + zones[k + 1][0]))
        out.append((lo, hi))
    return out


def fem_surface(hist: fem.FemHistory, step, window) -> tuple[np.ndarray, np.ndarray]:
    """Body 2's contact-row nodes in the window (sorted by x) and their nodal sxx."""
    x, y = body2_xy(hist)
    row = np.flatnonzero((y == 0) & (x >= window[0]) & (x <= window[1]))
    row = row[np.argsort(x[row])]
    return x[row], hist.body_stress(step, 1)[0, row]


def analytic_surface(sol, window) -> tuple[np.ndarray, np.ndarray]:
    """Analytic surface sxx on a grid clustered in the zones, with every edge and stick edge
    (computed once per solution and window: the report's figures reuse the metrics' curves)."""
    return memo(sol, ("surface", *map(float, window)), lambda: _analytic_surface(sol, window))


def _analytic_surface(sol, window) -> tuple[np.ndarray, np.ndarray]:
    normal = an_normal(sol)
    pts = [np.linspace(*window, PEAK_SAMPLES)]
    pts += [np.linspace(a, b, PEAK_SAMPLES) for a, b in normal.zones]
    if isinstance(sol, analytic.StickSolution):
        pts += [np.asarray([v for s in sol.stick_zones if s is not None for v in s])]
    x = np.unique(np.concatenate(pts))
    x = x[(x >= window[0]) & (x <= window[1])]
    return x, analytic.surface_stress(sol, x)


def regular(x: np.ndarray, zones, points, factor: float = 1.0) -> np.ndarray:
    """Surface points outside ``factor`` x the STRESS_EXCLUSION discs of the singular points."""
    keep = np.ones(x.shape, bool)
    for s in points:
        keep &= np.abs(x - s) > factor * STRESS_EXCLUSION * mt.zone_width_at(zones, s)
    return keep


def zone_peaks(xa, sa, xf, sf, zones, points) -> list[tuple[float, float, float, float]]:
    """Per zone ``(peak_an, x_an, peak_fe, x_fe)`` of sxx in its peak window, singular discs
    left out (the analytic sxx is unbounded there); ``x_an``: of analytic points tied with the
    peak (PEAK_TIE), the one nearest the FE peak."""
    ka, kf = regular(xa, zones, points), regular(xf, zones, points)
    scale = np.max(np.abs(sa[ka])) if ka.any() else 0.0
    out = []
    for lo, hi in peak_windows(zones):
        ma = ka & (xa >= lo) & (xa <= hi)
        mf = kf & (xf >= lo) & (xf <= hi)
        if not (ma.any() and mf.any()):
            out.append((NAN, NAN, NAN, NAN))
            continue
        i, j = np.flatnonzero(ma)[np.argmax(sa[ma])], np.flatnonzero(mf)[np.argmax(sf[mf])]
        if not regular(xa[i:i + 1], zones, points, PEAK_MARGIN)[0]:
            out.append((NAN, NAN, NAN, NAN))  # the sup is the singular point itself
            continue
        tied = np.flatnonzero(ma & (sa >= sa[i] - PEAK_TIE * scale))
        x_an = xa[tied[np.argmin(np.abs(xa[tied] - xf[j]))]]
        out.append((float(sa[i]), float(x_an), float(sf[j]), float(xf[j])))
    return out


# ---------------------------------------------------------------------------------------------
# states and metrics
# ---------------------------------------------------------------------------------------------
def analytic_states(case: Case, an: AnalyticResult) -> list[tuple[int, float, object]]:
    """``(stage, Q, solution)``: the stage-1 end and a StickSolution per sampled Q (solved once
    per analytic result, friction and Q0)."""
    return memo(an, ("states", case.mu, case.Q0), lambda: _analytic_states(case, an))


def _analytic_states(case: Case, an: AnalyticResult) -> list[tuple[int, float, object]]:
    out: list[tuple[int, float, object]] = [(1, 0.0, an.normal)]
    for st in an.samples:
        Q0 = None if st.stage == 2 else case.Q0
        out.append((st.stage, st.Q, stick_solution(an.normal, case.mu, st.Q, Q0)))
    return out


def fem_step(hist: fem.FemHistory, stage: int, Q: float):
    return hist.stage(1)[-1] if stage == 1 else hist.at(stage, Q=Q)


def compare_state(case: Case, hist: fem.FemHistory, stage: int, Q: float, sol, nodes, keep,
                  points) -> StressRow:
    """Subsurface error and, per zone, the surface peaks of one state."""
    step = fem_step(hist, stage, Q)
    x, y, w = nodes
    fe = hist.body_stress(step, 1)[:, keep]
    l2, shape = subsurface_error(fe, analytic.stress(sol, x[keep], y[keep], nu=case.nu), w[keep])
    zones = an_normal(sol).zones
    window = surface_window(an_normal(sol))
    xa, sa = analytic_surface(sol, window)
    xf, sf = fem_surface(hist, step, window)
    peaks = zone_peaks(xa, sa, xf, sf, zones, points)
    scale = np.max(np.abs(sa[regular(xa, zones, points)]))
    val = [abs(pf - pa) / scale for pa, _, pf, _ in peaks]
    loc = [abs(xf_ - xa_) / (b - a) for (_, xa_, _, xf_), (a, b) in zip(peaks, zones,
                                                                        strict=True)]
    if stage == 1 or all(np.isnan(val)):
        return StressRow(stage, Q, l2, shape, *max(peaks, key=lambda r: -np.inf
                                                   if np.isnan(r[0]) else r[0]), NAN, NAN)
    k = int(np.nanargmax([pa for pa, *_ in peaks]))
    return StressRow(stage, Q, l2, shape, *peaks[k], float(np.nanmax(val)),
                     float(np.nanmax(loc)))


def an_normal(sol) -> analytic.NormalSolution:
    return sol.normal if isinstance(sol, analytic.StickSolution) else sol


def stress_metrics(case: Case, an: AnalyticResult, hist: fem.FemHistory
                   ) -> tuple[dict, list[StressRow]]:
    """The stress metrics of a case and the per-state rows (all NaN, no rows, for a result
    without body fields: an external code's interface-only result, ``compare.verify``)."""
    if not hist.has_fields:
        return dict.fromkeys(STRESS_METRICS, NAN), []
    ns = an.normal
    nodes = body2_nodes(hist)
    points = mt.singular_points(ns.zones, ns.singular, kinks(case))
    keep = box_mask(nodes[0], nodes[1], ns.zones, points)
    states = analytic_states(case, an)
    hist.body_stresses([fem_step(hist, stage, Q) for stage, Q, _ in states], 1)  # one batch
    rows = [compare_state(case, hist, stage, Q, sol, nodes, keep, points)
            for stage, Q, sol in states]
    later = [r for r in rows if r.stage > 1]
    return {"stress_l2_error": max(r.l2_error for r in rows),
            "stress_shape_error": max(r.shape_error for r in rows),
            "surface_peak_error": _nanmax([r.peak_error for r in later]),
            "surface_peak_location_error": _nanmax([r.peak_location_error for r in later])}, rows


def _nanmax(values: list[float]) -> float:
    """Largest non-NaN value (NaN if none: not applicable)."""
    v = [x for x in values if not np.isnan(x)]
    return max(v) if v else NAN
