"""Ctrl-C during ``multicontact report`` (SIGINT to the process group, as a terminal sends it):
the workers leave the interrupt to the report, which stops them at once (their results are
discarded) and writes nothing (compare._forkserver)."""

from __future__ import annotations

import functools
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

#: Run in the child before exec: Ctrl-C's default action, as from a terminal (a shell's
#: background job, e.g. a CI runner's, inherits SIGINT ignored, and Python keeps it ignored).
DEFAULT_SIGINT = functools.partial(signal.signal, signal.SIGINT, signal.SIG_DFL)
#: Seconds after the report's banner before the interrupt (its worker units then run).
RUNNING_S = 4.0
#: Bound on the interrupted report's exit: the workers are stopped, not waited for (a
#: convergence unit alone takes ~30 s).
EXIT_S = 20.0


def test_interrupted_report_stops_its_workers_and_writes_nothing(tmp_path):
    out = tmp_path / "report"
    env = os.environ | {"PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "compare.cli", "report", "-o", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            start_new_session=True, preexec_fn=DEFAULT_SIGINT)
    try:
        banner = proc.stderr.readline()  # the banner, printed before the units start
        time.sleep(RUNNING_S)
        os.killpg(proc.pid, signal.SIGINT)
        t0 = time.monotonic()
        _, err = proc.communicate(timeout=60)
        waited = time.monotonic() - t0
        err = banner + err
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode != 0
    assert waited < EXIT_S, waited
    assert "ForkServerProcess" not in err, err[-2000:]  # no worker printed a traceback
    assert not out.exists()
