"""Verification report: ``DIR/index.html`` (self-contained), ``DIR/report.md`` and
``DIR/summary.json``.

Per case: a header line (sparse backend, DOFs, elements, the verdict with the worst metric
relative to its tolerance, run time), the metrics table with pass/fail, matplotlib figures with
one column per contact zone, zoomed to it, x horizontal (pressure and shear with FE - analytic
under each, sigma_xx around each zone with the interface status, surface sxx, subsurface
maximum shear, the stick-slip map over the cycle with the Ruiz parameter), a pyvista off-screen
picture of each zone's surroundings coloured by von Mises stress, and links to the VTK series
(``DIR/vtk/<case>/history.pvd``).  A case run without CHOLMOD is announced at the
top.  Optional convergence studies (log-log plots with observed orders) and the paper's Fig. 5
study page (``DIR/study_fig5.html``).  ``DIR`` is written through
:func:`compare.fileio.owned_output`: a folder holding files multicontact did not write is refused
(``force``: written beside them, they are kept), the report is made in a temporary folder next
to ``DIR`` and swapped in at the end, so a failed or interrupted run leaves the previous report
as it was.  The VTK series hold the interface at the last step of each stage and the bodies
under the largest load, the pictured step (``vtk="all"``: every step; ``fem.write_vtk``).  The
cases, the convergence studies and the Fig. 5 study run in REPORT_WORKERS forked processes, the
pyvista pictures in one child process at the end.  ``write_report`` is ``plan_report`` (every
check, before anything is computed) then ``build_report``; the CLI announces the run between
the two.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path

from compare._forkserver import forkserver_context, ignore_interrupts, kill_pool
from compare.case_format import check_name
from compare.cases import Case, case_from_dict, check_unique_names, load_case
from compare.convergence import ConvergenceStudy, convergence
from compare.errors import CaseError
from compare.fileio import OutputPlan, child, owned_output, plan_output
from compare.report import figures, region, zones
from compare.report.fig5 import fig5_rows
from compare.report.html import case_html, case_md, page, study_html, verdict_text
from compare.report.render3d import render_many
from compare.report.stress import stress_figures
from compare.run import CaseResult, run_case

#: The default suite of ``make run`` (each at its library FE level): ~48 s on 2 cores, 67 s of
#: CPU (sequential profile before the figure caches: FE 21 s, stress metrics 20 s, figures 30 s,
#: VTK and pictures 13 s, Fig. 5 study 6 s).
DEFAULT_SUITE = ("hertz", "cattaneo", "double_wedge_a", "two_cylinders_unequal",
                 "punch_and_cylinder", "applied_moment")
#: Levels of the report's convergence studies (``report --levels``).
DEFAULT_STUDY_LEVELS = (-1, 0, 1)
#: Default convergence study of the report: Hertz under uniform h-refinement.
DEFAULT_CONVERGENCE = {"hertz": DEFAULT_STUDY_LEVELS}

Progress = Callable[[str], None]
#: Which FE steps the report's VTK series hold (``fem.write_vtk``): "ends", the interface at the
#: end of each stage and the bodies under the largest load (default: what a person opens; 9.3 MB
#: of the default suite's 14.3 MB report, where bodies and interface at every stage end and
#: sampled Q in double precision took 138 MB of 143), or "all", every step.
VTK_STEPS = ("ends", "all")  # fem.vtk.VTK_STEPS
#: Files (and, ending in '/', folders) every report writes: a file or link of one of these
#: names that multicontact did not write refuses ``force`` before anything is computed.
REPORT_FILES = ("index.html", "report.md", "summary.json", "figures/")


@dataclass
class CaseSection:
    """What the report shows for one case."""

    result: CaseResult
    figures: dict = field(default_factory=dict)   # title -> png bytes
    render: str = ""                              # relative path of the pyvista picture
    render_png: bytes = b""
    render_note: str = ""
    vtk_link: str = ""
    vtk_note: str = ""
    seconds: float = 0.0                          # figures, VTK and picture of this case


def _write_figs(sec: CaseSection, root: Path) -> None:
    res = sec.result
    made = {"pressure (stage 1 end), per zone": zones.pressure_figure(res),
            "shear (stages 2 and 3), per zone": zones.shear_figure(res),
            "contact region: sigma_xx and interface status": region.region_figure(res)}
    made.update(stress_figures(res))
    sec.figures = {k: v for k, v in made.items() if v is not None}
    fig_dir = root / "figures"
    fig_dir.mkdir(exist_ok=True)
    for i, data in enumerate(sec.figures.values()):
        child(fig_dir, res.case.name, f"_{i}.png").write_bytes(data)


def _write_vtk(sec: CaseSection, root: Path, vtk: str = "ends") -> tuple | None:
    """The case's VTK series; returns the render job (vtu, png, region) of its pyvista
    picture, or None with the reason noted."""
    import fem

    res = sec.result
    out = child(root / "vtk", res.case.name)
    try:
        pvd = fem.write_vtk(res.fem, out, steps=vtk)
    except Exception as exc:  # noqa: BLE001 - any writer failure is reported, not fatal
        sec.vtk_note = f"VTK series not written: {type(exc).__name__}: {exc}"
        sec.render_note = "no pyvista picture: the VTK series is missing"
        return None
    sec.vtk_link = Path(pvd).relative_to(root).as_posix()
    vtu = out / f"bodies_{region.region_step(res).index:04d}.vtu"
    if not vtu.is_file():
        sec.render_note = f"no pyvista picture: {vtu.name} not found in the VTK series"
        return None
    return vtu, child(root / "figures", res.case.name, "_bodies.png"), region.region_boxes(res)


def _render(sections: list[CaseSection], jobs: list, root: Path) -> None:
    """All pyvista pictures in one child process (render3d.render_many)."""
    todo = [(sec, job) for sec, job in zip(sections, jobs, strict=True) if job is not None]
    t0 = time.perf_counter()
    done = render_many([job for _, job in todo])
    share = (time.perf_counter() - t0) / max(len(todo), 1)  # one child renders them all
    for (sec, (_, png, _)), (ok, why) in zip(todo, done, strict=True):
        sec.render, sec.render_note = (png.relative_to(root).as_posix(), "") if ok else ("", why)
        sec.render_png = png.read_bytes() if ok else b""
        sec.seconds += share


def _summary(sections: list[CaseSection], studies: list[ConvergenceStudy], fig5: list[dict],
             elapsed: float) -> dict:
    cases = []
    for s in sections:
        d = s.result.summary()
        d.update(render=s.render, render_note=s.render_note, vtk_link=s.vtk_link,
                 vtk_note=s.vtk_note, verdict=verdict_text(s.result), report_seconds=s.seconds)
        cases.append(d)
    return {"passed": all(s.result.passed for s in sections), "cases": cases,
            "convergence": [st.summary() for st in studies], "fig5": fig5,
            "elapsed_seconds": elapsed}


@dataclass(frozen=True)
class ReportPlan:
    """A report checked before anything is computed (:func:`plan_report`): its loaded cases,
    its convergence studies (name -> (case, levels)), whether it has the Fig. 5 study, the VTK
    steps and the checked output folder."""

    cases: list
    studies: dict
    fig5: bool
    vtk: str
    output: OutputPlan


def plan_report(cases: Sequence[str | Path | Case] = DEFAULT_SUITE,
                out_dir: str | Path = "report", convergence_cases: dict | None = None,
                fig5: bool = True, vtk: str = "ends", force: bool = False) -> ReportPlan:
    """Load (and validate) the cases and studies, check their names (each its own, one file
    name: they name the figures and VTK folders) and ``out_dir``
    (:func:`compare.fileio.plan_output`, with the files and folders the report writes): bad
    input raises :class:`compare.errors.CaseError` before anything is computed or written.
    Arguments as :func:`write_report`."""
    if vtk not in VTK_STEPS:
        raise CaseError(f"vtk = {vtk!r}: allowed {', '.join(VTK_STEPS)}")
    loaded = [load_case(c) for c in cases]
    conv = DEFAULT_CONVERGENCE if convergence_cases is None else convergence_cases
    studies = {name: (load_case(name), levels) for name, levels in conv.items()}
    studied = [c for c, _ in studies.values()]
    _check_names(loaded, studied)
    out = plan_output(out_dir, "report", force, expected=_expected(loaded, studied, fig5))
    return ReportPlan(loaded, studies, fig5, vtk, out)


def write_report(cases: Sequence[str | Path | Case] = DEFAULT_SUITE, out_dir: str | Path = "report",
                 convergence_cases: dict | None = None, fig5: bool = True,
                 progress: Progress | None = None, vtk: str = "ends", force: bool = False
                 ) -> dict:
    """Run ``cases`` and write the report into ``out_dir``; returns the summary dict.

    Everything is checked first (:func:`plan_report`): bad input raises
    :class:`compare.errors.CaseError` and nothing is written.  ``convergence_cases`` maps case
    names to level tuples (default :data:`DEFAULT_CONVERGENCE`; ``{}`` for none).
    ``progress`` receives a short message after each unit of work.  ``vtk``: one of
    :data:`VTK_STEPS`; ``force``: write beside files the report did not write in ``out_dir`` (a
    user's, another command's output: they are kept, never deleted or overwritten).
    """
    plan = plan_report(cases, out_dir, convergence_cases, fig5, vtk, force)
    return build_report(plan, progress)


def build_report(plan: ReportPlan, progress: Progress | None = None) -> dict:
    """Run a planned report (:func:`plan_report`) and write it; returns the summary dict."""
    t0 = time.perf_counter()
    with owned_output(plan.output.out, "report", plan.output.force, plan.output) as tmp:
        summary = _build(plan.cases, plan.studies, plan.fig5, tmp,
                         progress or (lambda msg: None), t0, vtk=plan.vtk)
    summary["index"] = str(plan.output.out / "index.html")
    return summary


def _check_names(cases: list[Case], studied: list[Case]) -> None:
    """CaseError unless every case and every studied case has its own name, one plain file
    name (:func:`compare.case_format.check_name`): the names name the figures and VTK
    folders."""
    check_unique_names(cases, "report sections, figures and VTK series")
    check_unique_names(studied, "convergence figures")
    for case in cases + studied:
        check_name(case.name, case.source or "given")


def _expected(cases: list[Case], studied: list[Case], fig5: bool) -> tuple[str, ...]:
    """Files and folders (ending in '/') the report will write that are known before anything
    is computed, checked against the files already in its folder then (a case's numbered and
    body figures are checked when the report is put in place)."""
    names = [*REPORT_FILES, "vtk/", *(f"vtk/{c.name}/" for c in cases)]
    names += [f"figures/{c.name}_convergence.png" for c in studied]
    return tuple(names + (["study_fig5.html", "figures/fig5.png"] if fig5 else []))


#: Worker processes of a report (each case, the convergence studies and the Fig. 5 study are
#: independent units of work; 2 cores: the report takes ~0.7 of its sequential time).
REPORT_WORKERS = 2


def _case_unit(case: Case, root: Path, vtk: str = "ends") -> tuple[CaseSection, tuple | None]:
    """One case: run, figures, VTK series; the section without what cannot cross a process
    boundary (the case and the analytic solution hold profile closures, the FE fields a sparse
    factor): the caller puts the case back; figures and VTK files are already made."""
    sec = CaseSection(run_case(case))
    t_case = time.perf_counter()
    _write_figs(sec, root)
    job = _write_vtk(sec, root, vtk)
    sec.seconds = time.perf_counter() - t_case
    res = sec.result
    sec.result = replace(res, case=None, analytic=None, fem=replace(res.fem, fields=None))
    return sec, job


def _convergence_unit(case: Case, levels: tuple, root: Path) -> tuple[ConvergenceStudy, bytes]:
    st = convergence(case, levels=levels)
    fig = figures.convergence_figure(st)
    child(root / "figures", case.name, "_convergence.png").write_bytes(fig)
    return st, fig


def _fig5_unit(root: Path) -> tuple[list, bytes]:
    rows = fig5_rows()
    fig5_png = figures.fig5_figure(rows)
    (root / "figures" / "fig5.png").write_bytes(fig5_png)
    html = page("Study: paper Fig. 5", study_html(rows, fig5_png), links=False)
    (root / "study_fig5.html").write_text(html, encoding="utf-8")
    return rows, fig5_png


def _case_doc_unit(doc: dict, root: Path, vtk: str = "ends") -> tuple[CaseSection, tuple | None]:
    """:func:`_case_unit` in a worker process: the case arrives as its case-file table."""
    return _case_unit(case_from_dict(doc, name=doc["name"]), root, vtk)


def _convergence_doc_unit(doc: dict, levels: tuple, root: Path):
    return _convergence_unit(case_from_dict(doc, name=doc["name"]), levels, root)


def portable(cases: list[Case]) -> list[dict] | None:
    """The case-file tables that rebuild ``cases`` in a worker process, or None if one does
    not round-trip (a mesh file, a profile without a spec): the report then runs in-process."""
    try:
        docs = [c.to_dict() for c in cases]
        same = all(case_from_dict(d, name=d["name"]).to_dict() == d for d in docs)
    except Exception:  # noqa: BLE001 - any failure means: do not ship this case
        return None
    return docs if same and not any(c.fem.mesh_file for c in cases) else None


def _run_units(units: list[tuple], workers: int):
    """Results of the units ``(function, *args)`` in order, in ``workers`` processes of a
    forkserver (safe when the caller has threads; 1: in this process)."""
    if workers <= 1 or len(units) <= 1:
        yield from (fn(*args) for fn, *args in units)
        return
    with ProcessPoolExecutor(max_workers=workers, mp_context=forkserver_context(),
                             initializer=ignore_interrupts) as pool:
        futures = [pool.submit(fn, *args) for fn, *args in units]
        try:
            for f in futures:
                yield f.result()
        except BaseException:  # Ctrl-C, or the caller stopped: the results are not wanted
            kill_pool(pool)
            raise


def _build(cases: list[Case], conv_cases: dict, want_fig5: bool, root: Path, progress: Progress,
           t0: float, workers: int = REPORT_WORKERS, vtk: str = "ends") -> dict:
    (root / "figures").mkdir()
    conv = list(conv_cases.values())
    docs = portable(cases + [c for c, _ in conv]) if workers > 1 else None
    run_one, run_conv = _case_doc_unit, _convergence_doc_unit
    if docs is None:
        workers, docs, run_one, run_conv = 1, cases + [c for c, _ in conv], _case_unit, \
            _convergence_unit
    units = [(run_one, d, root, vtk) for d in docs[:len(cases)]]
    units += [(run_conv, d, levels, root) for d, (_, levels) in zip(docs[len(cases):], conv,
                                                                     strict=True)]
    units += [(_fig5_unit, root)] if want_fig5 else []
    results = _run_units(units, workers)
    sections, jobs = [], []
    for case in cases:
        sec, job = next(results)
        sec.result = replace(sec.result, case=case)
        sections.append(sec)
        jobs.append(job)
        progress(f"case {case.name}: {'agrees' if sec.result.passed else 'FAILS'}")
    studies, conv_figs = [], {}
    for name in conv_cases:
        st, conv_figs[st.case_name] = next(results)  # keyed as _write_documents looks it up
        studies.append(st)
        progress(f"convergence {name}: pressure order {st.orders['pressure_l2_error']:.2f}, "
                 f"{st.verdict()}")
    rows = []
    if want_fig5:
        rows, _ = next(results)
        progress("study Fig. 5 written")
    _render(sections, jobs, root)
    summary = _summary(sections, studies, rows, time.perf_counter() - t0)
    _write_documents(root, sections, studies, conv_figs, want_fig5, summary)
    return summary


def _write_documents(root: Path, sections, studies, conv_figs, want_fig5, summary) -> None:
    from compare.report.html import (
        convergence_html,
        convergence_md,
        fig5_index_html,
        fig5_verdict,
        index_body,
        md_document,
    )

    body = index_body(sections, summary) + "".join(case_html(s) for s in sections)
    body += "".join(convergence_html(st, conv_figs[st.case_name]) for st in studies)
    if want_fig5:
        body += fig5_index_html(summary["fig5"])
    (root / "index.html").write_text(page("multicontact verification report", body),
                                     encoding="utf-8")
    md = md_document(summary) + "".join(case_md(s) for s in sections)
    md += "".join(convergence_md(st) for st in studies)
    if want_fig5:
        md += (f"\n## Study: paper Fig. 5\n\n{fig5_verdict(summary['fig5'])}.\n\n"
               "![Fig. 5](figures/fig5.png)\n\nSee study_fig5.html.\n")
    (root / "report.md").write_text(md, encoding="utf-8")
    (root / "summary.json").write_text(json.dumps(clean_json(summary), indent=1,
                                                  allow_nan=False), encoding="utf-8")


def clean_json(obj):
    """Plain JSON data: numpy scalars -> float, non-finite floats -> None (JSON has no NaN)."""
    if isinstance(obj, dict):
        return {str(k): clean_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [clean_json(v) for v in obj]
    if isinstance(obj, (bool, int, str)) or obj is None:
        return obj
    try:
        val = float(obj)
    except (TypeError, ValueError):
        return str(obj)
    return val if math.isfinite(val) else None


__all__ = ["DEFAULT_CONVERGENCE", "DEFAULT_SUITE", "clean_json", "write_report"]
