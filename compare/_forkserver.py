"""The forkserver every worker pool of the project starts its workers from (report, audit,
sweep).  A process has one forkserver, started by the first pool that needs it, and its preload
counts only if set before then: every pool asks for the same one here, so whichever starts the
server, the workers fork with these modules already imported."""

from __future__ import annotations

import multiprocessing
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
