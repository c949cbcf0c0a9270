"""HTML and Markdown fragments of the report (figures embedded as base64 PNG in HTML)."""

from __future__ import annotations

import base64
import html
import math

from compare.report.fig5 import FE_EXTENT_ELEMENTS, fe_deviation
from fem.linsolve import BACKENDS

CSS = """
body{font-family:system-ui,Arial,sans-serif;margin:24px auto;max-width:1150px;color:#222}
table{border-collapse:collapse;margin:8px 0 16px}td,th{border:1px solid #bbb;padding:3px 8px;
font-size:13px;text-align:right}th{background:#eee}td.l,th.l{text-align:left}
.pass{color:#176117;font-weight:600}.FAIL{color:#b00000;font-weight:700}.na{color:#777}
img{max-width:100%;border:1px solid #ddd;margin:6px 0}.note{color:#8a5a00}
h2{border-bottom:2px solid #ccc;padding-bottom:3px;margin-top:36px}
.head{background:#f4f4f4;border-left:4px solid #999;padding:6px 10px;font-size:14px}
.loud{background:#fff3cd;border:2px solid #b07d00;padding:8px 12px;font-weight:600}
"""

#: Element names by order.
ELEMENTS = {1: "Q4 (linear)", 2: "Q9 (quadratic)"}
#: The fast sparse backend; any other of ours is announced loudly (an external code's result
#: names that code as its backend: nothing to announce).
FAST_BACKEND = "cholmod"
SLOW_BACKENDS = set(BACKENDS) - {FAST_BACKEND}
#: CaseResult.source of our own FE (an external result names its code and files).
OWN_FE = "multicontact fem"


def img(data: bytes, alt: str, cls: str = "") -> str:
    b64 = base64.b64encode(data).decode("ascii")
    klass = f' class="{cls}"' if cls else ""
    return f'<img alt="{html.escape(alt)}"{klass} src="data:image/png;base64,{b64}">'


def fmt(v) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "n/a"
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def page(title: str, body: str, links: bool = True) -> str:
    nav = ('<p><a href="report.md">report.md</a> &middot; <a href="summary.json">summary.json'
           "</a></p>") if links else '<p><a href="index.html">back to the report</a></p>'
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}"
            f"</title><style>{CSS}</style></head><body><h1>{html.escape(title)}</h1>{nav}"
            f"{body}</body></html>\n")


def _status(st: str) -> str:
    cls = {"pass": "pass", "FAIL": "FAIL"}.get(st, "na")
    return f'<td class="{cls}">{st}</td>'


def worst_check(checks) -> tuple | None:
    """The check closest to (or furthest past) its tolerance: ``(check, value / tolerance)``.

    Exact checks (tolerance 0) count as 0 when met and inf when not; n/a checks are skipped.
    None when every check is n/a.
    """
    rated = []
    for c in checks:
        if math.isnan(c.value):
            continue
        ratio = c.value / c.tolerance if c.tolerance > 0 else (math.inf if c.value > 0 else 0.0)
        rated.append((ratio, c.name, c))
    if not rated:
        return None
    ratio, _, check = max(rated, key=lambda r: (r[0], r[1]))
    return check, ratio


def verdict_text(res) -> str:
    """'agrees' / 'FAILS' with the worst metric relative to its tolerance."""
    word = "agrees" if res.passed else "FAILS"
    worst = worst_check(res.checks)
    if worst is None:
        return f"{word} (every check n/a)"
    c, ratio = worst
    rel = "not met" if math.isinf(ratio) else f"{100 * ratio:.0f} % of its tolerance"
    return f"{word}; worst: {c.metric} = {fmt(c.value)} ({rel} {fmt(c.tolerance)})"


