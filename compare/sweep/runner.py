"""Sweep runner: ``run_sweep`` runs the unfinished cases of a sweep into a result directory.

It checks its input and that the directory is the sweep's own (or new) before anything is
written, connects to dask if asked, takes the directory's lock, rewrites the manifest, skips
the cases already finished (resume), hands the rest to an execution backend (local process
pool or dask), appends every record as it arrives, shows progress and, on SIGINT / SIGTERM,
stops after keeping every finished record.  It knows nothing of reports
(``compare.sweep.report``).
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
from compare.sweep.backends import StopFlag, check_scheduler, dask_client, run_dask, run_local
from compare.sweep.spec import Sweep, SweepCase, load_sweep
from compare.sweep.store import (
    MANIFEST_FILE,
    RESULTS_FILE,
    ResultStore,
    read_records,
    store_manifest,
)
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
    scheduler.  Bad input (workers, scheduler, parts, a folder that is not this sweep's:
    :func:`check_store_owner`) and an unreachable scheduler are refused (SweepError) before
    anything is written.  SIGINT / SIGTERM stop the run after keeping every finished record.
    """
    sweep = sweep if isinstance(sweep, Sweep) else load_sweep(sweep)
    check_scheduler(scheduler, workers)
    workers = check_workers(workers)
    check_store_owner(sweep, directory)
    todo, _ = pending_cases(sweep, directory, parts, retry_failed)
    run_id, t0 = uuid.uuid4().hex[:12], time.perf_counter()
    # records are only ever added, so the cases left under the lock are a subset of ``todo``:
    # no cases left now, no backend needed then
    with StopFlag() as stop, _backend(scheduler, workers, bool(todo)) as client, \
            ResultStore(directory, prepare=lambda d: _claim(sweep, d)) as store:
        todo, skipped = pending_cases(sweep, directory, parts, retry_failed)
        counts = Counter()
        prog, tid = _progress(progress, len(todo) + skipped, skipped)
        with prog, _runner(todo, sweep, workers, scheduler, client, stop) as records:
            for rec in records:
                rec["run"] = run_id
                store.append(rec)
                counts[rec["status"]] += 1
                prog.update(tid, advance=1, ok=skipped + counts["ok"], failed=counts["failed"],
                            remaining=len(todo) - counts.total())
    return SweepOutcome(str(directory), len(todo) + skipped, skipped, counts["ok"],
                        counts["failed"], len(todo) - counts.total(), stop.signum,
                        time.perf_counter() - t0, run_id)


def check_workers(workers: int | None) -> int:
    """The number of worker processes (None: the available cores); SweepError below 1."""
    if workers is None:
        return default_workers()
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise SweepError(f"workers={workers!r} is not allowed: need >= 1")
    return workers


def check_store_owner(sweep: Sweep, directory: str | Path) -> None:
    """Refuse (SweepError) a folder that is not ``sweep``'s store: a sweep.json that is not a
    sweep manifest, a results.jsonl without one, the store of a sweep of another name, or of a
    version of this sweep with finished cases that ``sweep`` no longer has (their records would
    drop out of the manifest and the report).  A new or empty folder, and this sweep's own
    store (resume; values added to an axis), pass."""
    directory = Path(directory)
    try:
        man = store_manifest(directory)
    except SweepError as exc:
        raise SweepError(f"{exc}; nothing was written: give the sweep a folder of its own"
                         ) from None
    if man is None:
        if (directory / RESULTS_FILE).exists():
            raise SweepError(f"{directory / RESULTS_FILE} has no {MANIFEST_FILE} beside it: "
                             f"{directory} is not a sweep's folder; nothing was written: give "
                             "the sweep a folder of its own")
        return
    if man["name"] != sweep.name:
        raise SweepError(f"{directory} holds sweep '{man['name']}' ({MANIFEST_FILE}), not "
                         f"'{sweep.name}'; nothing was written: a folder holds one sweep, give "
                         f"'{sweep.name}' a folder of its own")
    dropped = _dropped_cases(man, sweep, read_records(directory))
    if dropped:
        c = dropped[0]
        raise SweepError(f"{directory} holds {len(dropped)} finished case(s) of sweep "
                         f"'{sweep.name}' that this version of it does not have (e.g. part "
                         f"'{c.get('part')}' #{c.get('index')} {c.get('params')}); nothing "
                         "was written: run the changed sweep into a new folder (values added "
                         "to an axis are fine: the finished cases are kept)")


def _dropped_cases(manifest: dict, sweep: Sweep, records: dict) -> list[dict]:
    """Cases of the store's manifest that have a record but are not cases of ``sweep``."""
    keys = {c.key for c in sweep.cases}
    return [c for c in manifest["cases"] if c["key"] in records and c["key"] not in keys]


def _claim(sweep: Sweep, directory: Path) -> None:
    """Under the store's lock: check the folder again and write this sweep's manifest."""
    check_store_owner(sweep, directory)
    write_atomic(directory / MANIFEST_FILE, json.dumps(jsonable(sweep.manifest()), indent=1))


@contextlib.contextmanager
def _backend(scheduler: str | None, workers: int, needed: bool):
    """The dask client of ``scheduler`` (connected before the store is touched, so an
    unreachable scheduler writes nothing), or None for the local pool or nothing to run."""
    if scheduler is None or not needed:
        yield None
        return
    with dask_client(scheduler, workers) as client:
        yield client


@contextlib.contextmanager
def _runner(todo: list[SweepCase], sweep: Sweep, workers: int, scheduler: str | None, client,
            stop: StopFlag):
    tasks = [c.as_task(sweep) for c in todo]
    if not tasks:
        yield iter(())
        return
    gen = run_dask(tasks, client, stop) if scheduler else run_local(tasks, workers, stop)
    try:
        yield gen
    finally:
        gen.close()
