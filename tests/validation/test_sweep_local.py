"""Sweeps on the local process pool: results vs the analytic Fig. 5 data, failures recorded,
interrupt (SIGINT / SIGTERM) and resume, the sweep report."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import analytic
from compare import sweep as sw
from compare.sweep.cli import EXIT_FAILED_CASES, EXIT_SIGNAL
from compare.sweep.report import write_sweep_report
from compare.sweep.store import RESULTS_FILE

BASE = """
[base]
profile = { type = "double_wedge", c = 1.0, phi_inner = 0.11, phi_outer = 0.07 }
material = { A = 1.0 }
load = { P = 0.05, mu = 0.3 }
"""
PAIRS = [(0.11, 0.07), (0.07, 0.11)]
#: Sweep records (one solve per load) vs analytic.fig5_data (continuation along the loads):
#: two independent paths through the normal solver, which converges to ~1e-12.
FIG5_RTOL = 1e-7
#: Bound on waiting for a subprocess sweep (a hang fails the test instead of blocking).
WAIT_S = 90


def overlap_sweep(path: Path, loads) -> Path:
    inner = ", ".join(str(a) for a, _ in PAIRS)
    outer = ", ".join(str(b) for _, b in PAIRS)
    path.write_text(f'task = "overlap"\n[zip.angles]\n"profile.phi_inner" = [{inner}]\n'
                    f'"profile.phi_outer" = [{outer}]\n[axes]\n"load.P" = {list(loads)}\n'
                    + BASE)
    return path


def lines(d: Path) -> list[dict]:
    f = d / RESULTS_FILE
    return [json.loads(x) for x in f.read_text().splitlines()] if f.exists() else []



@pytest.mark.parametrize("workers", [0, -1])
def test_workers_below_one_refused_before_the_folder(tmp_path, workers):
    """--workers 0 is refused like -1 (it used to mean 'all cores' without a word)."""
    out = tmp_path / "out"
    with pytest.raises(sw.SweepError, match=f"workers={workers} is not allowed: need >= 1"):
        sw.run_sweep(overlap_sweep(tmp_path / "s.toml", [0.01]), out, workers=workers,
                     progress=False)
    assert not out.exists()

def test_overlap_sweep_matches_fig5_data_and_reports(tmp_path):
    loads = [0.01, 0.03, 0.06]
    out = tmp_path / "out"
    res = sw.run_sweep(overlap_sweep(tmp_path / "s.toml", loads), out, workers=2,
                       progress=False)
    assert (res.total, res.ok, res.failed, res.remaining) == (6, 6, 0, 0)
    recs = lines(out)
    assert len(recs) == 6 and len({r["key"] for r in recs}) == 6
    for phi1, phi2 in PAIRS:
        ref = analytic.fig5_data(phi1, phi2, loads=loads)
        got = sorted((r["params"]["load.P"], r["metrics"]) for r in recs
                     if r["params"]["profile.phi_inner"] == phi1)
        for name, want in (("extent", ref.actual), ("extent_overlapped", ref.overlapped),
                           ("Pe", ref.Pe), ("kappa", ref.kappa)):
            np.testing.assert_allclose([m[name] for _, m in got], want, rtol=FIG5_RTOL)
    rep = write_sweep_report(out)
    html = (rep / "index.html").read_text()
    md = (rep / "report.md").read_text()
    assert html.count("data:image/png;base64,") >= 3 and "<img" in html
    for link in [x.split("](")[1].split(")")[0] for x in md.splitlines() if x.startswith("![")]:
        assert (rep / link).stat().st_size > 5000
    summ = json.loads((rep / "summary.json").read_text())
    assert (summ["total"], summ["ok"], summ["failed"]) == (6, 6, 0)


def test_failing_case_is_recorded_and_sweep_goes_on(tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text('[parts.fe]\ntask = "fem"\nset = { "fem.level" = -3, "fem.window_margin" = 1.0 }\n'
                 'axes = { "load.P" = [0.002] }\n'
                 '[parts.an]\ntask = "analytic"\naxes = { "load.P" = [0.02, 0.04] }\n' + BASE)
    out = tmp_path / "out"
    code = sw.main(["sweep", str(f), "-o", str(out), "--workers", "2", "--no-progress"])
    assert code == EXIT_FAILED_CASES
    recs = {r["part"] + str(r["index"]): r for r in lines(out)}
    assert set(recs) == {"fe0", "an0", "an1"}
    bad = recs["fe0"]
    assert bad["status"] == "failed" and bad["metrics"] == {}
    assert bad["error"]["type"] == "InputError" and "mesh too coarse" in bad["error"]["message"]
    assert recs["an0"]["status"] == recs["an1"]["status"] == "ok"
    assert "1 failed" in capsys.readouterr().out
    # a resume does not rerun the failed case unless asked
    assert sw.run_sweep(f, out, workers=1, progress=False).skipped == 3
    again = sw.run_sweep(f, out, workers=1, progress=False, retry_failed=True)
    assert (again.skipped, again.failed) == (2, 1)
    summ = json.loads((write_sweep_report(out) / "summary.json").read_text())
    assert summ["failed"] == 1 and "mesh too coarse" in summ["failures"][0]["error"]


def run_cli(args: list[str]) -> subprocess.Popen:
    code = "import sys; from compare.sweep import main; sys.exit(main(sys.argv[1:]))"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    return subprocess.Popen([sys.executable, "-c", code, *args], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_interrupt_and_resume_runs_only_unfinished(tmp_path, signum):
    loads = [float(x) for x in np.round(np.linspace(0.01, 0.1, 7), 6)]
    study = overlap_sweep(tmp_path / "s.toml", loads)
    out = tmp_path / "out"
    n = 2 * len(loads)
    proc = run_cli(["sweep", str(study), "-o", str(out), "--workers", "1", "--no-progress"])
    try:
        t0 = time.monotonic()
        while len(lines(out)) < 3:
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() - t0 < WAIT_S, "sweep made no progress"
            time.sleep(0.05)
        proc.send_signal(signum)
        stdout, stderr = proc.communicate(timeout=WAIT_S)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == EXIT_SIGNAL[signum], stderr
    assert "interrupted" in stdout and "resume" in stdout
    first = lines(out)
    done = {r["key"] for r in first}
    assert 3 <= len(first) < n and len(done) == len(first)
    assert len({r["run"] for r in first}) == 1
    # resume: exactly the unfinished cases run, nothing twice
    res = sw.run_sweep(study, out, workers=2, progress=False)
    assert (res.skipped, res.ok, res.failed, res.remaining) == (len(first), n - len(first), 0, 0)
    allrec = lines(out)
    assert allrec[:len(first)] == first
    second = allrec[len(first):]
    assert {r["run"] for r in second} == {res.run_id}
    assert not done & {r["key"] for r in second}
    assert len({r["key"] for r in allrec}) == len(allrec) == n
    assert {r["key"] for r in allrec} == {c.key for c in sw.load_sweep(study).cases}
