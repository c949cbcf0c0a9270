"""``run_case``: solve a case analytically and by FE, and measure the distance between them.

Metrics (dimensionless but ``pressure_l2_top_x``; ``CaseResult.metrics`` is a flat dict of
floats):

- ``edge_error_max``: max over zones and edges of |a_fe - a_an| / (b_an - a_an) at P0;
  ``edge_error_max_elements``: the same errors divided by the local node spacing instead (per
  zone also ``edge_uncertainty_elements``: the edge estimator's own uncertainty);
- ``pressure_l2_error`` / ``pressure_max_error``: relative L2 / max of p_fe - p_an at P0 over
  all nodes of the refined window, away from singular points (metrics.SINGULAR_EXCLUSION);
- ``load_share_error_max``: max over zones of |F_fe - F_an| / P;
- ``moment_error``: |M_fe - M_an| / (P * contact span) (vertical indentation) or
  ``rotation_error`` |theta_fe - theta_an| / |theta_an| (applied moment);
- ``stick_edge_error_max`` / ``shear_l2_error``: max over the sampled Q of stages 2 and 3 of
  the stick-edge error relative to the contact-zone width and of the L2 shear error in units of
  the Coulomb bound, ||q_fe - q_an|| / (mu ||p_an||) (|q| <= mu p: the largest ||q|| any sample
  can have; relative to ||q_an|| the error blew up where q is small, e.g. at the stage-3
  reversal Q = 0, issue 25; benchmarks/shear_load_ratios.py); ``stick_edge_error_max_elements``:
  in local node spacings;
- ``pressure_l2_top_share`` / ``shear_l2_top_share``: the largest share of one node in the
  squared L2 error (of the worst shear sample; > metrics.DOMINANT_SHARE: one node dominates),
  ``pressure_l2_top_x`` that node's x (a length, the one non-dimensionless entry);
- ``uncoupling_error``: max over stages 2-3 of ||p_fe(Q) - p_fe(0)|| / ||p_fe(0)||;
- ``jc_error``: FE shear against mu [p_fe(P0) - p_fe(P*)] built from FE normal solutions;
- ``zone_count_mismatch`` and ``full_slip_mismatches``: counts that must be 0;
- ``stress_l2_error``, ``surface_peak_error``, ``surface_peak_location_error``: FE stresses of
  body 2 against ``analytic.stress`` (``compare/stress.py``).

NaN means "not applicable" (e.g. no tangential load) and is reported as n/a, never as pass
of a real measurement.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import fem
from compare import metrics as mt
from compare.analytic_side import AnalyticResult, StickState, solve_case
from compare.cases import Case, load_case
from compare.fem_side import Q_MERGE, kinks, run_fem
from compare.stress import stress_metrics
from compare.tolerances import METRIC_OF

NAN = float("nan")
#: Count metrics that must be exactly zero, checked like tolerances.
EXACT_CHECKS = {"zone_count": "zone_count_mismatch", "full_slip": "full_slip_mismatches"}


@dataclass(frozen=True)
class Check:
    """One pass/fail line: metric value against its named tolerance (status 'n/a' for NaN)."""

    name: str
    metric: str
    value: float
    tolerance: float

    @property
    def status(self) -> str:
        if math.isnan(self.value):
            return "n/a"
        return "pass" if self.value <= self.tolerance else "FAIL"

    @property
    def passed(self) -> bool:
        return self.status != "FAIL"


@dataclass(frozen=True)
class CaseResult:
    """Outcome of :func:`run_case`.

    case; analytic (AnalyticResult); fem (fem.FemHistory); metrics (flat dict of floats, see
    module docstring); zones (per analytic zone: edges, FE edges, errors, load shares);
    samples (per sampled Q: stage, Q, analytic and FE stick zones, errors); checks (one
    :class:`Check` per named tolerance); timings (seconds); vtk (path of the .pvd or None);
    source: what was verified ('multicontact fem' or the external code and its files, see
    ``compare.verify``); unavailable: metric -> why the result cannot give it (reported as
    "not available", not as a pass of a measurement); notes: what was done to the input
    before measuring (e.g. small negative pressures clipped, ``compare.verify``).
    """

    case: Case
    analytic: AnalyticResult
    fem: fem.FemHistory
    metrics: dict
    zones: list
    samples: list
    checks: tuple
    timings: dict
    vtk: str | None = None
    source: str = "multicontact fem"
    unavailable: dict = field(default_factory=dict)
    notes: tuple = ()

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    def failures(self) -> list[Check]:
        return [c for c in self.checks if not c.passed]

    def summary(self) -> dict:
        """JSON-ready summary (no arrays)."""
        return {"case": self.case.summary(), "passed": self.passed,
                "metrics": {k: _json_float(v) for k, v in self.metrics.items()},
                "checks": [{"name": c.name, "metric": c.metric, "value": _json_float(c.value),
                            "tolerance": c.tolerance, "status": c.status} for c in self.checks],
                "zones": self.zones, "samples": self.samples, "timings": self.timings,
                "vtk": self.vtk, "source": self.source, "unavailable": self.unavailable,
                "notes": list(self.notes),
                "fem": {"n_dofs": self.fem.n_dofs, "order": self.fem.order,
                        "h_min": self.fem.h_min, "backend": self.fem.backend}}


def _json_float(v: float) -> float | None:
    return None if v is None or (isinstance(v, float) and not math.isfinite(v)) else v


# ---------------------------------------------------------------------------------------------
# stage 1: edges, pressure, load share, moment
# ---------------------------------------------------------------------------------------------
def normal_metrics(case: Case, an: AnalyticResult, end: fem.FemStep) -> tuple[dict, list]:
    """Edge, pressure, load-share and moment metrics at the end of stage 1."""
    ns, it = an.normal, end.interface
    fe_zones = list(end.contact_zones)
    errs = mt.edge_errors(ns.zones, fe_zones)
    keep = mt.regular_mask(it.x, ns.zones, mt.singular_points(ns.zones, ns.singular,
                                                              kinks(case)))
    p_l2, p_max = mt.traction_errors(it.x, it.w, it.p, ns.pressure, keep)
    share, share_x = mt.top_share(it.p[keep], ns.pressure(it.x[keep]), it.w[keep], it.x[keep])
    match = mt.match_zones(ns.zones, fe_zones)
    zones = []
    for k, ((a, b), (ea, eb)) in enumerate(zip(ns.zones, errs, strict=True)):
        fz = fe_zones[match[k]] if match[k] is not None else None
        F_fe = mt.zone_load(it.x, it.w, it.p, fz) if fz else 0.0
        zk = keep & mt.zone_nodes(it.x, (a, b))
        zl2 = mt.traction_errors(it.x, it.w, it.p, ns.pressure, zk)[0] if zk.any() else NAN
        ua, ub = _edge_uncertainty(end, match[k])
        ha, hb = mt.local_spacing(it.x, a), mt.local_spacing(it.x, b)
        zones.append({"zone": k, "analytic": [a, b], "fem": list(fz) if fz else None,
                      "singular": list(ns.singular[k]), "edge_error": [ea, eb],
                      "edge_error_rel": [ea / (b - a), eb / (b - a)],
                      "h_local": [ha, hb], "edge_error_elements": [ea / ha, eb / hb],
                      "edge_uncertainty_elements": [ua / ha, ub / hb],
                      "load_share_analytic": ns.zone_loads[k] / case.P,
                      "load_share_fem": F_fe / case.P, "pressure_l2_error": zl2})
    m = {"edge_error_max": max(max(z["edge_error_rel"]) for z in zones),
         "edge_error_max_elements": max(max(z["edge_error_elements"]) for z in zones),
         "pressure_l2_error": p_l2, "pressure_max_error": p_max,
         "pressure_l2_top_share": share, "pressure_l2_top_x": share_x,
         "load_share_error_max": max(abs(z["load_share_fem"] - z["load_share_analytic"])
                                     for z in zones),
         "zone_count_mismatch": float(abs(len(fe_zones) - len(ns.zones)))}
    m.update(_moment_metrics(case, an, end))
    return m, zones


def _edge_uncertainty(step: fem.FemStep, j: int | None) -> tuple[float, float]:
    """The FE zone ``j``'s edge uncertainties (NaN when not computed or no zone)."""
    if j is None or j >= len(step.edge_uncertainty):
        return NAN, NAN
    return step.edge_uncertainty[j]


