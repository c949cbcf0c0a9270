"""Sweep execution backends: a local process pool or a dask.distributed cluster.

Both take plain-data task dicts and yield records as the cases finish, run
:func:`compare.sweep.tasks.execute` on the workers, stop early when the coordinator's
:class:`StopFlag` is set (SIGINT / SIGTERM) and turn a case whose worker died into a
``WorkerLost`` record instead of failing the sweep.  Local pool workers also watch the
coordinating process and end themselves when it is gone (e.g. SIGKILLed), so no orphaned
worker, forkserver or resource tracker stays behind.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import threading
import time
from collections import Counter, deque
from collections.abc import Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor
from concurrent.futures import wait as futures_wait
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from compare._forkserver import forkserver_context, ignore_interrupts, kill_pool
from compare.errors import SweepError
from compare.sweep.tasks import execute, infrastructure_failure

#: A case whose worker process died this many times is recorded as failed (local pool).
MAX_WORKER_DEATHS = 2
#: Seconds between checks for finished work and for an interrupt.
POLL_S = 0.2


class StopFlag:
    """Signal flag set by SIGINT / SIGTERM handlers (installed only in the main thread)."""

    def __init__(self):
        self.signum: int | None = None
        self._old: dict = {}

    def __enter__(self) -> StopFlag:
        if threading.current_thread() is threading.main_thread():
            for s in (signal.SIGINT, signal.SIGTERM):
                self._old[s] = signal.signal(s, self._handle)
        return self

    def _handle(self, signum, frame) -> None:
        self.signum = signum

    def __exit__(self, *exc) -> None:
        for s, h in self._old.items():
            signal.signal(s, h)

    def __bool__(self) -> bool:
        return self.signum is not None


#: Seconds between a worker's checks that the coordinating process is still alive.
COORDINATOR_POLL_S = 0.25
#: Exit status of a worker that ended itself because its coordinator was gone.
EXIT_ORPHANED = 75


def _proc_stat(pid: int) -> list[str] | None:
    """The fields of ``/proc/PID/stat`` after the command name (state first), or None."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return stat[stat.rfind(")") + 2:].split()


def process_identity(pid: int) -> tuple[int, str]:
    """``(pid, start time)``: a pid reused by a later process has another start time (Linux
    ``/proc``; elsewhere the start time is '' and only the pid is checked)."""
    fields = _proc_stat(pid)
    return pid, fields[19] if fields else ""


def is_alive(identity: tuple[int, str]) -> bool:
    """Whether the process ``identity`` (from :func:`process_identity`) still runs (a zombie,
    killed but not yet reaped, counts as gone)."""
    pid, start = identity
    if start:
        fields = _proc_stat(pid)
        return fields is not None and fields[19] == start and fields[0] not in ("Z", "X")
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def watch_coordinator(identity: tuple[int, str]) -> None:
    """End this (worker) process when the coordinator ``identity`` is gone, e.g. killed by
    SIGKILL, which it cannot forward: a daemon thread polls it every COORDINATOR_POLL_S.  Once
    the workers are gone, the forkserver and resource tracker they kept open exit too."""
    def watch() -> None:
        while is_alive(identity):
            time.sleep(COORDINATOR_POLL_S)
        os._exit(EXIT_ORPHANED)

    threading.Thread(target=watch, name="multicontact-coordinator-watch", daemon=True).start()


def _init_worker(coordinator: tuple[int, str]) -> None:
    """Pool workers leave Ctrl-C to the coordinator (which stops them and keeps the records)
    and end themselves when the coordinator dies."""
    ignore_interrupts()
    watch_coordinator(coordinator)


def _pool(workers: int) -> ProcessPoolExecutor:
    return ProcessPoolExecutor(max_workers=workers, mp_context=forkserver_context(),
                               initializer=_init_worker,
                               initargs=(process_identity(os.getpid()),))


