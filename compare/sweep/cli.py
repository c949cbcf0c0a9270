"""Command line of sweeps: ``multicontact sweep`` and ``multicontact report --sweep DIR``.

:func:`add_sweep_parser` registers both on the ``multicontact`` parser (``compare.cli``);
:func:`main` is the stand-alone entry (``python -m compare.sweep``).  This layer dispatches to
the runner (``compare.sweep.runner``) and to the report (``compare.sweep.report``), which do
not know each other.
"""

from __future__ import annotations

import argparse
import json
import signal
from pathlib import Path

from compare.errors import SweepError
from compare.exits import EXIT_FAIL, EXIT_INPUT, EXIT_OK, EXIT_SIGINT, EXIT_SIGTERM
from compare.fileio import check_store
from compare.sweep.backends import check_scheduler
from compare.sweep.runner import (
    SweepOutcome,
    check_store_owner,
    check_workers,
    pending_cases,
    run_sweep,
)
from compare.sweep.spec import Sweep, list_studies, load_sweep
from compare.sweep.store import MANIFEST_FILE, RESULTS_FILE, read_records

#: Exit codes of ``multicontact sweep`` (those of every command, ``compare.exits``).
EXIT_FAILED_CASES, EXIT_BAD_INPUT = EXIT_FAIL, EXIT_INPUT
EXIT_SIGNAL = {signal.SIGINT: EXIT_SIGINT, signal.SIGTERM: EXIT_SIGTERM}
#: Description of ``multicontact sweep --help``.
DESCRIPTION = ("Parameter sweeps: many cases from one base case, run on a process pool or "
               "dask.distributed.")