def _moment_metrics(case: Case, an: AnalyticResult, end: fem.FemStep) -> dict:
    ns = an.normal
    span = ns.zones[-1][1] - ns.zones[0][0]
    if case.M is None:
        return {"moment_error": abs(end.M - ns.M) / (case.P * span), "rotation_error": NAN}
    theta_fe = float(end.plate[2])  # both sides: the gap in contact is h0(x) - theta x
    den = abs(ns.theta) if ns.theta != 0 else 1.0
    return {"moment_error": NAN, "rotation_error": abs(theta_fe - ns.theta) / den}


# ---------------------------------------------------------------------------------------------
# stages 2 and 3: stick zones, shear, uncoupling, Jaeger-Ciavarella
# ---------------------------------------------------------------------------------------------
def sample_metrics(case: Case, an: AnalyticResult, hist: fem.FemHistory, keep: np.ndarray
                   ) -> tuple[dict, list]:
    """Stick-edge and shear errors at every sampled Q."""
    rows = [_sample_row(case, an, hist, st, keep) for st in an.samples]
    if not rows:
        return {"stick_edge_error_max": NAN, "stick_edge_error_max_elements": NAN,
                "shear_l2_error": NAN, "shear_l2_top_share": NAN,
                "full_slip_mismatches": NAN}, []
    worst = max(rows, key=lambda r: r["shear_l2_error"])
    return {"stick_edge_error_max": max(r["stick_edge_error_max"] for r in rows),
            "stick_edge_error_max_elements": max(r["stick_edge_error_max_elements"]
                                                 for r in rows),
            "shear_l2_error": worst["shear_l2_error"],
            "shear_l2_top_share": worst["shear_l2_top_share"],
            "full_slip_mismatches": float(sum(r["full_slip_mismatch"] for r in rows))}, rows


