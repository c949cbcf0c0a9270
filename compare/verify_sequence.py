"""Verify a mesh sequence: one code's results of one case at several resolutions (issue 25).

A single result against a fixed tolerance cannot say whether another code is *right*; the
standard answer of verification (Roache 1998; ASME V&V 20-2009) is the observed order of accuracy
over a mesh sequence and whether the error keeps falling.  :func:`verify_convergence` verifies
every result with :func:`compare.verify.verify` (the same readers, checks and metrics), takes the
node spacing ``h`` of each (the smallest interface node distance, ``FemHistory.h_min``) as the
resolution, and builds the study with :func:`compare.convergence.assemble`, so the honesty rules
are those of ``multicontact converge`` (one rule, not a second copy): local and least-squares
orders of the tracked errors, a *stall* when an error's local order over the last refinement is
below ``convergence.STALL_ORDER``, no "converges" on a stall, Richardson extrapolation of the
contact edges refused for non-monotone sequences and implausible orders.

Roache's grid convergence index of every contact edge (end of stage 1) where it applies:
``GCI = Fs |f1 - f2| / (r^p - 1)``, divided by the zone width (an edge location has no natural
relative scale), with f1, f2 the two finest edges, r the refinement ratio and p the order
estimated from the three finest results (Fs = 1.25) or, with two results, the expected order
(``convergence.EXPECTED_ORDERS``, Fs = 3).  It is refused with the reason wherever Richardson is
refused (``metrics.richardson_check``) and when the refinement ratio is not constant.  Beside it
the fine result's true edge error says whether the band covers the analytic edge, and with three
results ``GCI_23 / (r^p GCI_12)`` says whether the sequence is in the asymptotic range (~1).

The results need not have the same loads (a displacement-driven code reaches them only
approximately; each is compared with the analytic solution at its own loads), so every FE edge is
carried into the frame of the finest result's analytic solution before it is extrapolated:
``edge_i + (analytic_finest - analytic_i)``.
"""

from __future__ import annotations

import html
import json
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from compare import metrics as mt
from compare.cases import Case, load_case
from compare.convergence import EXPECTED_ORDERS, TRACKED, ConvergenceStudy, assemble, paired_edges
from compare.errors import CaseError
from compare.external import ExternalResult, read_result
from compare.fileio import owned_output, plan_output
from compare.run import CaseResult
from compare.verify import verify

#: Each result must be finer than the one before by at least this ratio of node spacings:
#: Celik et al. (J. Fluids Eng. 130, 2008, the journal's procedure after Roache) ask for r > 1.3;
#: closer resolutions make the observed order a quotient of two differences of noise.
MIN_REFINEMENT = 1.3
#: Richardson extrapolation and the GCI assume one refinement ratio r; the ratios h_i / h_i+1 of
#: a sequence may differ by this fraction (our own levels: exactly 2).
RATIO_RTOL = 0.05
#: Roache's safety factors: 1.25 when the order is observed on three or more grids, 3 when two
#: grids and the expected order are all there is.
GCI_SAFETY_OBSERVED = 1.25
GCI_SAFETY_ASSUMED = 3.0
SHORT = {"edge_error_max": "edge", "pressure_l2_error": "pressure L2",
         "stick_edge_error_max": "stick edge", "shear_l2_error": "shear L2"}


@dataclass(frozen=True)
class EdgeGCI:
    """Roache's grid convergence index of one contact edge (end of stage 1).

    edge: 'a1', 'b1', 'a2', ...; analytic: the edge of the finest result's analytic solution;
    fine: the finest result's FE edge; order: p used (observed from the three finest results,
    or the expected order with two); safety: Fs; gci: Fs |f1 - f2| / (r^p - 1) / zone width (nan
    where refused); error: |fine - analytic| / zone width; covered: error <= gci; asymptotic:
    GCI_23 / (r^p GCI_12) (~1 in the asymptotic range; nan with two results); reason: '' or why
    the GCI was refused.
    """

    edge: str
    analytic: float
    fine: float
    order: float
    safety: float
    gci: float
    error: float
    covered: bool
    asymptotic: float
    reason: str


