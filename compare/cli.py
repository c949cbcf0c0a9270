"""Command line ``multicontact``: list, solve, fem, run, verify, converge, report.

Exit codes: 0 the FE and analytic solutions agree (or nothing to compare), 1 a tolerance
failed, 2 bad input (one message on stderr, nothing written), 3 a solver did not converge.
``--json`` prints machine-readable output on stdout; progress goes to stderr.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

EXIT_OK, EXIT_FAIL, EXIT_INPUT, EXIT_SOLVER = 0, 1, 2, 3


def _progress():
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}"
                    "/{task.total}"), TimeElapsedColumn(), console=Console(stderr=True),
                    transient=True)


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
    print(f"{case.name}: P = {ns.P:g}, M = {ns.M:.6g}, theta = {ns.theta:.6g} ({ns.mode})")
    for k, ((a, b), ld) in enumerate(zip(ns.zones, ns.zone_loads, strict=True)):
        print(f"  zone {k}: [{a:.8g}, {b:.8g}]  load {ld:.6g}  singular {ns.singular[k]}")
    for s in an.samples:
        zs = ", ".join("full slip" if z is None else f"[{z[0]:.6g}, {z[1]:.6g}]"
                       for z in s.stick_zones)
        print(f"  stage {s.stage} Q = {s.Q:.6g}: stick {zs}")
    return EXIT_OK


def cmd_fem(args) -> int:
    import fem
    from compare.analytic_side import solve_normal_case
    from compare.fem_side import run_fem

    case = _case(args, args.case)
    out = Path(args.out or f"{case.name}-vtk")
    hist = run_fem(case, solve_normal_case(case))
    pvd = fem.write_vtk(hist, out)
    if args.export:
        from compare.external import write_result

        write_result(hist, args.export, case=case.name)
    ends = [hist.stage(k)[-1] for k in (1, 2, 3) if hist.stage(k)]
    data = {"case": case.name, "vtk": str(pvd), "n_dofs": hist.n_dofs, "h_min": hist.h_min,
            "timings": hist.timings,
            "stage_ends": [{"stage": s.stage, "P": s.P, "Q": s.Q, "M": s.M,
                            "contact_zones": s.contact_zones, "stick_zones": s.stick_zones}
                           for s in ends]}
    if args.json:
        _print_json(data)
        return EXIT_OK
    print(f"{case.name}: {hist.n_dofs} dofs, h = {hist.h_min:.3g}; VTK series {pvd}")
    for s in data["stage_ends"]:
        print(f"  end of stage {s['stage']} (P = {s['P']:g}, Q = {s['Q']:g}): contact "
              f"{s['contact_zones']}, stick {s['stick_zones']}")
    return EXIT_OK


def cmd_run(args) -> int:
    from compare.run import run_case
    from compare.testing import format_checks

    cases = [_case(args, n) for n in args.cases]
    results = []
    with _progress() as prog:
        task = prog.add_task("running cases", total=len(cases))
        for case in cases:
            prog.update(task, description=f"running {case.name}")
            results.append(run_case(case, vtk_dir=args.vtk and Path(args.vtk) / case.name))
            prog.advance(task)
    if args.json:
        _print_json([r.summary() for r in results])
    else:
        for r in results:
            print(format_checks(r.checks, f"{r.case.name}: "
                                f"{'agrees' if r.passed else 'FAILS'}"))
    return EXIT_OK if all(r.passed for r in results) else EXIT_FAIL


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
    from compare.testing import format_checks
    from compare.verify import verify, write_verify_report

    res = verify(args.case, args.result, samples=args.samples, settings=_settings(args.set))
    report = write_verify_report(res, args.out) if args.out else None
    if args.json:
        _print_json(res.summary() | ({"index": report["index"]} if report else {}))
        return EXIT_OK if res.passed else EXIT_FAIL
    print(format_checks(res.checks, f"{res.case.name}: {res.source}: "
                        f"{'agrees' if res.passed else 'FAILS'}"))
    for metric, why in res.unavailable.items():
        print(f"  not available: {metric}: {why}")
    if report:
        print(f"report written: {report['index']}")
    return EXIT_OK if res.passed else EXIT_FAIL


def cmd_converge(args) -> int:
    from compare.convergence import convergence, convergence_text

    case = _case(args, args.case)
    with _progress() as prog:
        n = len(args.levels) if args.kind == "h" else len(args.values or (0, 0, 0))
        task = prog.add_task(f"{args.kind}-convergence of {case.name}", total=n)
        st = convergence(case, levels=args.levels, kind=args.kind, values=args.values,
                         progress=lambda i, n: prog.update(task, completed=i),
                         phase_locked=args.phase_locked)
    if args.json:
        _print_json(st.summary())
    else:
        print(convergence_text(st))
    return EXIT_OK if st.converges else EXIT_FAIL


def cmd_report(args) -> int:
    from compare.report import DEFAULT_CONVERGENCE, DEFAULT_SUITE, write_report

    cases = args.cases or list(DEFAULT_SUITE)
    conv = DEFAULT_CONVERGENCE if args.convergence is None else {
        n: tuple(args.levels) for n in args.convergence}
    total = len(cases) + len(conv) + (0 if args.no_fig5 else 1)
    with _progress() as prog:
        task = prog.add_task("report", total=total)

        def step(msg: str) -> None:
            prog.console.print(f"  {msg}")
            prog.advance(task)

        summary = write_report(cases, args.out, convergence_cases=conv, fig5=not args.no_fig5,
                               progress=step)
    if args.json:
        _print_json(summary)
    else:
        print(f"report written: {summary['index']} "
              f"({'all cases agree' if summary['passed'] else 'some cases FAIL'}, "
              f"{summary['elapsed_seconds']:.0f} s)")
    return EXIT_OK if summary["passed"] else EXIT_FAIL


# ---------------------------------------------------------------------------------------------
# parser and entry point
# ---------------------------------------------------------------------------------------------
def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="multicontact", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)

    def add(name, func, help_):
        sp = sub.add_parser(name, help=help_)
        sp.add_argument("--json", action="store_true", help="machine-readable output on stdout")
        sp.set_defaults(func=func)
        return sp

    add("list", cmd_list, "list the library cases")
    sp = add("solve", cmd_solve, "analytic solution of a case (zones, loads, stick zones)")
    sp.add_argument("case", help="library case name or .toml path")
    sp = add("fem", cmd_fem, "FE solution of a case; writes the VTK series")
    sp.add_argument("case")
    sp.add_argument("-o", "--out", help="VTK directory (default <case>-vtk)")
    sp.add_argument("--level", type=int, help="override the FE mesh level")
    sp.add_argument("--export", metavar="DIR",
                    help="also write the history in the exchange format (docs/external.md)")
    sp = add("run", cmd_run, "analytic + FE + metrics; exit 1 if a tolerance fails")
    sp.add_argument("cases", nargs="+")
    sp.add_argument("--level", type=int, help="override the FE mesh level")
    sp.add_argument("--vtk", help="also write VTK series into VTK/<case>/")
    sp = add("verify", cmd_verify, "verify an external FE result (docs/external.md) against the "
             "analytic solution; exit 1 if a tolerance fails")
    sp.add_argument("case", help="library case name or .toml path")
    sp.add_argument("result", help="steps.csv manifest, folder of step files, or .pvd series")
    sp.add_argument("-o", "--out", help="write the report pages into this folder")
    sp.add_argument("--samples", choices=("steps", "case"), default="steps",
                    help="compare at every stage-2/3 step (default) or at the case's samples")
    sp.add_argument("--set", action="append", metavar="KEY=VALUE",
                    help="override a header item (convention or meta data), repeatable")
    sp = add("converge", cmd_converge, "convergence study (h, penalty or domain size)")
    sp.add_argument("case")
    sp.add_argument("--kind", choices=("h", "penalty", "domain"), default="h")
    sp.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2])
    sp.add_argument("--values", type=float, nargs="+",
                    help="penalty factors (inf: augmented Lagrangian) or size factors (kinds "
                         "penalty / domain)")
    sp.add_argument("--phase-locked", action="store_true",
                    help="a mesh node on every analytic contact edge at every level (the edge "
                         "error then does not swing with the edge's place between nodes)")
    sp = add("report", cmd_report, "verification report (index.html, report.md, summary.json)")
    sp.add_argument("cases", nargs="*", help="cases (default: the default suite)")
    sp.add_argument("-o", "--out", default="report", help="output directory (default report)")
    sp.add_argument("--convergence", nargs="*", metavar="CASE",
                    help="cases with an h-convergence study (default: hertz; none if empty)")
    sp.add_argument("--levels", type=int, nargs="+", default=[-1, 0, 1],
                    help="levels of the convergence studies")
    sp.add_argument("--no-fig5", action="store_true", help="skip the paper Fig. 5 study page")
    from compare.sweep.cli import add_sweep_parser  # `sweep` and `report --sweep DIR`

    add_sweep_parser(sub)
    p.description = f"Command line multicontact: {', '.join(sub.choices)}."
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``multicontact`` console script; returns the exit code."""
    args = parser().parse_args(argv)
    import analytic.errors
    import fem.errors
    from compare.errors import CaseError

    try:
        return args.func(args)
    except (CaseError, analytic.errors.InputError, fem.errors.InputError) as exc:
        print(f"multicontact: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except (analytic.errors.ConvergenceError, fem.errors.ConvergenceError) as exc:
        print(f"multicontact: solver did not converge: {exc}", file=sys.stderr)
        return EXIT_SOLVER


if __name__ == "__main__":
    sys.exit(main())
