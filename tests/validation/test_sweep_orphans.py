"""A sweep whose coordinating process is killed with SIGKILL leaves no process behind.

SIGKILL cannot be caught, so the coordinator cannot stop its pool: the workers must notice and
end themselves (then the forkserver and the resource tracker exit too).  The sweep runs in its
own session, so every process it started (workers, forkserver, resource tracker, dask worker
processes) is found by its session id in /proc after the kill.  The store stays kill-safe:
every line is a complete record and a resume finishes the sweep without duplicates.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from compare import sweep as sw
from compare.sweep.store import RESULTS_FILE

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")

STUDY = """task = "overlap"
[axes]
"load.P" = [0.01, 0.014, 0.018, 0.022, 0.026, 0.03, 0.034, 0.038, 0.042, 0.046, 0.05, 0.06]
[base]
profile = { type = "double_wedge", c = 1.0, phi_inner = 0.11, phi_outer = 0.07 }
material = { A = 1.0 }
load = { P = 0.05, mu = 0.3 }
"""
#: Bound on waiting for the sweep's first records (a hang fails instead of blocking).
WAIT_S = 120
#: Workers poll their coordinator every COORDINATOR_POLL_S; allow for a loaded 2-core machine.
ORPHAN_GRACE_S = 5.0


def session_processes(sid: int) -> list[tuple[int, str]]:
    """Live (non-zombie) processes of session ``sid``: (pid, command line)."""
    out = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            cmd = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()[:120]
        except OSError:
            continue
        fields = stat[stat.rfind(")") + 2:].split()
        if int(fields[3]) == sid and fields[0] not in ("Z", "X"):
            out.append((int(entry.name), cmd))
    return out


def records(out: Path) -> list[dict]:
    f = out / RESULTS_FILE
    return [json.loads(x) for x in f.read_text().splitlines()] if f.exists() else []


def kill_sweep_after_two_records(study: Path, out: Path, extra: list[str]) -> list:
    """Start ``multicontact sweep --workers 2`` in a new session, SIGKILL the coordinator once
    two records are stored; return the session's processes alive ORPHAN_GRACE_S later."""
    code = "import sys; from compare.sweep import main; sys.exit(main(sys.argv[1:]))"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    proc = subprocess.Popen([sys.executable, "-c", code, "sweep", str(study), "-o", str(out),
                             "--workers", "2", "--no-progress", *extra], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    try:
        t0 = time.monotonic()
        while len(records(out)) < 2:
            assert proc.poll() is None, "the sweep ended before it could be killed"
            assert time.monotonic() - t0 < WAIT_S, "sweep made no progress"
            time.sleep(0.05)
        assert len(session_processes(proc.pid)) >= 3  # coordinator + its workers
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
        deadline = time.monotonic() + ORPHAN_GRACE_S
        while session_processes(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        return session_processes(proc.pid)
    finally:
        for pid, _ in session_processes(proc.pid):  # never leave them behind, pass or fail
            os.kill(pid, signal.SIGKILL)


@pytest.mark.parametrize("extra", [[], ["--scheduler", "local"]], ids=["pool", "dask-local"])
def test_sigkilled_sweep_leaves_no_process_and_resumes(tmp_path, extra):
    if extra:
        pytest.importorskip("distributed")
    study, out = tmp_path / "s.toml", tmp_path / "out"
    study.write_text(STUDY)
    left = kill_sweep_after_two_records(study, out, extra)
    assert left == [], f"orphans after SIGKILL of the coordinator: {left}"
    first = records(out)  # every stored line parses: no torn record
    assert len({r["key"] for r in first}) == len(first) >= 2
    res = sw.run_sweep(study, out, workers=2, progress=False)
    n = len(sw.load_sweep(study).cases)
    assert (res.skipped, res.ok + res.skipped, res.remaining) == (len(first), n, 0)
    assert len({r["key"] for r in records(out)}) == len(records(out)) == n