def _sample_row(case: Case, an: AnalyticResult, hist: fem.FemHistory, st: StickState,
                keep: np.ndarray) -> dict:
    ns = an.normal
    step = hist.at(st.stage, Q=st.Q)
    match = mt.match_zones(ns.zones, list(step.contact_zones))
    fe_sticks = [step.stick_zones[j] if j is not None else None for j in match]
    errs = [mt.stick_edge_error(s_an, s_fe, b - a)
            for (a, b), s_an, s_fe in zip(ns.zones, st.stick_zones, fe_sticks, strict=True)]
    it = step.interface
    x, w = it.x[keep], it.w[keep]
    q_l2 = mt.bounded_l2(it.q[keep], np.asarray(st.shear(x), float), w,
                         case.mu * mt.l2(ns.pressure(x), w))
    share, share_x = mt.top_share(it.q[keep], np.asarray(st.shear(x), float), w, x)
    mismatch = sum((a is None) != (f is None) for a, f in zip(st.stick_zones, fe_sticks,
                                                             strict=True))
    elems = [_stick_elements(it.x, s_an, s_fe, e * (b - a))
             for (a, b), s_an, s_fe, e in zip(ns.zones, st.stick_zones, fe_sticks, errs,
                                              strict=True)]
    return {"stage": st.stage, "Q": st.Q, "Q_over_Q0": st.Q / case.Q0,
            "stick_analytic": [list(s) if s else None for s in st.stick_zones],
            "stick_fem": [list(s) if s else None for s in fe_sticks],
            "stick_edge_error": errs, "stick_edge_error_max": max(errs),
            "stick_edge_error_elements": elems,
            "stick_edge_error_max_elements": max(elems),
            "stick_uncertainty_elements": _stick_uncertainty(step, match, it.x),
            "shear_l2_error": q_l2, "shear_l2_top_share": share, "shear_l2_top_x": share_x,
            "full_slip_mismatch": int(mismatch)}


def _stick_elements(x: np.ndarray, s_an, s_fe, error: float) -> float:
    """A stick-edge error (length) in elements: at the FE stick zone's worse edge (or the
    analytic zone's centre when one side is in full slip)."""
    if s_an is None and s_fe is None:
        return 0.0
    if s_an is None or s_fe is None:
        c, d = s_an if s_fe is None else s_fe
        return mt.in_elements(error, x, 0.5 * (c + d))
    worse = 0 if abs(s_fe[0] - s_an[0]) >= abs(s_fe[1] - s_an[1]) else 1
    return mt.in_elements(error, x, s_fe[worse])


def _stick_uncertainty(step: fem.FemStep, match: list, x: np.ndarray) -> list:
    """Per analytic zone: the matched FE stick zone's edge uncertainties in elements."""
    out = []
    for j in match:
        u = step.stick_uncertainty[j] if j is not None and j < len(step.stick_uncertainty) \
            else None
        s = step.stick_zones[j] if j is not None else None
        out.append(None if u is None or s is None else
                   [mt.in_elements(u[0], x, s[0]), mt.in_elements(u[1], x, s[1])])
    return out


def uncoupling_error(hist: fem.FemHistory) -> float:
    """max over stages 2-3 of ||p(Q) - p(stage-1 end)|| / ||p(stage-1 end)||."""
    s1, later = hist.stage(1)[-1].interface, hist.stage(2) + hist.stage(3)
    if not later:
        return NAN
    return max(mt.relative_l2(s.interface.p, s1.p, s1.w) for s in later)


