"""The exits of every command of ``multicontact`` (see :mod:`compare.cli`): input errors 2,
solver failures 3, SIGINT / SIGTERM 130 / 143 after the cleanup on the way out, a closed stdout
141; with ``--json`` an error is also a JSON object on stdout.  Shared by ``compare.cli`` and
``compare.sweep.cli`` (the stand-alone ``python -m compare.sweep``)."""

from __future__ import annotations

import argparse
import json
import os
import select
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

EXIT_OK, EXIT_FAIL, EXIT_INPUT, EXIT_SOLVER = 0, 1, 2, 3
#: 128 + the signal number, as a shell reports a program that the signal ended.
EXIT_SIGINT, EXIT_SIGTERM, EXIT_PIPE = 130, 143, 141


def solver_errors() -> tuple[type[Exception], ...]:
    """The two solvers' ConvergenceError classes (exit 3)."""
    import analytic.errors
    import fem.errors

    return analytic.errors.ConvergenceError, fem.errors.ConvergenceError


def run_command(parse: Callable[[], argparse.Namespace]) -> int:
    """``args.func(args)`` for ``args = parse()``, with the exits of every command (module
    docstring): input errors 2, solver failures 3, SIGINT / SIGTERM 130 / 143 after the cleanup
    on the way out (temporary output folders removed, worker pools stopped), a closed stdout
    141."""
    args = None
    with _sigterm_as_interrupt():
        try:
            args = parse()
            code = _dispatch(args)
            sys.stdout.flush()  # a closed pipe shows here, not at interpreter exit
            return code
        except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM (Terminated)
            term = isinstance(exc, Terminated)
            return report_error(args, "interrupted",
                                "interrupted" + (" (SIGTERM)" if term else ""),
                                EXIT_SIGTERM if term else EXIT_SIGINT)
        except BrokenPipeError:
            if not _stdout_gone():
                raise
            _silence_stdout()
            return EXIT_PIPE


def _dispatch(args: argparse.Namespace) -> int:
    import analytic.errors
    import fem.errors
    from compare.errors import CaseError

    try:
        return args.func(args)
    except (CaseError, analytic.errors.InputError, fem.errors.InputError) as exc:
        return report_error(args, "input", f"error: {exc}", EXIT_INPUT)
    except solver_errors() as exc:
        return report_error(args, "solver", f"solver did not converge: {exc}", EXIT_SOLVER)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C's KeyboardInterrupt so that it takes the same way out."""


@contextmanager
def _sigterm_as_interrupt() -> Iterator[None]:
    """Within: SIGTERM raises :class:`Terminated` (once: a second SIGTERM, e.g. ``timeout``'s
    to the process group, does not interrupt the cleanup).  Not in a thread other than the
    main one, nor when SIGTERM is ignored; the previous handler is restored after."""
    if threading.current_thread() is not threading.main_thread() \
            or signal.getsignal(signal.SIGTERM) is signal.SIG_IGN:
        yield
        return
    raised = False

    def handler(signum: int, frame) -> None:
        nonlocal raised
        if not raised:
            raised = True
            raise Terminated

    old = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def _stdout_gone() -> bool:
    """Whether stdout is a pipe whose reader has gone (poll reports an error on it)."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):
        return False
    poll = select.poll()
    poll.register(fd, select.POLLOUT)
    return any(ev & select.POLLERR for _, ev in poll.poll(0))


def _silence_stdout() -> None:
    """Send what is still buffered for stdout to /dev/null (no error at interpreter exit)."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)


def report_error(args, kind: str, message: str, code: int, extra: dict | None = None) -> int:
    """The message on stderr and, with --json, a JSON error object (and ``extra``) on stdout."""
    print(f"multicontact: {message}", file=sys.stderr)
    if getattr(args, "json", False):
        doc = {"error": {"kind": kind, "message": message, "exit_code": code}}
        if extra:
            from compare.report import clean_json

            doc |= clean_json(extra)
        print(json.dumps(doc, indent=1))
    return code