@dataclass(frozen=True)
class SequenceVerification:
    """A code's results of one case at several resolutions, verified as a sequence.

    case_name; code (from the results' headers); sources (coarse to fine); h: node spacing of
    each result (case length units); ratios: refinement ratios h_i / h_i+1; study: the
    :class:`compare.convergence.ConvergenceStudy` of the tracked errors (values = h); gci: one
    :class:`EdgeGCI` per analytic contact edge; results: the verified results (CaseResult).
    """

    case_name: str
    code: str
    sources: tuple
    h: tuple
    ratios: tuple
    study: ConvergenceStudy
    gci: tuple
    results: tuple

    @property
    def converges(self) -> bool:
        return self.study.converges

    def verdict(self) -> str:
        """'converges at order p toward the analytic solution (...)', 'stalls at ...' or
        'does not converge: <why>' -- the rule of compare.convergence."""
        st = self.study
        if st.converges:
            others = ", ".join(f"{SHORT[m]} {st.orders[m]:.2f}" for m in TRACKED
                               if m != "pressure_l2_error" and math.isfinite(st.orders[m]))
            return (f"converges at order {st.orders['pressure_l2_error']:.2f} toward the "
                    f"analytic solution (pressure L2 error; {others})")
        why = st.failure()
        return why if why.startswith("stalls") else f"does not converge: {why}"

    def summary(self) -> dict:
        """JSON-ready: the verdict, the study, the GCI and each result's summary."""
        return {"case": self.case_name, "code": self.code, "sources": list(self.sources),
                "h": list(self.h), "refinement_ratios": list(self.ratios),
                "verdict": self.verdict(), "converges": self.converges,
                "study": self.study.summary(),
                "gci": [_json(vars(g)) for g in self.gci],
                "results": [r.summary() for r in self.results]}


def _json(d: dict) -> dict:
    return {k: None if isinstance(v, float) and not math.isfinite(v) else v for k, v in d.items()}


def verify_convergence(case: Case | str | Path,
                       results: Sequence[ExternalResult | str | Path],
                       samples: str = "steps", settings: dict | None = None
                       ) -> SequenceVerification:
    """Verify ``results`` (two or more results of ``case`` by one code at different resolutions,
    in any order) as a mesh sequence; ``samples`` and ``settings`` as in
    :func:`compare.verify.verify`.  Every result is read and the resolutions are checked
    before anything is solved; bad input raises :class:`CaseError`."""
    case = load_case(case)
    if len(results) < 2:
        raise CaseError(f"a mesh sequence needs at least two results, got {len(results)}")
    read = [r if isinstance(r, ExternalResult) else read_result(r, settings) for r in results]
    spacing = [r.history(case.mu, case.E, case.nu).h_min for r in read]
    order_ = np.argsort(spacing)[::-1]
    ratios = _ratios([read[k].source for k in order_], [spacing[k] for k in order_])
    runs = [verify(case, read[k], samples=samples) for k in order_]
    h = [float(r.fem.h_min) for r in runs]
    edges, zones = _framed_edges(runs)
    errors = {m: [float(r.metrics.get(m, math.nan)) for r in runs] for m in TRACKED}
    order = runs[-1].fem.order if runs[-1].fem.order in (1, 2) else 1
    ratio = _constant_ratio(ratios)
    study = assemble(case.name, "h", h, h, errors, edges, zones, order,
                     [sum(r.timings.values()) for r in runs], label="h =",
                     ratio=ratio if math.isfinite(ratio) else 2.0)
    if not math.isfinite(ratio):
        study = replace(study, richardson_edges=(math.nan,) * len(study.analytic_edges),
                        richardson_error=math.nan, richardson_reason=_ratio_reason(ratios))
    gci = tuple(_gci(np.asarray(edges, float), zones, ratio, ratios, order))
    return SequenceVerification(case.name, runs[-1].fem.backend, tuple(r.source for r in runs),
                                tuple(h), tuple(ratios), study, gci, tuple(runs))