def backend_notice(sections) -> str:
    """A loud line when a case ran without the fast sparse backend (else empty)."""
    slow = sorted({s.result.fem.backend for s in sections if is_own_fe(s.result.source)}
                  & SLOW_BACKENDS)
    if not slow:
        return ""
    return (f'<p class="loud">Sparse backend: {", ".join(slow)}. CHOLMOD (scikit-sparse) is '
            "not available, so the FE model ran on a slower solver (2.5-4x); the numbers are "
            "the same. Install python3-dev and libsuitesparse-dev and run make again.</p>")


def is_own_fe(source: str) -> bool:
    """Whether a result is our own FE run (else an external code's, ``compare.verify``)."""
    return source == OWN_FE


def fe_text(res, bold: str = "**", sep: str = ", ", esc=str) -> str:
    """'Backend **B**, N DOFs, Q4 (linear), level L' of our FE; 'Code **C**, N DOFs, element
    order k' of an external result, 'not given' where its header gives no DOF count or order
    (``bold``: the markup around the name; ``sep`` between the items; ``esc`` for the name)."""
    fe = res.fem
    end = bold.replace("<", "</") if bold.startswith("<") else bold
    name = esc(fe.backend)
    if is_own_fe(res.source):
        element = ELEMENTS.get(fe.order, f"order {fe.order}")
        if fe.order == 1 and res.case.fem.incompatible:
            element += " with incompatible modes"
        return sep.join((f"Backend {bold}{name}{end}", f"{fe.n_dofs} DOFs",
                         f"{element}, level {res.case.fem.level}"))
    dofs = f"{fe.n_dofs} DOFs" if fe.n_dofs > 0 else "DOFs not given"
    order = f"element order {fe.order}" if fe.order > 0 else "element order not given"
    return sep.join((f"Code {bold}{name}{end}", dofs, order))


def case_head(sec) -> str:
    """Top line of a case: backend, DOFs, elements, verdict with the worst metric, run time."""
    res, fe = sec.result, sec.result.fem
    t = res.timings
    head = fe_text(res, "<b>", " &middot; ", html.escape)
    return (f'<p class="head">{head[0].lower()}{head[1:]}, h = {fe.h_min:.3g} &middot; '
            f'<span class="{"pass" if res.passed else "FAIL"}">'
            f"{html.escape(verdict_text(res))}</span> &middot; run time "
            f"{sum(t.values()):.1f} s ({', '.join(f'{k} {v:.1f}' for k, v in t.items())}) "
            f"+ report {sec.seconds:.1f} s</p>")


def index_body(sections, summary: dict) -> str:
    rows = "".join(
        f'<tr><td class="l"><a href="#{s.result.case.name}">{s.result.case.name}</a></td>'
        f'{_status("pass" if s.result.passed else "FAIL")}'
        f"<td>{fmt(s.result.metrics['edge_error_max'])}</td>"
        f"<td>{fmt(s.result.metrics['stick_edge_error_max'])}</td>"
        f"<td>{fmt(s.result.metrics['pressure_l2_error'])}</td>"
        f"<td>{fmt(s.result.metrics['shear_l2_error'])}</td>"
        f"<td>{_worst_cell(s.result)}</td><td class='l'>{html.escape(s.result.fem.backend)}</td>"
        f"<td>{sum(s.result.timings.values()):.1f}</td></tr>" for s in sections)
    n = len(sections)
    verdict = ("some cases FAIL their tolerances" if not summary["passed"] else
               f"all {n} cases agree with their tolerances" if n > 1 else
               "the case agrees with its tolerances")
    na = any(math.isnan(s.result.metrics.get(m, math.nan)) for s in sections
             for m in ("stick_edge_error_max", "shear_l2_error"))
    return (f"{backend_notice(sections)}<p><b>{verdict}</b> (elapsed "
            f"{summary['elapsed_seconds']:.0f} s)</p>"
            "<table><tr><th class='l'>case</th><th>verdict</th><th>edge err</th>"
            "<th>stick edge err</th><th>pressure L2</th><th>shear L2</th>"
            "<th>worst / tolerance</th><th class='l'>backend</th><th>time (s)</th></tr>"
            f"{rows}</table><p class='na'>"
            + ("n/a: the metric does not apply to the case (stick and shear without tangential "
               "load). " if na else "")
            + "Errors are relative: edges to the zone width, L2 errors to the analytic norm.</p>")


