"""benchmarks/audit.py: "i of N" progress, and an interrupt (Ctrl-C: SIGINT to the process
group) writes the table of the finished cases, exits 130 and leaks no semaphores."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: Bound on waiting for the first finished case (a case solves in well under a second; the
#: worker's interpreter start-up dominates).
WAIT_S = 120


def test_interrupt_writes_partial_table(tmp_path):
    out = tmp_path / "audit"
    env = os.environ | {"PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, str(ROOT / "benchmarks" / "audit.py"), "--n", "400",
                             "--out", str(out)], stderr=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True, env=env, start_new_session=True)
    seen, deadline = [], time.monotonic() + WAIT_S
    while time.monotonic() < deadline:
        line = proc.stderr.readline()
        seen.append(line)
        if line.startswith("[2 of 400, ") or not line:
            break
    os.killpg(proc.pid, signal.SIGINT)
    _, rest = proc.communicate(timeout=WAIT_S)
    err = "".join(seen) + rest
    assert proc.returncode == 130, err
    assert "[1 of 400, " in err and "interrupted after" in err
    assert "leaked semaphore" not in err and "Traceback" not in err
    doc = json.loads((out / "audit.json").read_text())
    assert 2 <= doc["summary"]["cases"] < 400
    assert (out / "audit.md").is_file()