def run_local(tasks: list[dict], workers: int, stop: StopFlag) -> Iterator[dict]:
    """Run tasks on a local process pool (``workers`` in flight), yielding records as they end.

    A worker process that dies breaks the pool: the cases it held are resubmitted to a fresh
    pool; a case present at ``MAX_WORKER_DEATHS`` deaths is recorded as failed.
    """
    queue, deaths = deque(tasks), Counter()
    while queue and not stop:
        pool, inflight = _pool(workers), {}
        try:
            while (queue or inflight) and not stop:
                while queue and len(inflight) < workers:
                    t = queue.popleft()
                    inflight[pool.submit(execute, t)] = t
                done, _ = futures_wait(inflight, timeout=POLL_S, return_when=FIRST_COMPLETED)
                for fut in done:
                    t = inflight.pop(fut)
                    if isinstance(fut.exception(), BrokenProcessPool):
                        inflight[fut] = t
                        raise fut.exception()
                    yield fut.result()
        except BrokenProcessPool:
            for t in inflight.values():
                deaths[t["key"]] += 1
                if deaths[t["key"]] >= MAX_WORKER_DEATHS:
                    yield infrastructure_failure(t, f"worker process died {deaths[t['key']]} "
                                                 "times while running this case")
                else:
                    queue.appendleft(t)
        finally:
            kill_pool(pool)


#: The forms of a scheduler address (``--scheduler``), as said in error messages.
SCHEDULER_FORMS = "'local' (a dask LocalCluster here) or tcp://HOST:PORT (an existing scheduler)"
_TCP_ADDRESS = re.compile(r"tcp://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9._-]+):([0-9]{1,5})")


def check_scheduler(scheduler: str | None, workers: int | None = None) -> str | None:
    """``scheduler`` if it is None, 'local' or tcp://HOST:PORT (port 1-65535), else a
    SweepError naming it and the allowed forms (checked before anything is written); a number
    of ``workers`` given with a tcp:// scheduler is refused too (the workers are that
    cluster's)."""
    if scheduler is None or scheduler == "local":
        return scheduler
    m = _TCP_ADDRESS.fullmatch(scheduler) if isinstance(scheduler, str) else None
    if m is None or not 1 <= int(m[2]) <= 65535:
        raise SweepError(f"scheduler {scheduler!r} is not allowed: give {SCHEDULER_FORMS}, "
                         "e.g. tcp://127.0.0.1:8786")
    if workers is not None:
        raise SweepError(f"workers={workers!r} does not apply to scheduler {scheduler}: the "
                         "workers are that cluster's; workers sizes the local pool or "
                         "scheduler 'local'")
    return scheduler


def _dask():
    try:
        import distributed
    except ImportError:
        raise SweepError("--scheduler needs dask.distributed, which is not installed: "
                         "pip install 'multicontact[cluster]'") from None
    return distributed


@contextlib.contextmanager
def dask_client(scheduler: str, workers: int):
    """A dask Client on ``scheduler`` (an address), or on a new LocalCluster if 'local'."""
    distributed = _dask()
    if scheduler == "local":
        with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                      dashboard_address=None) as cluster, \
                distributed.Client(cluster) as client:
            yield client
        return
    try:
        client = distributed.Client(scheduler, timeout="20s")
    except (OSError, TimeoutError) as exc:
        raise SweepError(f"cannot connect to the dask scheduler {scheduler!r}: {exc}") from None
    with client:
        yield client


def run_dask(tasks: list[dict], client, stop: StopFlag) -> Iterator[dict]:
    """Submit all tasks to a dask cluster and yield records as they finish.

    A worker that dies has its cases rescheduled by the scheduler; a case that kills
    ``distributed.scheduler.allowed-failures`` workers comes back as KilledWorker and is
    recorded as failed.  Futures are keyed by the case key, so a resubmitted case is one task.
    """
    distributed = _dask()
    by_key = {f"multicontact-sweep-{t['key']}": t for t in tasks}
    futs = [client.submit(execute, t, key=k, pure=False) for k, t in by_key.items()]
    ac = distributed.as_completed(futs)
    try:
        while not ac.is_empty() and not stop:
            if not ac.has_ready():
                time.sleep(POLL_S / 4)
                continue
            for fut in ac.next_batch(block=False):
                t = by_key[fut.key]
                try:
                    yield fut.result()
                except Exception as exc:  # noqa: BLE001 - KilledWorker, lost data, ...
                    yield infrastructure_failure(t, f"{type(exc).__name__}: {exc}")
                fut.release()
    finally:
        client.cancel([f for f in futs if not f.done()])