def _worst_cell(res) -> str:
    worst = worst_check(res.checks)
    return "n/a" if worst is None else f"{fmt(worst[1])} ({worst[0].name})"


def _checks_table(res) -> str:
    """The checks with a value; those the case does not have (n/a) are named under it."""
    rows = "".join(f'<tr><td class="l">{c.name}</td><td class="l">{c.metric}</td>'
                   f"<td>{fmt(c.value)}</td><td>{fmt(c.tolerance)}</td>{_status(c.status)}</tr>"
                   for c in res.checks if c.status != "n/a")
    na = [c.name for c in res.checks if c.status == "n/a"]
    note = (f'<p class="na">Not applicable to this case (no value): {", ".join(na)}.</p>'
            if na else "")
    return ("<table><tr><th class='l'>check</th><th class='l'>metric</th><th>value</th>"
            f"<th>tolerance</th><th>status</th></tr>{rows}</table>{note}")


def _zones_table(res) -> str:
    rows = "".join(
        f"<tr><td>{z['zone']}</td><td>{fmt(z['analytic'][0])}, {fmt(z['analytic'][1])}</td>"
        f"<td>{'none' if z['fem'] is None else fmt(z['fem'][0]) + ', ' + fmt(z['fem'][1])}</td>"
        f"<td>{fmt(max(z['edge_error_rel']))}</td><td>{fmt(z['load_share_analytic'])}</td>"
        f"<td>{fmt(z['load_share_fem'])}</td></tr>" for z in res.zones)
    return ("<table><tr><th>zone</th><th>analytic [a, b]</th><th>FE [a, b]</th>"
            "<th>edge err / width</th><th>load share (an)</th><th>load share (FE)</th></tr>"
            f"{rows}</table>")


def case_html(sec) -> str:
    res = sec.result
    c = res.case
    out = [f'<h2 id="{c.name}">{html.escape(c.name)} &mdash; '
           f'<span class="{"pass" if res.passed else "FAIL"}">'
           f'{"agrees" if res.passed else "FAILS"}</span></h2>', case_head(sec),
           f"<p>{html.escape(c.description)}</p>",
           f"<p>P = {c.P:g}, Q0 = {c.Q0:g}, mu = {c.mu:g}"
           + ("" if c.M is None else f", M = {fmt(c.M)}") + f", E = {c.E:g}, nu = {c.nu:g}</p>",
           _checks_table(res), _zones_table(res)]
    out += [f"<h3>{html.escape(t)}</h3>{img(d, t)}" for t, d in sec.figures.items()]
    out.append("<h3>von Mises stress around each contact zone (pyvista, deformed at true "
               "scale)</h3>")
    out.append(f"<p>{img(sec.render_png, 'pyvista picture')}</p>" if sec.render_png
               else f'<p class="note">{html.escape(sec.render_note)}</p>')
    out.append(f'<p>VTK series: <a href="{sec.vtk_link}">{sec.vtk_link}</a> (open in ParaView '
               "or pyvista)</p>" if sec.vtk_link else
               f'<p class="note">{html.escape(sec.vtk_note)}</p>')
    return "".join(out)


def _conv_lines(st) -> list[str]:
    """The verdict and the study's second line, in the words of ``multicontact converge``."""
    shift = f"FE edges move by {st.edge_shift:.3e} of the zone width over the runs"
    return [st.verdict(), st.richardson_line() or shift]


