"""Command line ``multicontact``: list, solve, fem, run, verify, converge, report.

Exit codes: 0 the FE and analytic solutions agree (or nothing to compare), 1 a tolerance
failed, 2 bad input (one message on stderr, nothing written), 3 a solver did not converge
(the message names the case), 130 / 143 interrupted by SIGINT (Ctrl-C) / SIGTERM (one line
``multicontact: interrupted``; unfinished output is removed, as on any error), 141 the reader
of stdout went away (e.g. ``| head``: the rest of the output is dropped quietly, like a
program ended by SIGPIPE).  ``--json`` prints machine-readable output on stdout (an error also
as ``{"error": {"kind", "message", "exit_code"}}``); progress goes to stderr.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from compare.exits import (
    EXIT_FAIL,
    EXIT_OK,
    EXIT_SOLVER,
    report_error,
    run_command,
    solver_errors,
)


def _progress():
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}"
                    "/{task.total}"), TimeElapsedColumn(), console=Console(stderr=True),
                    transient=True)


#: Relative size below which a printed result is round-off: the symmetric Hertz case gives
#: M = 3.7e-16 for P max|x| = 10.8 (3e-17 of it); the solver's residuals are ~1e-14 of their
#: scale, so 1e-12 leaves a margin of 100 above round-off.
ROUNDOFF = 1e-12


def _resolved(value: float, scale: float, name: str) -> str:
    """``value`` as a plain number, or 0 with its size when it is round-off of ``scale``."""
    if abs(value) <= ROUNDOFF * abs(scale):
        return f"0 (round-off: {abs(value):.1e} < {ROUNDOFF:.0e} {name})"
    return f"{value:.6g}"


def _zones(zones) -> str:
    """Zones as [a, b] with plain numbers (None: full slip)."""
    return ", ".join("full slip" if z is None else f"[{float(z[0]):.6g}, {float(z[1]):.6g}]"
                     for z in zones) or "none"


def _elapsed(t0: float) -> str:
    import time

    sec = time.perf_counter() - t0
    return f"{sec:.0f} s" if sec < 120 else f"{sec / 60:.1f} min"


def _print_json(data) -> None:
    from compare.report import clean_json

    print(json.dumps(clean_json(data), indent=1, allow_nan=False))


def _case(args, name: str):
    from compare.cases import load_case

    case = load_case(name)
    if getattr(args, "level", None) is not None:
        case = case.with_fem(level=args.level)
    return case


# ---------------------------------------------------------------------------------------------
# commands
# ---------------------------------------------------------------------------------------------
def cmd_list(args) -> int:
    from compare.cases import list_cases, load_case

    rows = [(n, load_case(n).description) for n in list_cases()]
    if args.json:
        _print_json([{"name": n, "description": d} for n, d in rows])
    else:
        width = max(len(n) for n, _ in rows)
        for n, d in rows:
            print(f"{n:<{width}}  {d}")
    return EXIT_OK


def cmd_solve(args) -> int:
    from compare.analytic_side import solve_case

    case = _case(args, args.case)
    an = solve_case(case)
    ns = an.normal
    data = {"case": case.name, "zones": ns.zones, "singular": ns.singular,
            "zone_loads": ns.zone_loads, "P": ns.P, "M": ns.M, "theta": ns.theta,
            "mode": ns.mode, "residuals": ns.residuals,
            "samples": [{"stage": s.stage, "Q": s.Q, "stick_zones": s.stick_zones,
                         "full_slip": s.full_slip} for s in an.samples]}
    if args.json:
        _print_json(data)
        return EXIT_OK
    arm = max(abs(x) for zone in ns.zones for x in zone)
    print(f"{case.name}: P = {ns.P:g}, M = {_resolved(ns.M, ns.P * arm, 'P*max|x|')}, "
          f"theta = {ns.theta:.6g} ({ns.mode})")
    for k, ((a, b), ld) in enumerate(zip(ns.zones, ns.zone_loads, strict=True)):
        print(f"  zone {k}: [{a:.8g}, {b:.8g}]  load {ld:.6g}  singular {ns.singular[k]}")
    for s in an.samples:
        print(f"  stage {s.stage} Q = {s.Q:.6g}: stick {_zones(s.stick_zones)}")
    return EXIT_OK


def cmd_fem(args) -> int:
    import fem
    from compare.analytic_side import solve_normal_case
    from compare.fem_side import run_fem
    from compare.fileio import check_apart, owned_output, plan_output

    _check_fem_options(args)
    case = _case(args, args.case)
    check_apart({"-o": args.out, "--export": args.export})
    plans = {what: plan_output(d, what, args.force, expected=names)
             for what, d, names in (("fem", args.out, ("history.pvd",)),
                                    ("export", args.export, ("steps.csv",))) if d}
    hist = run_fem(case, solve_normal_case(case))
    pvd = None
    if args.out:
        with owned_output(args.out, "fem", args.force, plans["fem"]) as tmp:
            fem.write_vtk(hist, tmp, steps=args.vtk or "ends")
        pvd = plans["fem"].out / "history.pvd"
    if args.export:
        from compare.external import write_result

        write_result(hist, args.export, case=case.name, force=args.force)
    ends = [hist.stage(k)[-1] for k in (1, 2, 3) if hist.stage(k)]
    data = {"case": case.name, "vtk": pvd and str(pvd), "n_dofs": hist.n_dofs,
            "h_min": hist.h_min, "timings": hist.timings,
            "stage_ends": [{"stage": s.stage, "P": s.P, "Q": s.Q, "M": s.M,
                            "contact_zones": s.contact_zones, "stick_zones": s.stick_zones}
                           for s in ends]}
    if args.json:
        _print_json(data)
        return EXIT_OK
    written = [f"VTK series {pvd}"] if pvd else []
    written += [f"exchange format {Path(args.export).resolve()}"] if args.export else []
    print(f"{case.name}: {hist.n_dofs} dofs, h = {hist.h_min:.3g}; "
          + ("; ".join(written) or "no files written (-o DIR: VTK, --export DIR: CSV)"))
    for s in ends:
        print(f"  end of stage {s.stage} (P = {s.P:g}, Q = {s.Q:g}): contact "
              f"{_zones(s.contact_zones)}; stick {_zones(s.stick_zones)}")
    return EXIT_OK


def _refuse(message: str) -> None:
    """Bad or contradictory options: exit 2 with ``message``, before anything is computed."""
    from compare.errors import CaseError

    raise CaseError(message)


def _check_fem_options(args) -> None:
    """``fem``: --vtk shapes the VTK series of -o; --force applies to -o and --export."""
    if args.vtk is not None and not args.out:
        _refuse(f"--vtk {args.vtk} applies to the VTK series written with -o DIR: add -o DIR "
                "or leave --vtk out")
    if args.force and not (args.out or args.export):
        _refuse("--force applies to the folder of -o DIR or --export DIR: add one of them or "
                "leave --force out")


def cmd_run(args) -> int:
    from compare.cases import check_unique_names
    from compare.fileio import plan_output

    if args.force and not args.vtk:
        _refuse("--force applies to the folder of --vtk DIR: add --vtk DIR or leave --force out")
    cases = [_case(args, n) for n in args.cases]
    plan = None
    if args.vtk:
        check_unique_names(cases, "VTK series (--vtk DIR/<name>/)")
        plan = plan_output(args.vtk, "run", args.force,
                           expected=tuple(f"{c.name}/" for c in cases))
    results: list = []
    try:
        _run_cases(cases, args, plan, results)
    except solver_errors() as exc:  # name the case; the finished ones are printed first
        failed = cases[len(results)].name
        if not args.json:
            _print_results(results, False)
        return report_error(args, "solver", f"solver did not converge in case {failed}: "
                            f"{exc}", EXIT_SOLVER, {"results": [r.summary() for r in results]})
    _print_results(results, args.json)
    return EXIT_OK if all(r.passed for r in results) else EXIT_FAIL


def _run_cases(cases: list, args, plan, results: list) -> None:
    """Run ``cases`` in order, appending each result to ``results`` (the VTK folder of --vtk
    is written only when every case ran)."""
    from compare.fileio import child, owned_output
    from compare.run import run_case

    with owned_output(args.vtk, "run", args.force, plan) if plan else _no_dir() as root, \
            _progress() as prog:
        task = prog.add_task("running cases", total=len(cases))
        for case in cases:
            prog.update(task, description=f"running {case.name}")
            results.append(run_case(case, vtk_dir=root and child(root, case.name)))
            prog.advance(task)


def _print_results(results: list, as_json: bool) -> None:
    from compare.testing import format_checks

    if as_json:
        _print_json([r.summary() for r in results])
        return
    for r in results:
        print(format_checks(r.checks, f"{r.case.name}: {'agrees' if r.passed else 'FAILS'}"))


def _no_dir():
    from contextlib import nullcontext

    return nullcontext(None)


def _settings(items: Sequence[str] | None) -> dict:
    from compare.errors import CaseError

    out = {}
    for item in items or ():
        key, eq, value = item.partition("=")
        if not eq or not key.strip():
            raise CaseError(f"--set {item!r}: expected KEY=VALUE (e.g. pressure_sign=-1)")
        out[key.strip()] = value.strip()
    return out


def cmd_verify(args) -> int:
    from compare.fileio import plan_output
    from compare.testing import format_checks
    from compare.verify import measurement_lines, verify, write_verify_report

    _check_verify_options(args)
    if args.out:  # refused before anything is computed
        plan_output(args.out, "verify", args.force)
    if len(args.result) > 1:
        return _verify_sequence(args, _fem_levels(args) if args.out else None)
    res = verify(args.case, args.result[0], samples=args.samples, settings=_settings(args.set))
    report = write_verify_report(res, args.out, force=args.force) if args.out else None
    if args.json:
        _print_json(res.summary() | ({"index": report["index"]} if report else {}))
        return EXIT_OK if res.passed else EXIT_FAIL
    print(format_checks(res.checks, f"{res.case.name}: {res.source}: "
                        f"{'agrees' if res.passed else 'FAILS'}"))
    for metric, why in res.unavailable.items():
        print(f"  not available: {metric}: {why}")
    for line in measurement_lines(res) + [f"note: {n}" for n in res.notes]:
        print(f"  {line}")
    if report:
        print(f"report written: {report['index']}")
    return EXIT_OK if res.passed else EXIT_FAIL


def _check_verify_options(args) -> None:
    """``verify``: --force applies to -o; --fem-levels to the report of a mesh sequence."""
    if args.force and not args.out:
        _refuse("--force applies to the report folder of -o DIR: add -o DIR or leave --force "
                "out")
    if args.fem_levels is not None and not (args.out and len(args.result) > 1):
        _refuse("--fem-levels applies to the report (-o DIR) of a mesh sequence (several "
                "results): add them or leave --fem-levels out")


def _fem_levels(args) -> list[int]:
    """--fem-levels (default compare.convergence.DEFAULT_LEVELS), refused by that name unless
    refining."""
    from compare.convergence import DEFAULT_LEVELS, study_values

    levels = DEFAULT_LEVELS if args.fem_levels is None else args.fem_levels
    return study_values("h", levels, label="--fem-levels")


def _verify_sequence(args, levels: list[int] | None) -> int:
    """``verify CASE R1 R2 ...``: the results as a mesh sequence (compare.verify_sequence); the
    report (-o) shows our own FE's h-convergence at ``levels`` (--fem-levels) on the same
    axes."""
    from compare.convergence import convergence
    from compare.verify_sequence import sequence_text, verify_convergence, write_sequence_report

    seq = verify_convergence(args.case, args.result, samples=args.samples,
                             settings=_settings(args.set))
    report = None
    if args.out:
        ours = convergence(_case(args, args.case), levels=levels)
        report = write_sequence_report(seq, args.out, reference=ours, force=args.force)
    if args.json:
        _print_json(seq.summary() | ({"index": report["index"]} if report else {}))
    else:
        print(sequence_text(seq))
        if report:
            print(f"report written: {report['index']}")
    return EXIT_OK if seq.converges else EXIT_FAIL


def _check_converge_options(args) -> None:
    """``converge``: --levels are the runs of --kind h, --values those of penalty / domain."""
    if args.kind == "h" and args.values is not None:
        _refuse("--values applies to --kind penalty or domain; --kind h runs the mesh levels "
                "of --levels")
    if args.kind != "h" and args.levels is not None:
        _refuse(f"--levels applies to --kind h; --kind {args.kind} runs the case's level with "
                "the factors of --values")


def cmd_converge(args) -> int:
    from compare.convergence import DEFAULT_LEVELS, convergence, convergence_text, study_values

    _check_converge_options(args)
    levels = DEFAULT_LEVELS if args.levels is None else args.levels
    study_values(args.kind, levels, args.values,  # refused by the option's name, before a run
                 label="--levels" if args.kind == "h" else "--values")
    case = _case(args, args.case)
    with _progress() as prog:
        n = len(levels) if args.kind == "h" else len(args.values or (0, 0, 0))
        task = prog.add_task(f"{args.kind}-convergence of {case.name}", total=n)
        st = convergence(case, levels=levels, kind=args.kind, values=args.values,
                         progress=lambda i, n: prog.update(task, completed=i),
                         phase_locked=args.phase_locked)
    if args.json:
        _print_json(st.summary())
    else:
        print(convergence_text(st))
    return EXIT_OK if st.converges else EXIT_FAIL


#: Output folder of ``report`` without -o.
DEFAULT_REPORT_DIR = "report"


class _Steps:
    """Progress of a report on stderr: ``[i of N, elapsed] message`` per finished unit."""

    def __init__(self, units: list[str]):
        import time

        self.units, self.done, self.t0 = units, 0, time.perf_counter()

    def step(self, msg: str) -> None:
        self.done += 1
        print(f"  [{self.done} of {len(self.units)}, {_elapsed(self.t0)}] {msg}",
              file=sys.stderr, flush=True)

    def current(self) -> str:
        """The unit being worked on (the units finish in order)."""
        return self.units[self.done] if self.done < len(self.units) else "the report pages"


def _report_inputs(args) -> tuple[list, dict]:
    """The cases and the convergence studies (name -> levels) of ``report``, refused (exit 2)
    before anything runs."""
    from compare.cases import load_case
    from compare.convergence import study_values
    from compare.report import DEFAULT_CONVERGENCE, DEFAULT_STUDY_LEVELS, DEFAULT_SUITE

    cases = [load_case(c) for c in args.cases or DEFAULT_SUITE]  # bad input: before the banner
    studied = DEFAULT_CONVERGENCE if args.convergence is None else args.convergence
    if args.levels and not studied:
        _refuse("--levels sets the levels of the convergence studies, and --convergence without "
                "a case asks for none: name a case after --convergence or leave --levels out")
    levels = study_values("h", args.levels or DEFAULT_STUDY_LEVELS, label="--levels")
    conv = {n: tuple(levels) for n in studied}
    return cases, conv


def cmd_report(args) -> int:
    from compare.report import build_report, plan_report

    cases, conv = _report_inputs(args)
    out = args.out or DEFAULT_REPORT_DIR
    plan = plan_report(cases, out, conv, not args.no_fig5, args.vtk or "ends", args.force)
    steps = _Steps([f"case {c.name}" for c in cases]
                   + [f"the convergence study of {n}" for n in conv]
                   + ([] if args.no_fig5 else ["the Fig. 5 study"]))
    studies = f"{len(conv)} convergence stud{'y' if len(conv) == 1 else 'ies'}"
    print(f"multicontact report: {len(cases)} case{'' if len(cases) == 1 else 's'}, {studies}"
          f"{'' if args.no_fig5 else ', the Fig. 5 study'} into {out} (a case takes 5-40 s; "
          "two run at a time)", file=sys.stderr, flush=True)
    try:
        summary = build_report(plan, progress=steps.step)
    except solver_errors() as exc:  # the units before it are listed as they finished
        return report_error(args, "solver", f"solver did not converge in {steps.current()}: "
                            f"{exc}; no report was written", EXIT_SOLVER)
    if args.json:
        _print_json(summary)
    else:
        print(f"report written: {summary['index']} "
              f"({'all cases agree' if summary['passed'] else 'some cases FAIL'}, "
              f"{summary['elapsed_seconds']:.0f} s, {_size(Path(summary['index']).parent)})")
    return EXIT_OK if summary["passed"] else EXIT_FAIL


def _size(root: Path) -> str:
    total = sum(f.stat().st_size for f in root.rglob("*") if f.is_file())
    return f"{total / 1e6:.1f} MB"


# ---------------------------------------------------------------------------------------------
# parser and entry point
# ---------------------------------------------------------------------------------------------
def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("multicontact")
    except PackageNotFoundError:
        return "(not installed)"


def _force(sp: argparse.ArgumentParser) -> None:
    sp.add_argument("--force", action="store_true",
                    help="write into a folder that holds other files (they are kept; only "
                         "multicontact's own previous output there is replaced)")


def _vtk_steps(sp: argparse.ArgumentParser) -> None:
    sp.add_argument("--vtk", choices=("ends", "all"),
                    help="VTK steps: 'ends' (default): the interface at the end of each stage "
                         "and the bodies under the largest load; 'all': every step")


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="multicontact", description=__doc__.split("\n\n")[0])
    p.add_argument("--version", action="version", version=f"multicontact {_version()}")
    sub = p.add_subparsers(dest="command", required=True)

    def add(name, func, help_):
        sp = sub.add_parser(name, help=help_)
        sp.add_argument("--json", action="store_true", help="machine-readable output on stdout")
        sp.set_defaults(func=func)
        return sp

    add("list", cmd_list, "list the library cases")
    sp = add("solve", cmd_solve, "analytic solution of a case (zones, loads, stick zones)")
    sp.add_argument("case", help="library case name or .toml path")
    sp = add("fem", cmd_fem, "FE solution of a case; -o writes the VTK series, --export the "
             "exchange format")
    sp.add_argument("case")
    sp.add_argument("-o", "--out", metavar="DIR", help="write the VTK series (.pvd) into DIR")
    sp.add_argument("--level", type=int, help="override the FE mesh level")
    sp.add_argument("--export", metavar="DIR",
                    help="write the history in the exchange format (docs/external.md) into DIR")
    _vtk_steps(sp)
    _force(sp)
    sp = add("run", cmd_run, "analytic + FE + metrics; exit 1 if a tolerance fails")
    sp.add_argument("cases", nargs="+")
    sp.add_argument("--level", type=int, help="override the FE mesh level")
    sp.add_argument("--vtk", metavar="DIR", help="also write every step's VTK into DIR/<case>/")
    _force(sp)
    sp = add("verify", cmd_verify, "verify an external FE result (docs/external.md) against the "
             "analytic solution; exit 1 if a tolerance fails")
    sp.add_argument("case", help="library case name or .toml path")
    sp.add_argument("result", nargs="+",
                    help="steps.csv manifest, folder of step files, or .pvd series; several: "
                         "results of one code at several resolutions, verified as a mesh "
                         "sequence (orders, stall, grid convergence index)")
    sp.add_argument("-o", "--out", metavar="DIR",
                    help="write the report pages into DIR (e.g. verify-report)")
    _force(sp)
    sp.add_argument("--samples", choices=("steps", "case"), default="steps",
                    help="compare at every stage-2/3 step (default) or at the case's samples")
    sp.add_argument("--set", action="append", metavar="KEY=VALUE",
                    help="override a header item (convention or meta data), repeatable")
    sp.add_argument("--fem-levels", type=int, nargs="+",
                    help="a sequence's report: levels of our own FE's convergence study drawn "
                         "beside it (default 0 1 2)")
    sp = add("converge", cmd_converge, "convergence study (h, penalty or domain size)")
    sp.add_argument("case")
    sp.add_argument("--kind", choices=("h", "penalty", "domain"), default="h")
    sp.add_argument("--levels", type=int, nargs="+",
                    help="mesh levels of --kind h (default 0 1 2)")
    sp.add_argument("--values", type=float, nargs="+",
                    help="penalty factors (inf: augmented Lagrangian) or size factors (kinds "
                         "penalty / domain)")
    sp.add_argument("--phase-locked", action="store_true",
                    help="a mesh node on every analytic contact edge at every level (the edge "
                         "error then does not swing with the edge's place between nodes)")
    sp = add("report", cmd_report, "verification report (index.html, report.md, summary.json)")
    sp.add_argument("cases", nargs="*", help="cases (default: the default suite)")
    sp.add_argument("-o", "--out", help=f"output directory (default {DEFAULT_REPORT_DIR}; with "
                    "--sweep DIR: default DIR/report)")
    sp.add_argument("--convergence", nargs="*", metavar="CASE",
                    help="cases with an h-convergence study (default: hertz; none if empty)")
    sp.add_argument("--levels", type=int, nargs="+",
                    help="levels of the convergence studies (default -1 0 1)")
    sp.add_argument("--no-fig5", action="store_true", help="skip the paper Fig. 5 study page")
    _vtk_steps(sp)
    _force(sp)
    from compare.sweep.cli import add_sweep_parser  # `sweep` and `report --sweep DIR`

    add_sweep_parser(sub)
    p.description = f"Command line multicontact: {', '.join(sub.choices)}."
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``multicontact`` console script; returns the exit code."""
    return run_command(lambda: parser().parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
