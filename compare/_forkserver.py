"""The forkserver every worker pool of the project starts its workers from (report, audit,
sweep).  A process has one forkserver, started by the first pool that needs it, and its preload
counts only if set before then: every pool asks for the same one here, so whichever starts the
server, the workers fork with these modules already imported.

The workers share the caller's process group, so Ctrl-C reaches them too: each pool's
initializer calls :func:`ignore_interrupts` and leaves the interrupt to the caller, which
cancels what has not started and waits for the running work (the audit: its cases take a
second) or stops the workers (:func:`kill_pool`: the report, whose units take up to ~30 s and
whose results an interrupt discards, and the sweep).  A worker interrupted itself printed a
traceback from its idle ``call_queue.get``, or died while sending a result and left the pool's
shutdown waiting for the rest of that message (a hang, seen under load)."""

from __future__ import annotations

import multiprocessing
import signal
from concurrent.futures import ProcessPoolExecutor
from multiprocessing.context import BaseContext

#: Modules the forkserver imports once, so that each worker forked from it starts without
#: importing them (~2 s of interpreter work per worker on 2 cores).  The server is a fresh
#: interpreter, not the caller: a worker's memory limit (compare.audit.run.WORKER_MEMORY) still
#: counts only the server's ~0.3 GB, not the caller's address space.
PRELOAD = ("compare.sweep.tasks", "analytic", "fem")


def forkserver_context() -> BaseContext:
    """The forkserver start context with :data:`PRELOAD`."""
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(list(PRELOAD))
    return ctx


def ignore_interrupts() -> None:
    """Pool initializer: this worker ignores SIGINT (the caller handles Ctrl-C)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def kill_pool(pool: ProcessPoolExecutor) -> None:
    """Stop a pool now: cancel queued work and terminate the worker processes it started."""
    procs = list(getattr(pool, "_processes", {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        if p.is_alive():
            p.terminate()
    for p in procs:
        p.join(timeout=5)