def convergence_html(st, png: bytes) -> str:
    shown = [m for m in st.errors if st.applies(m)]
    rows = "".join(f"<tr><td class='l'>{m}</td>" + "".join(f"<td>{fmt(v)}</td>"
                                                         for v in st.errors[m])
                   + f"<td>{fmt(st.orders[m])}</td><td>{fmt(st.local_orders[m][-1])}</td>"
                   f"<td>{fmt(st.expected.get(m, (None,))[0])}</td></tr>" for m in shown)
    head = "".join(f"<th>{fmt(v)}</th>" for v in st.values)
    why = "".join(f"<li>{m}: ~{o:g} ({html.escape(r)})</li>"
                  for m, (o, r) in st.expected.items() if m in shown)
    verdict, second = _conv_lines(st)
    cls = "pass" if st.converges else "FAIL"
    return (f'<h2 id="conv-{st.case_name}">convergence: {st.case_name} ({st.kind})</h2>'
            f'<p><b class="{cls}">{html.escape(verdict)}</b>.<br>{html.escape(second)}.</p>'
            f"<table><tr><th class='l'>metric \\ level</th>"
            f"{head}<th>order</th><th>last order</th><th>expected</th></tr>{rows}</table>"
            f"<ul>{why}</ul>{img(png, 'convergence')}")


def fig5_verdict(rows: list[dict]) -> str:
    """One line judging the FE points of the Fig. 5 study against FE_EXTENT_ELEMENTS."""
    devs = [(d, r["label"]) for r in rows if (d := fe_deviation(r)) is not None]
    if not devs:
        return "no FE points"
    worst, label = max(devs, key=lambda dl: dl[0]["elements"])
    ok = all(d["passed"] for d, _ in devs)
    word = "agree with" if ok else "DEVIATE from"
    return (f"FE extents {word} the analytic ones within {FE_EXTENT_ELEMENTS:g} finest element "
            f"length h (worst: pair ({label}), |FE - actual| = {worst['elements']:.2f} h)")


FIG5_EXPLAINED = (
    "The FE extent is judged in finest element lengths h, not relative to the extent: the FE "
    "points of one angle pair come from one load history on one mesh, graded for the zone at "
    "the largest load, and each FE edge lies within a fraction of an element of the analytic "
    "one. The relative deviation is therefore about h / extent and largest at the smallest "
    "load, where the zone spans only a few elements (the column 'zone / h'); it falls with the "
    "mesh level (pair (a) at the smallest load: 11 % at level 2, 3.2 % at level 3). The "
    "fig5_sweep sweep meshes every load for its own zone and gets 0.05-0.07 % at level 2 "
    "(docs/sweeps.md).")


def study_html(rows: list[dict], png: bytes) -> str:
    def cells(r):
        d = fe_deviation(r)
        if d is None:
            return "<td>n/a</td>" * 5
        return (f"<td>{d['elements']:.2f}</td>{_status('pass' if d['passed'] else 'FAIL')}"
                f"<td>{100 * d['rel']:.1f}</td><td>{d['PAc']:.3g}</td><td>{d['across']:.1f}</td>")

    ok = all((d := fe_deviation(r)) is None or d["passed"] for r in rows)
    tab = "".join(
        f"<tr><td>({r['label']})</td><td>{r['phi1']}</td><td>{r['phi2']}</td>"
        f"<td>{fmt(r['kappa'][-1])}</td><td>{fmt(r['Pe'][-1])}</td>{cells(r)}</tr>" for r in rows)
    return ("<p>Symmetric double wedge (paper Fig. 4): width of the right contact zone from the "
            "consistency conditions (actual), from free interpenetration (overlapped) and from "
            "the FE model at the stage-1 increments of one history per angle pair; loads as "
            "P A / c (the scale of the fig5_sweep sweep report).</p>"
            f'<p class="{"pass" if ok else "FAIL"}">{html.escape(fig5_verdict(rows))}</p>'
            "<table><tr><th>pair</th><th>phi1</th><th>phi2</th><th>kappa (max)</th>"
            "<th>Pe at max load (%)</th><th>max |FE - actual| / h</th><th>within 1 h</th>"
            "<th>max |FE - actual| / actual (%)</th><th>at P A / c</th><th>zone / h there</th>"
            f"</tr>{tab}</table><p>{html.escape(FIG5_EXPLAINED)}</p>{img(png, 'paper Fig. 5')}")


