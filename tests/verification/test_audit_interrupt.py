"""benchmarks/audit.py: "i of N" progress, and an interrupt (Ctrl-C: SIGINT to the process
group) writes the table of the finished cases, exits 130 and leaks no semaphores."""

from __future__ import annotations

import functools
import json
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

#: Run in the child before exec: Ctrl-C's default action, as from a terminal (a shell's
#: background job, e.g. a CI runner's, inherits SIGINT ignored, and Python keeps it ignored).
DEFAULT_SIGINT = functools.partial(signal.signal, signal.SIGINT, signal.SIG_DFL)
#: Bound on waiting for the second finished case, and then for the interrupted audit to exit
#: (a case solves in well under a second; the workers' interpreter start-up dominates).
WAIT_S = 120


def read_lines(stream, lines: list[str], seen: threading.Event, mark: str) -> None:
    """Collect a pipe's lines; set ``seen`` at the first line starting with mark or at EOF."""
    for line in stream:
        lines.append(line)
        if line.startswith(mark):
            seen.set()
    seen.set()


def test_interrupt_writes_partial_table(tmp_path):
    out = tmp_path / "audit"
    env = os.environ | {"PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, str(ROOT / "benchmarks" / "audit.py"), "--n", "400",
                             "--out", str(out)], stderr=subprocess.PIPE,
                            stdout=subprocess.DEVNULL, text=True, env=env,
                            start_new_session=True, preexec_fn=DEFAULT_SIGINT)
    lines, second = [], threading.Event()
    reader = threading.Thread(target=read_lines, args=(proc.stderr, lines, second, "[2 of 400, "))
    reader.start()
    try:  # a slow machine fails this test, it never leaves the audit's processes behind
        assert second.wait(WAIT_S), "no second case within WAIT_S: " + "".join(lines)
        os.killpg(proc.pid, signal.SIGINT)
        proc.wait(timeout=WAIT_S)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        reader.join()
    err = "".join(lines)
    assert proc.returncode == 130, err
    assert "[1 of 400, " in err and "interrupted after" in err
    assert "leaked semaphore" not in err and "Traceback" not in err
    doc = json.loads((out / "audit.json").read_text())
    assert 2 <= doc["summary"]["cases"] < 400
    assert (out / "audit.md").is_file()