def jc_pairs(hist: fem.FemHistory, mu: float, tol: float) -> tuple[list, list]:
    """Steps of stages 2 / 3 paired with the stage-1 step at their reduced load.

    Stage 2: ``P* = P0 - Q / mu``; stage 3: ``P** = P0 - (Q0 - Q) / (2 mu)`` (P0, Q0 the ends of
    stages 1 and 2).  Only pairs present in the history (stage-1 load within ``tol``) count.
    """
    s1, s2, s3 = hist.stage(1), hist.stage(2), hist.stage(3)
    if not s2:
        return [], []
    P0, Q0 = s1[-1].P, s2[-1].Q

    def at_load(P: float):
        near = [s for s in s1 if abs(s.P - P) <= tol]
        return near[-1] if near else None

    two = [(s, at_load(P0 - s.Q / mu)) for s in s2 if s.Q > Q_MERGE * Q0]
    three = [(s, at_load(P0 - (Q0 - s.Q) / (2 * mu))) for s in s3 if s.Q < Q0 - Q_MERGE * Q0]
    return [p for p in two if p[1] is not None], [p for p in three if p[1] is not None]


def jc_error(case: Case, hist: fem.FemHistory, keep: np.ndarray, tol: float | None = None
             ) -> float:
    """FE shear vs the Jaeger-Ciavarella superposition of FE normal solutions (floored L2,
    on the nodes ``keep``: away from singular points), over the pairs of :func:`jc_pairs`
    (``tol``: stage-1 load match, default that of ``FemHistory.at``).

    Not applicable with an applied moment: the reduced problem keeps the stage-1 rotation,
    which the stage-1 FE increments (moment scaled with P) do not.
    """
    if case.M is not None or case.Q0 == 0:
        return NAN
    mu = case.mu
    two, three = jc_pairs(hist, mu, 1e-9 * max(case.P, 1.0) if tol is None else tol)
    end1, end2 = hist.stage(1)[-1].interface, hist.stage(2)[-1].interface
    p0, w, q_end = end1.p[keep], end1.w[keep], end2.q[keep]
    floor = mt.SHEAR_FLOOR * mu * mt.l2(p0, w)
    errs = [mt.relative_l2(s.interface.q[keep], mu * (p0 - r.interface.p[keep]), w, floor)
            for s, r in two]
    errs += [mt.relative_l2(s.interface.q[keep], q_end - 2 * mu * (p0 - r.interface.p[keep]),
                            w, floor) for s, r in three]
    return max(errs) if errs else NAN


# ---------------------------------------------------------------------------------------------
# public
# ---------------------------------------------------------------------------------------------
def checks_for(metrics: dict, tolerances: dict) -> tuple[Check, ...]:
    """One :class:`Check` per named tolerance plus the exact (must-be-zero) counts."""
    out = [Check(name, METRIC_OF[name], float(metrics.get(METRIC_OF[name], NAN)), tol)
           for name, tol in tolerances.items()]
    out += [Check(name, key, float(metrics.get(key, NAN)), 0.0)
            for name, key in EXACT_CHECKS.items()]
    return tuple(out)


def evaluate(case: Case, an: AnalyticResult, hist: fem.FemHistory, jc_tol: float | None = None
             ) -> tuple[dict, list, list]:
    """All metrics of a solved case: (metrics, zones, samples).

    ``hist`` is our FE history or an external result read as one (``compare.verify``);
    ``jc_tol``: load match of the Jaeger-Ciavarella pairs (see :func:`jc_error`).
    """
    end = hist.stage(1)[-1]
    m, zones = normal_metrics(case, an, end)
    ns = an.normal
    keep = mt.regular_mask(end.interface.x, ns.zones,
                           mt.singular_points(ns.zones, ns.singular, kinks(case)))
    ms, samples = sample_metrics(case, an, hist, keep)
    m.update(ms)
    m["uncoupling_error"] = uncoupling_error(hist)
    m["jc_error"] = jc_error(case, hist, keep, jc_tol)
    m.update(stress_metrics(case, an, hist)[0])
    return m, zones, samples


def run_case(case: Case | str | Path, vtk_dir: str | Path | None = None,
             analytic: AnalyticResult | None = None) -> CaseResult:
    """Run the analytic and FE solvers on a case and compare them.

    ``case``: a :class:`Case`, library name or TOML path; ``vtk_dir``: write the FE VTK series
    there (``fem.write_vtk``); ``analytic``: reuse an analytic result (convergence studies).
    """
    case = load_case(case)
    t0 = time.perf_counter()
    an = analytic or solve_case(case)
    t1 = time.perf_counter()
    hist = run_fem(case, an.normal)
    t2 = time.perf_counter()
    m, zones, samples = evaluate(case, an, hist)
    vtk = None if vtk_dir is None else str(fem.write_vtk(hist, vtk_dir))
    return CaseResult(case=case, analytic=an, fem=hist, metrics=m, zones=zones, samples=samples,
                      checks=checks_for(m, case.tolerances),
                      timings={"analytic": t1 - t0, "fem": t2 - t1,
                               "compare": time.perf_counter() - t2},
                      vtk=vtk)