def add_sweep_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``sweep`` subcommand (and ``report --sweep DIR`` if a report parser exists)."""
    p = subparsers.add_parser("sweep", help="run a parameter sweep (process pool or dask)",
                              description=DESCRIPTION)
    p.add_argument("study", help="sweep file (.toml) or library study name "
                   f"({', '.join(list_studies())})")
    p.add_argument("-o", "--output", required=True,
                   help="result directory: new, or this sweep's own (resumable)")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes of the local pool or of --scheduler local (default: "
                        "available cores)")
    p.add_argument("--scheduler", default=None,
                   help="dask scheduler address tcp://host:port, or 'local' for a dask "
                        "LocalCluster (default: local process pool, no dask needed)")
    p.add_argument("--part", action="append", default=None,
                   help="run only this part (repeatable)")
    p.add_argument("--retry-failed", action="store_true", help="run failed cases again")
    p.add_argument("--dry-run", action="store_true", help="list the cases to run and stop")
    p.add_argument("--json", action="store_true", help="print the outcome as JSON")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--force", action="store_true",
                   help="run into a folder that holds other files (they are kept)")
    p.set_defaults(func=cmd_sweep, handler=cmd_sweep)
    report = subparsers.choices.get("report")
    if report is not None:
        _hook_report(report)
    return p


def _hook_report(report: argparse.ArgumentParser) -> None:
    """``report --sweep DIR``: route to the sweep report, else to the case report."""
    report.add_argument("--sweep", metavar="DIR", default=None,
                        help="write the report of a sweep directory into DIR/report (or -o); "
                             "exit 1 if a case of the sweep failed; takes -o, --force and "
                             "--json only")
    original = report.get_default("func") or report.get_default("handler")

    def route(args) -> int:
        if getattr(args, "sweep", None):
            return cmd_sweep_report(args)
        return original(args)

    report.set_defaults(func=route, handler=route)


#: Options of the case report (``multicontact report``) that a sweep report does not take:
#: argparse dest -> (the option as the user wrote it, its value when not given).
CASE_REPORT_ONLY = {"cases": ("CASE arguments", []), "convergence": ("--convergence", None),
                    "levels": ("--levels", None), "no_fig5": ("--no-fig5", False),
                    "vtk": ("--vtk", None)}


def _case_report_options(args) -> list[str]:
    """The case-report options given with ``report --sweep`` (they would be ignored)."""
    return [opt for dest, (opt, unset) in CASE_REPORT_ONLY.items()
            if getattr(args, dest, unset) != unset]


def cmd_sweep_report(args) -> int:
    """``report --sweep DIR [-o OUT] [--force] [--json]``: exit 0 every case ok (or not run),
    1 a case of the sweep failed, 2 bad input."""
    from compare.sweep.report import write_sweep_report

    given = _case_report_options(args)
    if given:
        raise SweepError(f"{', '.join(given)}: not for a sweep report (report --sweep DIR "
                         "takes -o, --force and --json); leave them out, or run the case "
                         "report without --sweep")
    out = write_sweep_report(args.sweep, getattr(args, "out", None),
                             force=getattr(args, "force", False))
    summ = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    if getattr(args, "json", False):
        print(json.dumps(summ | {"index": str(out / "index.html")}))
    else:
        print(f"sweep report: {out / 'index.html'} and {out / 'report.md'} ({summ['ok']} ok, "
              f"{summ['failed']} failed, {summ['pending']} not run)")
    return EXIT_FAILED_CASES if summ["failed"] else EXIT_OK


def _dry_run(sweep: Sweep, args) -> int:
    todo, skipped = pending_cases(sweep, args.output, args.part, args.retry_failed)
    if args.json:
        print(json.dumps({"to_run": [c.params | {"part": c.part} for c in todo],
                          "finished": skipped}))
    else:
        print(f"{sweep.name}: {len(todo)} cases to run, {skipped} finished")
        for c in todo:
            print(f"  {c.part}#{c.index} {c.task} {c.params}")
    return EXIT_OK


def cmd_sweep(args) -> int:
    """Entry of ``multicontact sweep`` (exit 0 all ok, 1 a case failed, 130/143 interrupted;
    bad input raises :class:`SweepError`, a CaseError: exit 2 by ``compare.exits``, with
    --json also as a JSON error object)."""
    sweep = load_sweep(args.study)
    _check_options(args)
    check_store_owner(sweep, args.output)  # first: --force cannot help there
    check_store(args.output, MANIFEST_FILE, args.force)
    if args.dry_run:
        return _dry_run(sweep, args)
    res = run_sweep(sweep, args.output, workers=args.workers, scheduler=args.scheduler,
                    parts=args.part, retry_failed=args.retry_failed,
                    progress=not args.no_progress and not args.json)
    _print_outcome(res, args.json)
    if res.signal is not None:
        return EXIT_SIGNAL.get(res.signal, 130)
    return EXIT_FAILED_CASES if res.failed or _failed_in_store(sweep, args) else EXIT_OK


def _check_options(args) -> None:
    """--workers and --scheduler, checked before anything is written (also for --dry-run)."""
    check_workers(args.workers)
    check_scheduler(args.scheduler, args.workers)


def _failed_in_store(sweep: Sweep, args) -> bool:
    recs = read_records(args.output)
    return any(recs[c.key]["status"] != "ok" for c in sweep.cases
               if c.key in recs and (not args.part or c.part in args.part))


def _print_outcome(res: SweepOutcome, as_json: bool) -> None:
    if as_json:
        print(json.dumps(vars(res) | {"throughput_per_min": res.throughput_per_min}))
        return
    state = "interrupted" if res.signal is not None else "finished"
    print(f"sweep {state}: {res.ok} ok, {res.failed} failed, {res.skipped} already done, "
          f"{res.remaining} remaining of {res.total} ({res.elapsed_s:.1f} s) -> "
          f"{Path(res.directory) / RESULTS_FILE}")
    if res.signal is not None:
        print("run the same command again to resume (finished cases are skipped)")


def main(argv: list[str] | None = None) -> int:
    """Stand-alone entry (``python -m compare.sweep``) with the sweep and report commands."""
    parser = argparse.ArgumentParser(prog="multicontact")
    sub = parser.add_subparsers(dest="command", required=True)
    add_sweep_parser(sub)
    rep = sub.add_parser("report", help="report of a sweep directory (exit 1 if a case failed)")
    rep.add_argument("--sweep", metavar="DIR", required=True)
    rep.add_argument("-o", "--out", help="output directory (default DIR/report)")
    rep.add_argument("--force", action="store_true",
                     help="write the report folder beside files multicontact did not write there")
    rep.add_argument("--json", action="store_true", help="print the summary as JSON")
    rep.set_defaults(func=cmd_sweep_report)
    from compare.exits import run_command  # the exits of every command (signals, closed stdout)

    return run_command(lambda: parser.parse_args(argv))