def _ratios(sources: list[str], h: list[float]) -> list[float]:
    """Refinement ratios h_i / h_i+1 (coarse to fine), each >= MIN_REFINEMENT (else CaseError)."""
    ratios = [a / b for a, b in zip(h, h[1:], strict=False)]
    for k, r in enumerate(ratios):
        if not r >= MIN_REFINEMENT:
            raise CaseError(f"{sources[k]} (h = {h[k]:.6g}) and {sources[k + 1]} (h = "
                            f"{h[k + 1]:.6g}): refinement ratio {r:.3g}; a mesh sequence needs "
                            f"each result finer than the next coarser one by >= "
                            f"{MIN_REFINEMENT:g} in node spacing")
    return ratios


def _constant_ratio(ratios: list[float]) -> float:
    """The common refinement ratio, nan when the ratios differ by more than RATIO_RTOL."""
    lo, hi = min(ratios), max(ratios)
    return float(np.mean(ratios)) if hi <= lo * (1.0 + RATIO_RTOL) else math.nan


def _ratio_reason(ratios: list[float]) -> str:
    return (f"refinement ratios {', '.join(f'{r:.3g}' for r in ratios)} differ by more than "
            f"{RATIO_RTOL:.0%} (needs one ratio)")


def _framed_edges(runs: list[CaseResult]) -> tuple[list[list[float]], list]:
    """Per run the FE edges paired with the analytic ones, carried into the frame of the finest
    run's analytic solution; and that solution's zones."""
    zones = runs[-1].analytic.normal.zones
    ref = np.array([e for z in zones for e in z])
    out = []
    for r in runs:
        own = r.analytic.normal.zones
        if len(own) != len(zones):
            raise CaseError(f"{r.source}: {len(own)} analytic contact zone(s) at its loads, "
                            f"{len(zones)} at those of {runs[-1].source}; the results of a "
                            "sequence must be of the same case at the same loads")
        an = np.array([e for z in own for e in z])
        out.append(list(np.asarray(paired_edges(r)) + ref - an))
    return out, list(zones)


def grid_convergence_index(values: Sequence[float], ratio: float, scale: float,
                           expected_order: float) -> tuple[float, float, float, float, str]:
    """Roache's GCI of the finest of ``values`` (coarse to fine, refinement ratio ``ratio``),
    divided by ``scale``: ``(gci, p, Fs, asymptotic, reason)``.

    Three or more values: p observed from the three finest (:func:`metrics.richardson_check`,
    refused outside RICHARDSON_ORDERS or for a non-monotone sequence), Fs = 1.25 and
    ``asymptotic = GCI_23 / (r^p GCI_12)`` (1 for an exact power law); two values: p =
    ``expected_order``, Fs = 3, asymptotic nan.  Refused (gci nan, ``reason`` says why) where
    Richardson's extrapolation is; ``ratio`` nan (ratios not constant) is refused too.
    """
    f = np.asarray(values, float)
    three = f.size >= 3
    safety = GCI_SAFETY_OBSERVED if three else GCI_SAFETY_ASSUMED
    nan = math.nan
    if not math.isfinite(ratio):
        return nan, nan, safety, nan, "the refinement ratio is not constant"
    if three:
        _, p, reason = mt.richardson_check(f, ratio)
    else:
        p, reason = expected_order, mt.richardson_check(f, ratio, order=expected_order)[2]
    if reason:
        return nan, float(p), safety, nan, reason
    gci = safety * abs(f[-1] - f[-2]) / (ratio**p - 1.0) / scale
    asym = nan
    if three and gci > 0:
        asym = safety * abs(f[-2] - f[-3]) / (ratio**p - 1.0) / scale / (ratio**p * gci)
    return float(gci), float(p), safety, float(asym), ""


def _gci(edges: np.ndarray, zones: list, ratio: float, ratios: list[float], order: int
         ) -> list[EdgeGCI]:
    names = [f"{s}{k + 1}" for k in range(len(zones)) for s in "ab"]
    an = [e for z in zones for e in z]
    widths = np.repeat([b - a for a, b in zones], 2)
    expected = EXPECTED_ORDERS["edge_error_max"][order][0]
    out = []
    for j, name in enumerate(names):
        gci, p, safety, asym, reason = grid_convergence_index(edges[:, j], ratio, widths[j],
                                                              expected)
        if not math.isfinite(ratio):
            reason = _ratio_reason(ratios)
        err = abs(edges[-1, j] - an[j]) / widths[j]
        out.append(EdgeGCI(name, float(an[j]), float(edges[-1, j]), p, safety, gci,
                           float(err), bool(err <= gci), asym, reason))
    return out


