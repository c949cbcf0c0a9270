"""``verify``: judge a contact result computed by any FE code against the analytic solution.

The result comes in the exchange format of ``docs/external.md`` (CSV manifest or step files, or
a VTK series).  It is read as an FE-like history (:meth:`ExternalResult.history`), its loads are
checked against the case, and the analytic side is solved at the result's *own* loads: P (and M
in applied-moment mode) of the last stage-1 step, and every stage-2/3 step's Q with Q0 the last
stage-2 Q.  The metrics, named tolerances and checks are those of :func:`compare.run.run_case`
(:func:`compare.run.evaluate`); a metric the result cannot give is NaN with its reason in
``CaseResult.unavailable`` ("not available", never a pass of a measurement).
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

import fem
from compare.analytic_side import solve_case
from compare.cases import Case, load_case
from compare.errors import CaseError
from compare.external import ExternalResult, read_result
from compare.metrics import DOMINANT_SHARE
from compare.run import CaseResult, checks_for, evaluate
from compare.stress import STRESS_METRICS

#: The result's loads may differ from the case's by this fraction of P (Q: of mu P, i.e. Q0/muP
#: within 0.02; an applied M: of M).  The analytic side is solved at the result's own loads, so
#: this decides only whether the result is one of *this* case: it admits a run that lands
#: within 1 % (the drivers: Kratos -0.02 % on P, -0.22 % on Q0; CalculiX under load control
#: < 1e-4) and rejects a neighbouring load case (at 0.1, a Q0 = 0.5 mu P result passed as
#: Cattaneo's 0.6 mu P).
LOAD_MATCH_RTOL = 0.02
#: A stage-1 step pairs with a stage-2/3 step for the Jaeger-Ciavarella check when its P is
#: within this fraction of P0 of the reduced load: p then differs by about this fraction of its
#: norm, two orders below the JC tolerance.
JC_PAIR_RTOL = 2e-3
#: verify's choices of the sampled Q values.
SAMPLES = ("steps", "case")


def check_loads(case: Case, res: ExternalResult, hist: fem.FemHistory) -> None:
    """Every step's loads within :data:`LOAD_MATCH_RTOL` of the case's load path."""
    P, tol_q = case.P, LOAD_MATCH_RTOL * case.mu * case.P
    P0 = hist.stage(1)[-1].P
    Q0 = hist.stage(2)[-1].Q if hist.stage(2) else 0.0
    where = {s.index: raw.where for s, raw in zip(hist.steps, res.steps, strict=True)}
    if abs(P0 - P) > LOAD_MATCH_RTOL * P:
        _bad(where[hist.stage(1)[-1].index], f"P = {P0:.6g} at the end of stage 1", P)
    if case.Q0 > tol_q and not hist.stage(2):
        raise CaseError(f"{res.source}: the result has no stage-2 steps but the case has "
                        f"Q0 = {case.Q0:g}; add stages 2 and 3, or verify against a case with "
                        "Q0 = 0")
    if abs(Q0 - case.Q0) > tol_q:
        step = hist.stage(2)[-1].index if hist.stage(2) else hist.stage(1)[-1].index
        _bad(where[step], f"Q0 = {Q0:.6g} at the end of stage 2", case.Q0,
             f" +- {tol_q:.4g}")
    M0 = hist.stage(1)[-1].M
    if case.M and math.isfinite(M0) and abs(M0 - case.M) > LOAD_MATCH_RTOL * abs(case.M):
        _bad(where[hist.stage(1)[-1].index], f"M = {M0:.6g} at the end of stage 1", case.M)
    for s in hist.steps:
        _check_step(s, where[s.index], case, P0, Q0, tol_q)


def check_infinite_gaps(case: Case, res: ExternalResult, hist: fem.FemHistory) -> None:
    """``gap = inf`` ("contact impossible", an edge then sits at a sharp corner with no
    uncertainty) only where the case's profile cannot touch: h0 = inf at the node or at one of
    its neighbours (a code's grid need not put a node on the corner)."""
    for s, raw in zip(hist.steps, res.steps, strict=True):
        x, gap = s.interface.x, s.interface.gap
        bad = np.flatnonzero(np.isinf(gap))
        if not bad.size:
            continue
        near = np.stack([x[np.clip(bad + k, 0, x.size - 1)] for k in (-1, 0, 1)])
        beyond = np.isinf(np.asarray(case.profile.h0(near.ravel()), float)).reshape(near.shape)
        wrong = bad[~beyond.any(axis=0)]
        if wrong.size:
            i = int(wrong[0])
            raise CaseError(f"{raw.where}: gap = inf (contact impossible) at node {i + 1}, x = "
                            f"{float(x[i]):.6g}, where the case's profile can touch (h0 = "
                            f"{float(case.profile.h0(np.array([x[i]]))[0]):.4g}); allowed: inf "
                            "only beyond a sharp corner of the profile (give the gap there, or "
                            "leave the gap column out)")


def _check_step(s, where: str, case: Case, P0: float, Q0: float, tol_q: float) -> None:
    tol_p = LOAD_MATCH_RTOL * case.P
    if s.stage == 1 and (s.P > P0 + tol_p or abs(s.Q) > tol_q):
        raise CaseError(f"{where}: stage-1 step with P = {s.P:.6g}, Q = {s.Q:.6g}; allowed: "
                        f"0 < P <= {P0:.6g} (+- {tol_p:.4g}) and Q = 0 (+- {tol_q:.4g})")
    if s.stage > 1 and abs(s.P - P0) > tol_p:
        raise CaseError(f"{where}: stage-{s.stage} step with P = {s.P:.6g}; the normal load "
                        f"must stay at P0 = {P0:.6g} (+- {tol_p:.4g}) in stages 2 and 3")
    lo, hi = (-tol_q, Q0 + tol_q) if s.stage == 2 else (-Q0 - tol_q, Q0 + tol_q)
    if s.stage > 1 and not lo <= s.Q <= hi:
        raise CaseError(f"{where}: stage-{s.stage} step with Q = {s.Q:.6g}; allowed "
                        f"{lo:.6g} <= Q <= {hi:.6g} (Q0 = {Q0:.6g} from the end of stage 2)")
    if s.stage > 1 and abs(s.Q) > case.mu * s.P:
        raise CaseError(f"{where}: |Q| = {abs(s.Q):.6g} exceeds mu P = {case.mu * s.P:.6g} "
                        "(gross sliding is not part of the load path)")


def _bad(where: str, what: str, want: float, tol: str = "") -> None:
    raise CaseError(f"{where}: {what} does not match the case ({want:.6g}{tol}, within "
                    f"{LOAD_MATCH_RTOL:.0%}): a result at other loads (another Q0 / mu P) is not "
                    "a result of this case; verify it against a case file at the result's loads "
                    "(a copy of the case's .toml with its P and Q0, docs/cases.md), or, if only "
                    "its units or signs differ, declare them with --set (length_scale, "
                    "stress_scale, pressure_sign, shear_sign)")


def clip_stage3(hist: fem.FemHistory) -> fem.FemHistory:
    """Stage-3 loads measured just beyond +-Q0 (within the load tolerance, checked before)
    taken as +-Q0: the analytic stage 3 runs from Q0 to -Q0 and no further."""
    if not hist.stage(3):
        return hist
    Q0 = hist.stage(2)[-1].Q
    steps = tuple(replace(s, Q=float(np.clip(s.Q, -Q0, Q0))) if s.stage == 3 else s
                  for s in hist.steps)
    return replace(hist, steps=steps)


def result_case(case: Case, hist: fem.FemHistory, samples: str, code: str) -> Case:
    """The case at the result's own loads, sampled at its steps (or the case's samples)."""
    end = hist.stage(1)[-1]
    Q0 = hist.stage(2)[-1].Q if hist.stage(2) else 0.0
    M = None
    if case.M is not None:
        M = end.M if math.isfinite(end.M) else case.M
    if samples == "steps":
        s2 = tuple(s.Q for s in hist.stage(2))
        s3 = tuple(s.Q for s in hist.stage(3))
    else:
        s2, s3 = case.stage2, case.stage3
        _check_sampled(hist, s2, s3)
    return replace(case, P=end.P, Q0=Q0, M=M, stage2=s2, stage3=s3,
                   description=f"Result of {code} verified. {case.description}")


def _check_sampled(hist: fem.FemHistory, s2: tuple, s3: tuple) -> None:
    for stage, qs in ((2, s2), (3, s3)):
        for Q in qs:
            try:
                hist.at(stage, Q=Q)
            except fem.InputError:
                have = ", ".join(f"{s.Q:.6g}" for s in hist.stage(stage))
                raise CaseError(f"samples = 'case': the case samples Q = {Q:.6g} in stage "
                                f"{stage}, which is not a step of the result (its Q: {have}); "
                                "use samples = 'steps'") from None


def unavailable(case: Case, hist: fem.FemHistory, metrics: dict) -> dict:
    """What the case asks for but the result cannot give: metric (or stage) -> why.

    Metrics that do not apply to the case itself (the rotation in vertical indentation, M with
    an applied moment, stages 2-3 with Q0 = 0) are n/a for our own FE too and are not listed.
    """
    isnan = {k for k, v in metrics.items() if isinstance(v, float) and math.isnan(v)}
    why = {}
    if case.M is None and "moment_error" in isnan:
        why["moment_error"] = "the result gives no M at the end of stage 1"
    if case.M is not None and "rotation_error" in isnan:
        why["rotation_error"] = "the result gives no theta at the end of stage 1"
    if case.M is None and case.Q0 > 0 and "jc_error" in isnan:
        why["jc_error"] = ("needs stage-1 steps at the reduced loads P* = P0 - Q/mu (stage 2) or "
                           "P** = P0 - (Q0 - Q)/(2 mu) (stage 3) of its stage-2/3 steps; the "
                           f"result has none within {JC_PAIR_RTOL:g} P0")
    if not hist.has_fields:
        applies = STRESS_METRICS if case.Q0 > 0 else STRESS_METRICS[:2]
        for k in applies:
            why[k] = "the result has interface data only (no body stresses)"
    if case.Q0 > 0 and not hist.stage(3):
        why["stage 3"] = "the result has no stage-3 steps: stick and shear cover stage 2 only"
    return why


def verify(case: Case | str | Path, result: ExternalResult | str | Path,
           samples: str = "steps", settings: dict | None = None) -> CaseResult:
    """Verify an external result of ``case`` against the analytic solution.

    ``result``: an :class:`ExternalResult` or the path of a manifest / step-file folder / .pvd;
    ``samples``: "steps" (every stage-2/3 step) or "case" (the case's sampled Q, which must be
    steps of the result); ``settings``: header items overriding the files' (e.g.
    ``{"pressure_sign": "-1"}``).  Bad files raise :class:`CaseError` before anything is solved.
    """
    if samples not in SAMPLES:
        raise CaseError(f"samples = {samples!r} is not allowed; allowed: {', '.join(SAMPLES)}")
    case = load_case(case)
    res = result if isinstance(result, ExternalResult) else read_result(result, settings)
    hist, notes = res.checked_history(case.mu, case.E, case.nu)
    check_loads(case, res, hist)
    check_infinite_gaps(case, res, hist)
    hist = clip_stage3(hist)
    eff = result_case(case, hist, samples, res.meta.code)
    t0 = time.perf_counter()
    an = solve_case(eff)
    t1 = time.perf_counter()
    m, zones, rows = evaluate(eff, an, hist, jc_tol=JC_PAIR_RTOL * eff.P)
    return CaseResult(case=eff, analytic=an, fem=hist, metrics=m, zones=zones, samples=rows,
                      checks=checks_for(m, case.tolerances),
                      timings={"analytic": t1 - t0, "compare": time.perf_counter() - t1,
                               "external": res.meta.seconds},
                      source=f"{res.meta.code} ({res.source})",
                      unavailable=unavailable(eff, hist, m), notes=notes)


def measurement_lines(res: CaseResult) -> list[str]:
    """The edge errors in elements (with the estimator's own uncertainty) and the L2 errors
    that one node dominates (:data:`compare.metrics.DOMINANT_SHARE`)."""
    m = res.metrics
    out = []
    unc = [u for z in res.zones for u in z.get("edge_uncertainty_elements", ())
           if math.isfinite(u)]
    if math.isfinite(m.get("edge_error_max_elements", math.nan)):
        out.append(f"edge error: {m['edge_error_max']:.3g} of the zone width = "
                   f"{m['edge_error_max_elements']:.3g} element"
                   + (f" (edge estimator uncertainty up to {max(unc):.2g} element)"
                      if unc else ""))
    if math.isfinite(m.get("stick_edge_error_max_elements", math.nan)):
        out.append(f"stick-edge error: {m['stick_edge_error_max']:.3g} of the zone width = "
                   f"{m['stick_edge_error_max_elements']:.3g} element" + _worst_stick(res))
        out += _stick_unresolved(res)
    for metric, key, where in (("pressure_l2_error", "pressure_l2_top_share",
                                "pressure_l2_top_x"),
                               ("shear_l2_error", "shear_l2_top_share", None)):
        share = m.get(key, math.nan)
        if math.isfinite(share) and share > DOMINANT_SHARE:
            at = f" at x = {m[where]:.4g}" if where and math.isfinite(m.get(where, math.nan)) \
                else ""
            out.append(f"{metric}: one node{at} carries {share:.0%} of the squared error "
                       "(the value depends on where an edge falls between nodes)")
    return out


def _row_uncertainties(row: dict) -> list[float]:
    return [u for pair in row.get("stick_uncertainty_elements", ()) if pair for u in pair
            if math.isfinite(u)]


def _worst_stick(res: CaseResult) -> str:
    """Where the stick-edge error is largest, with the estimator's uncertainty there and its
    largest over the steps (a large uncertainty elsewhere says nothing of the worst step)."""
    rows = [r for r in res.samples if math.isfinite(r.get("stick_edge_error_max", math.nan))]
    if not rows:
        return ""
    worst = max(rows, key=lambda r: r["stick_edge_error_max"])
    here, every = _row_uncertainties(worst), [u for r in rows for u in _row_uncertainties(r)]
    unc = f"; estimator uncertainty there {max(here):.2g} element" if here else ""
    if every and max(every) > max(here or [0.0]):
        unc += f"{',' if here else '; estimator uncertainty'} up to {max(every):.2g}" + (
            "" if here else " element") + " over the steps"
    return f" (worst at stage {worst['stage']}, Q = {worst['Q']:.4g}{unc})"


def _stick_unresolved(res: CaseResult) -> list[str]:
    """A line when the stick check FAILs within the estimator's own uncertainty: every failing
    step's error is within its uncertainty of the tolerance (noisy data then FAIL or pass at
    random: 0.5 % noise FAILed a result that 1 % noise passed).  A pass is not flagged: on
    smooth stage-3 data the uncertainty is overstated (the distance to the frozen stage-2 edge,
    up to 21 elements where the error is 0.5)."""
    tol = next((c.tolerance for c in res.checks if c.name == "stick"), math.nan)
    failing = [(r, max(u)) for r in res.samples if (u := _row_uncertainties(r))
               and r.get("stick_edge_error_max", 0.0) > tol]
    if not failing or not all(r["stick_edge_error_max_elements"] - u <= _tol_elements(r, tol)
                              for r, u in failing):
        return []
    r, u = max(failing, key=lambda ru: ru[0]["stick_edge_error_max"])
    return [f"stick FAIL within the estimator's uncertainty: at stage {r['stage']}, Q = "
            f"{r['Q']:.4g} the error is {r['stick_edge_error_max_elements']:.2g} +- {u:.2g} "
            f"element against a tolerance of {_tol_elements(r, tol):.2g} element there (every "
            "failing step is within its uncertainty of the tolerance): the stick edge is not "
            "resolved either way at this noise and mesh"]


def _tol_elements(row: dict, tol: float) -> float:
    """The stick tolerance (fraction of the width) in elements at a sample's worse edge."""
    return tol * row["stick_edge_error_max_elements"] / row["stick_edge_error_max"]


def report_note(res: CaseResult) -> str:
    """One paragraph naming the verified result, the metrics it cannot give, the edge errors in
    elements and what was done to the input."""
    na = "; ".join(f"{k}: {v}" for k, v in res.unavailable.items())
    notes = " ".join(f"Note: {n}." for n in res.notes)
    meas = " ".join(f"{line[0].upper()}{line[1:]}." for line in measurement_lines(res))
    return (f"Verified result: {res.source}." + (f" Not available: {na}." if na else "")
            + (f" {meas}" if meas else "") + (f" {notes}" if notes else ""))


def write_verify_report(res: CaseResult, out_dir: str | Path, force: bool = False) -> dict:
    """Report pages of a verified external result (index.html, report.md, summary.json).

    The same pages as ``compare.report.write_report`` for one case, written through
    :func:`compare.fileio.owned_output` (``force``: see there); the page names the external code
    and lists the metrics that are not available.
    """
    from compare import report as rp
    from compare.fileio import owned_output, plan_output

    t0 = time.perf_counter()
    shown = replace(res, case=replace(res.case, description=report_note(res)))
    plan = plan_output(out_dir, "verify", force, expected=rp.REPORT_FILES)
    with owned_output(out_dir, "verify", force, plan) as tmp:
        (tmp / "figures").mkdir()
        sec = rp.CaseSection(shown, vtk_note=f"interface data only: {res.source}",
                             render_note="an external result has no body fields to render")
        rp._write_figs(sec, tmp)
        summary = rp._summary([sec], [], [], time.perf_counter() - t0)
        rp._write_documents(tmp, [sec], [], {}, False, summary)
    out = plan.out
    summary["index"] = str(out / "index.html")
    return summary
