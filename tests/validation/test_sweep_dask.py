"""Sweeps on a real dask.distributed cluster on loopback: a scheduler and two worker
processes started here (``python -m dask scheduler`` / ``python -m dask worker``) and stopped
after each test.  Results must equal the local process-pool run; killing a worker mid-sweep
must lose and duplicate nothing."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

pytest.importorskip("distributed")

from compare import sweep as sw  # noqa: E402
from compare.sweep.store import RESULTS_FILE  # noqa: E402

BASE = """
[base]
profile = { type = "double_wedge", c = 1.0, phi_inner = 0.11, phi_outer = 0.07 }
material = { A = 1.0 }
load = { P = 0.05, mu = 0.3 }
"""
LOADS = [0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08]
#: Bound on cluster start-up and on every wait (a hang fails instead of blocking the suite).
START_S = 60
#: Same code, inputs and BLAS threads on both sides: records agree to the solver tolerance;
#: quantities that are zero up to round-off (M of a symmetric case, residuals ~1e-14) differ
#: in their noise between processes, hence the absolute floor.
SAME_RTOL = 1e-9
SAME_ATOL = 1e-12


def study(path: Path) -> Path:
    path.write_text('task = "overlap"\n[zip.angles]\n"profile.phi_inner" = [0.11, 0.07]\n'
                    f'"profile.phi_outer" = [0.07, 0.11]\n[axes]\n"load.P" = {LOADS}\n' + BASE)
    return path


@contextlib.contextmanager
def cluster(tmp: Path, n_workers: int = 2):
    """Scheduler + ``n_workers`` single-thread worker processes (no nanny) on 127.0.0.1."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    sfile = tmp / "scheduler.json"
    dask = [sys.executable, "-m", "dask"]
    logs = []

    def start(args, name):
        log = open(tmp / f"{name}.log", "w")
        logs.append(log)
        return subprocess.Popen(dask + args, env=env, stdout=log, stderr=subprocess.STDOUT)

    procs = [start(["scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                    "--scheduler-file", str(sfile)], "scheduler")]
    try:
        t0 = time.monotonic()
        while not sfile.exists() or not sfile.read_text().strip():
            assert procs[0].poll() is None, (tmp / "scheduler.log").read_text()
            assert time.monotonic() - t0 < START_S, "scheduler did not start"
            time.sleep(0.1)
        address = json.loads(sfile.read_text())["address"]
        workers = [start(["worker", address, "--nthreads", "1", "--no-nanny", "--no-dashboard",
                          "--host", "127.0.0.1", "--name", f"w{i}"], f"worker{i}")
                   for i in range(n_workers)]
        procs += workers
        from distributed import Client

        with Client(address, timeout=START_S) as c:
            c.wait_for_workers(n_workers, timeout=START_S)
        yield address, workers
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                p.terminate()
        for p in procs:
            try:
                p.wait(timeout=15)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait(timeout=5)
        for log in logs:
            log.close()


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The local process-pool run of the study: {key: record}."""
    tmp = tmp_path_factory.mktemp("local")
    res = sw.run_sweep(study(tmp / "s.toml"), tmp / "out", workers=2, progress=False)
    assert res.ok == 2 * len(LOADS)
    return sw.read_records(tmp / "out")


def lines(d: Path) -> list[dict]:
    return [json.loads(x) for x in (d / RESULTS_FILE).read_text().splitlines()]


def assert_same(got: dict, ref: dict) -> None:
    assert set(got) == set(ref)
    for key, r in ref.items():
        g = got[key]
        assert (g["status"], g["params"], g["part"], g["index"]) == \
            (r["status"], r["params"], r["part"], r["index"])
        assert set(g["metrics"]) == set(r["metrics"])
        for name, v in r["metrics"].items():
            w = g["metrics"][name]
            if isinstance(v, float):
                assert w == pytest.approx(v, rel=SAME_RTOL, abs=SAME_ATOL), (key, name)
            else:
                assert w == v, (key, name)


def test_dask_cluster_equals_local_run(tmp_path, reference):
    with cluster(tmp_path) as (address, _):
        res = sw.run_sweep(study(tmp_path / "s.toml"), tmp_path / "out", scheduler=address,
                           progress=False)
    assert (res.ok, res.failed, res.remaining) == (len(reference), 0, 0)
    recs = lines(tmp_path / "out")
    assert len(recs) == len(reference)
    assert_same(sw.read_records(tmp_path / "out"), reference)
    assert len({r["worker"]["pid"] for r in recs}) == 2, "both workers should have run cases"


def test_killed_worker_loses_and_duplicates_nothing(tmp_path, reference):
    out = tmp_path / "out"
    killed = threading.Event()
    with cluster(tmp_path) as (address, workers):
        victim = workers[0]

        def kill_when_running():
            t0 = time.monotonic()
            while time.monotonic() - t0 < START_S:
                f = out / RESULTS_FILE
                if f.exists() and len(f.read_text().splitlines()) >= 3:
                    victim.send_signal(signal.SIGKILL)
                    killed.set()
                    return
                time.sleep(0.02)

        th = threading.Thread(target=kill_when_running, daemon=True)
        th.start()
        res = sw.run_sweep(study(tmp_path / "s.toml"), out, scheduler=address, progress=False)
        th.join(timeout=START_S)
        assert killed.is_set() and victim.wait(timeout=10) == -signal.SIGKILL
    assert res.remaining == 0
    recs = lines(out)
    assert len(recs) == len({r["key"] for r in recs}) == len(reference)
    assert all(r["status"] == "ok" for r in recs)
    assert_same(sw.read_records(out), reference)
    late = [r for r in recs[3:] if r["worker"]["pid"] == victim.pid]
    assert len(late) <= 1, "the killed worker cannot deliver more than its in-flight case"