# ---------------------------------------------------------------------------------------------
# text, figure, report
# ---------------------------------------------------------------------------------------------
def sequence_text(seq: SequenceVerification) -> str:
    """Plain text: verdict, the results (each with its single-result verdict on the named
    tolerances), errors with local and least-squares orders, GCI."""
    st = seq.study
    lines = [f"{seq.case_name}: {seq.code}, {len(seq.h)} results: {seq.verdict()}"]
    lines += [f"  result {k + 1}: {r.source} (h = {h:.4g}): " + (
              "agrees" if r.passed else "FAILS " + ", ".join(c.name for c in r.failures()))
              for k, (r, h) in enumerate(zip(seq.results, seq.h, strict=True))]
    lines.append(f"  {'h':<22} " + " ".join(f"{v:10.4g}" for v in seq.h))
    for m, vals in st.errors.items():
        if not np.any(np.isfinite(vals)):
            continue
        local = " ".join(f"{v:.2f}" for v in st.local_orders[m])
        lines.append(f"  {m:<22} " + " ".join(f"{v:10.3e}" for v in vals)
                     + f"   order {st.orders[m]:.2f} (local {local})")
    lines.append("  refinement ratios " + ", ".join(f"{r:.3g}" for r in seq.ratios))
    for g in seq.gci:
        if g.reason:
            lines.append(f"  GCI of edge {g.edge}: refused ({g.reason}); fine-result error "
                         f"{g.error:.3e} of the width")
        else:
            asym = f", GCI_23/(r^p GCI_12) {g.asymptotic:.2f}" if math.isfinite(g.asymptotic) \
                else ""
            lines.append(f"  GCI of edge {g.edge}: {g.gci:.3e} of the width (Fs {g.safety:g}, "
                         f"p {g.order:.2f}{asym}); fine-result error {g.error:.3e} "
                         f"({'inside' if g.covered else 'OUTSIDE'} the band)")
    rich = (f"{st.richardson_error:.3e}" if math.isfinite(st.richardson_error)
            else f"refused ({st.richardson_reason})")
    lines.append(f"  Richardson edge error / width: {rich}")
    return "\n".join(lines)


