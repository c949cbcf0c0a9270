"""Sweep runner: ``run_sweep`` runs the unfinished cases of a sweep into a result directory.

It takes the directory's lock, rewrites the manifest, skips the cases already finished
(resume), hands the rest to an execution backend (local process pool or dask), appends every
record as it arrives, shows progress and, on SIGINT / SIGTERM, stops after keeping every
finished record.  It knows nothing of reports (``compare.sweep.report``).
"""

from __future__ import annotations

import contextlib
import json
import os
import time
import uuid
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from compare.errors import SweepError
from compare.fileio import write_atomic
from compare.sweep.backends import StopFlag, dask_client, run_dask, run_local
from compare.sweep.spec import Sweep, SweepCase, load_sweep
from compare.sweep.store import MANIFEST_FILE, ResultStore, read_records
from compare.sweep.tasks import jsonable


@dataclass(frozen=True)
class SweepOutcome:
    """Counts of one ``run_sweep`` call.

    total: cases in the (selected parts of the) sweep; skipped: already finished before this
    run; ok / failed: finished in this run; remaining: not finished (interrupt);
    signal: the signal number that stopped the run, or None; elapsed_s: wall time.
    """

    directory: str
    total: int
    skipped: int
    ok: int
    failed: int
    remaining: int
    signal: int | None
    elapsed_s: float
    run_id: str

    @property
    def throughput_per_min(self) -> float:
        n = self.ok + self.failed
        return 60.0 * n / self.elapsed_s if self.elapsed_s > 0 else float("nan")


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)))


def _progress(enabled: bool, total: int, done: int):
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    prog = Progress(TextColumn("[bold]sweep"), BarColumn(),
                    TextColumn("done {task.fields[ok]}  failed {task.fields[failed]}  "
                               "remaining {task.fields[remaining]}"),
                    TimeElapsedColumn(), console=Console(stderr=True), disable=not enabled)
    tid = prog.add_task("sweep", total=total, completed=done, ok=done, failed=0,
                        remaining=total - done)
    return prog, tid


def pending_cases(sweep: Sweep, directory: str | Path, parts: list[str] | None = None,
                  retry_failed: bool = False) -> tuple[list[SweepCase], int]:
    """Cases still to run (and how many of the selected are already finished)."""
    if parts:
        bad = sorted(set(parts) - {p.name for p in sweep.parts})
        if bad:
            raise SweepError(f"unknown part {bad[0]!r}: this sweep has "
                             f"{', '.join(p.name for p in sweep.parts)}")
    chosen = [c for c in sweep.cases if not parts or c.part in parts]
    done = read_records(directory)
    finished = {k for k, r in done.items() if r["status"] == "ok" or not retry_failed}
    todo = [c for c in chosen if c.key not in finished]
    return todo, len(chosen) - len(todo)


def run_sweep(sweep: Sweep | str | Path, directory: str | Path, *, workers: int | None = None,
              scheduler: str | None = None, parts: list[str] | None = None,
              retry_failed: bool = False, progress: bool = True) -> SweepOutcome:
    """Run the unfinished cases of a sweep into ``directory`` and return the counts.

    ``scheduler``: None = local process pool with ``workers`` processes; ``"local"`` = a dask
    LocalCluster with ``workers`` processes; ``"tcp://host:port"`` = an existing dask
    scheduler.  SIGINT / SIGTERM stop the run after keeping every finished record.
    """
    sweep = sweep if isinstance(sweep, Sweep) else load_sweep(sweep)
    workers = default_workers() if workers is None else workers
    if workers < 1:
        raise SweepError(f"workers={workers!r} is not allowed: need >= 1")
    run_id, t0 = uuid.uuid4().hex[:12], time.perf_counter()
    with ResultStore(directory) as store, StopFlag() as stop:
        write_atomic(store.dir / MANIFEST_FILE, json.dumps(jsonable(sweep.manifest()), indent=1))
        todo, skipped = pending_cases(sweep, directory, parts, retry_failed)
        counts = Counter()
        prog, tid = _progress(progress, len(todo) + skipped, skipped)
        with prog, _runner(todo, sweep, workers, scheduler, stop) as records:
            for rec in records:
                rec["run"] = run_id
                store.append(rec)
                counts[rec["status"]] += 1
                prog.update(tid, advance=1, ok=skipped + counts["ok"], failed=counts["failed"],
                            remaining=len(todo) - counts.total())
    return SweepOutcome(str(directory), len(todo) + skipped, skipped, counts["ok"],
                        counts["failed"], len(todo) - counts.total(), stop.signum,
                        time.perf_counter() - t0, run_id)


@contextlib.contextmanager
def _runner(todo: list[SweepCase], sweep: Sweep, workers: int, scheduler: str | None,
            stop: StopFlag):
    tasks = [c.as_task(sweep) for c in todo]
    if not tasks:
        yield iter(())
        return
    with contextlib.ExitStack() as stack:
        if scheduler is None:
            gen = run_local(tasks, workers, stop)
        else:
            gen = run_dask(tasks, stack.enter_context(dask_client(scheduler, workers)), stop)
        stack.callback(gen.close)
        yield gen