def fig5_index_html(rows: list[dict]) -> str:
    """The Fig. 5 section of the index: its own verdict (not part of the cases' one) and the
    link to the study page."""
    ok = all(d is None or d["passed"] for d in map(fe_deviation, rows))
    return ('<h2 id="fig5">Study: paper Fig. 5</h2>'
            f'<p class="{"pass" if ok else "FAIL"}">{html.escape(fig5_verdict(rows))}</p>'
            '<p><a href="study_fig5.html">Actual vs overlapped extent of the double wedge '
            "(study page)</a></p>")


# ---------------------------------------------------------------------------------------------
# Markdown
# ---------------------------------------------------------------------------------------------
def md_document(summary: dict) -> str:
    slow = sorted({c["fem"]["backend"] for c in summary["cases"]
                   if is_own_fe(c.get("source", OWN_FE))} & SLOW_BACKENDS)
    loud = ([f"**Sparse backend: {', '.join(slow)}. CHOLMOD (scikit-sparse) is not available: "
             "the FE model ran on a slower solver (2.5-4x); the numbers are the same.**\n"]
            if slow else [])
    lines = ["# multicontact verification report\n", *loud,
             f"Verdict: **{'all cases agree' if summary['passed'] else 'some cases FAIL'}** "
             f"(elapsed {summary['elapsed_seconds']:.0f} s). HTML: index.html; data: "
             "summary.json.\n", "| case | verdict |", "|---|---|"]
    lines += [f"| {c['case']['name']} | {'pass' if c['passed'] else 'FAIL'} |"
              for c in summary["cases"]]
    return "\n".join(lines) + "\n"


def case_md(sec) -> str:
    res = sec.result
    tm = res.timings
    lines = [f"\n## {res.case.name}: {'agrees' if res.passed else 'FAILS'}\n",
             f"{fe_text(res)}; "
             f"{verdict_text(res)}; run time {sum(tm.values()):.1f} s + report "
             f"{sec.seconds:.1f} s.\n",
             res.case.description + "\n", "| check | metric | value | tolerance | status |",
             "|---|---|---|---|---|"]
    lines += [f"| {c.name} | {c.metric} | {fmt(c.value)} | {fmt(c.tolerance)} | {c.status} |"
              for c in res.checks if c.status != "n/a"]
    na = [c.name for c in res.checks if c.status == "n/a"]
    lines.append(f"\nNot applicable to this case (no value): {', '.join(na)}.\n" if na else "")
    lines += [f"![{t}](figures/{res.case.name}_{i}.png)" for i, t in enumerate(sec.figures)]
    lines.append(f"\n![von Mises stress around each contact zone]({sec.render})" if sec.render else
                 f"\n_{sec.render_note}_")
    lines.append(f"\nVTK series: [{sec.vtk_link}]({sec.vtk_link})" if sec.vtk_link else
                 f"\n_{sec.vtk_note}_")
    return "\n".join(lines) + "\n"


def convergence_md(st) -> str:
    shown = [m for m in st.errors if st.applies(m)]
    verdict, second = _conv_lines(st)
    lines = [f"\n## convergence: {st.case_name} ({st.kind})\n",
             f"**{verdict}**. {second}.\n",
             "| metric | " + " | ".join(fmt(v) for v in st.values)
             + " | order | last order | expected |",
             "|---|" + "---|" * (len(st.values) + 3)]
    lines += [f"| {m} | " + " | ".join(fmt(v) for v in st.errors[m]) + f" | {fmt(st.orders[m])} | "
              f"{fmt(st.local_orders[m][-1])} | {fmt(st.expected.get(m, (None,))[0])} |"
              for m in shown]
    lines += [f"\n- expected {m}: ~{o:g} ({r})" for m, (o, r) in st.expected.items() if m in shown]
    lines.append(f"\n![convergence](figures/{st.case_name}_convergence.png)")
    return "\n".join(lines) + "\n"