def sequence_figure(seq: SequenceVerification, reference: ConvergenceStudy | None = None
                    ) -> bytes:
    """One log-log panel per tracked error against h / (contact zone width): the sequence and,
    on the same axes, ``reference`` (our own FE's h-convergence study of the case)."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    from compare.report.figures import png

    width = min(b - a for a, b in seq.results[-1].analytic.normal.zones)
    fig, axes = plt.subplots(2, 2, figsize=(9, 6.5))
    runs = [(f"{seq.code} (verified sequence)", seq.h, seq.study, "o-")]
    if reference is not None:
        levels = ", ".join(f"{v:g}" for v in reference.values)
        runs.append((f"multicontact fem (levels {levels}; at the case's samples)",
                     reference.parameter, reference, "s--"))
    for ax, m in zip(axes.flat, TRACKED, strict=True):
        orders = []
        for name, h, st, style in runs:
            e, x = np.asarray(st.errors[m], float), np.asarray(h, float) / width
            ax.loglog(x, np.where(e > 0, e, np.nan), style, label=name)
            orders.append(f"{st.orders[m]:.2f}")
        ax.set(xlabel="h / contact zone width", ylabel="error")
        ax.set_title(f"{SHORT[m]}: order {' / '.join(orders)}", fontsize=9)
        ticks = np.asarray(seq.h) / width
        ax.set_xticks(ticks, [f"{t:.2g}" for t in ticks], fontsize=7)
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.grid(True, which="both", alpha=0.3)
    fig.legend(*axes.flat[0].get_legend_handles_labels(), loc="lower center", ncol=2,
               fontsize=8)
    fig.suptitle(f"{seq.case_name}: {seq.code}: {seq.verdict()}"[:150], fontsize=8)
    fig.tight_layout(rect=(0, 0.05, 1, 0.97))
    return png(fig)


def _html(seq: SequenceVerification, reference: ConvergenceStudy | None) -> str:
    from compare.report.html import fmt, page

    st = seq.study
    rows = "".join(f"<tr><td class='l'>{m}</td>" + "".join(f"<td>{fmt(v)}</td>" for v in vals)
                   + f"<td>{fmt(st.orders[m])}</td><td>{fmt(st.local_orders[m][-1])}</td>"
                   f"<td>{fmt(st.expected[m][0])}</td></tr>" for m, vals in st.errors.items())
    gci = "".join(f"<tr><td>{g.edge}</td><td>{fmt(g.gci)}</td><td>{fmt(g.error)}</td>"
                  f"<td>{'yes' if g.covered else 'no'}</td><td>{fmt(g.asymptotic)}</td>"
                  f"<td class='l'>{html.escape(g.reason)}</td></tr>" for g in seq.gci)
    srcs = "".join(f"<li>{html.escape(s)} (h = {fmt(h)})</li>"
                   for s, h in zip(seq.sources, seq.h, strict=True))
    ours = (f"<p>Our own FE (multicontact fem, levels "
            f"{', '.join(str(v) for v in reference.values)}): "
            f"{html.escape(reference.verdict())}. Its stick-edge and shear errors are taken at "
            "the case's sampled Q; the sequence's at the samples verify was given (every "
            "stage-2/3 step by default, a stricter set: the same FE then shows larger errors): "
            "give <code>--samples case</code> to compare like with like.</p>"
            if reference else "")
    body = (f"<h1>{html.escape(seq.case_name)}: mesh sequence of {html.escape(seq.code)}</h1>"
            f"<p><b>{html.escape(seq.verdict())}</b></p><ol>{srcs}</ol>"
            f"<table><tr><th class='l'>metric \\ h</th>"
            + "".join(f"<th>{fmt(h)}</th>" for h in seq.h)
            + f"<th>order</th><th>last order</th><th>expected</th></tr>{rows}</table>"
            "<h2>Grid convergence index of the contact edges (Roache)</h2>"
            "<table><tr><th>edge</th><th>GCI / width</th><th>fine error / width</th>"
            f"<th>covered</th><th>GCI_23/(r^p GCI_12)</th><th>refused</th></tr>{gci}</table>"
            f"{ours}<img src='figures/convergence.png' alt='convergence'>")
    return page(f"{seq.case_name}: mesh sequence", body, links=False)


#: The files a sequence report writes (a foreign file of these names is never overwritten).
SEQUENCE_FILES = ("index.html", "report.md", "summary.json")


def write_sequence_report(seq: SequenceVerification, out_dir: str | Path,
                          reference: ConvergenceStudy | None = None,
                          force: bool = False) -> dict:
    """index.html, report.md, summary.json and figures/convergence.png of a sequence (with
    ``reference``, our own FE's study, on the same axes), written through
    :func:`compare.fileio.owned_output` (``force``: see there).  Returns the summary with its
    'index'."""
    t0 = time.perf_counter()
    plan = plan_output(out_dir, "verify", force, expected=SEQUENCE_FILES)
    summary = seq.summary() | {"reference": reference.summary() if reference else None}
    with owned_output(out_dir, "verify", force, plan) as tmp:
        (tmp / "figures").mkdir()
        (tmp / "figures" / "convergence.png").write_bytes(sequence_figure(seq, reference))
        (tmp / "index.html").write_text(_html(seq, reference), encoding="utf-8")
        (tmp / "report.md").write_text(f"# {seq.case_name}: mesh sequence of {seq.code}\n\n"
                                       f"```\n{sequence_text(seq)}\n```\n\n"
                                       "![convergence](figures/convergence.png)\n",
                                       encoding="utf-8")
        summary["elapsed_seconds"] = time.perf_counter() - t0
        (tmp / "summary.json").write_text(json.dumps(_clean(summary), indent=1),
                                          encoding="utf-8")
    return summary | {"index": str(plan.out / "index.html")}


def _clean(obj):
    from compare.report import clean_json

    return clean_json(obj)
