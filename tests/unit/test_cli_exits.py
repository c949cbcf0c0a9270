"""The ``multicontact`` command line's ways out: SIGTERM and Ctrl-C (one line, 143 / 130, no
temporary output left), a closed stdout (quiet, 141), a solver failure naming its case (3), and
options that would be ignored (refused with one line, exit 2, before anything runs)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from compare.cli import main

ROOT = Path(__file__).resolve().parents[2]
#: 128 + the signal number: SIGINT, SIGTERM, SIGPIPE.
EXIT_SIGINT, EXIT_SIGTERM, EXIT_PIPE = 130, 143, 141
#: Bound on a child command (it computes nothing: the FE side is replaced).
WAIT_S = 60
#: A child ``multicontact fem hertz -o OUT`` whose FE run is a stand-in and whose VTK writer
#: stops it (SIGNAL) while its temporary output folder holds a file.
INTERRUPTED_FEM = """
import os, signal, sys, time
import compare.analytic_side, compare.fem_side, fem
from compare.cli import main

compare.analytic_side.solve_normal_case = lambda case: None
compare.fem_side.run_fem = lambda case, normal: None

def write_vtk(hist, folder, steps):
    (folder / "history.pvd").write_text("partial")
    if sys.argv[1] == "SIGINT":
        raise KeyboardInterrupt
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(WAIT)

fem.write_vtk = write_vtk
sys.exit(main(["fem", "hertz", "--level", "0", "-o", sys.argv[2]]))
""".replace("WAIT", str(WAIT_S))


def child(args: list[str], **kw) -> subprocess.CompletedProcess:
    env = os.environ | {"PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, *args], env=env, text=True, timeout=WAIT_S,
                          stderr=subprocess.PIPE, **kw)


@pytest.mark.parametrize("how, code, line", [
    ("SIGTERM", EXIT_SIGTERM, "multicontact: interrupted (SIGTERM)"),
    ("SIGINT", EXIT_SIGINT, "multicontact: interrupted"),
])
def test_interrupt_one_line_and_no_temporary_output(tmp_path, how, code, line):
    """SIGTERM takes Ctrl-C's way out: the atomic output's temporary folder is removed (a
    SIGTERM used to leave .OUT.tmp-xxxx behind) and one line replaces the traceback."""
    out = tmp_path / "vtk"
    proc = child(["-c", INTERRUPTED_FEM, how, str(out)], stdout=subprocess.PIPE)
    assert proc.returncode == code, proc.stderr
    assert proc.stderr.strip() == line
    assert list(tmp_path.iterdir()) == []


def test_closed_stdout_quiet_exit_141(tmp_path):
    """``multicontact list | head -0``: the reader has gone; no BrokenPipeError traceback."""
    read, write = os.pipe()
    os.close(read)
    try:
        proc = child(["-m", "compare.cli", "list"], stdout=write)
    finally:
        os.close(write)
    assert proc.returncode == EXIT_PIPE
    assert proc.stderr == ""


#: The library Hertz case under a moment it cannot carry (the solver's self-check fails).
BAD_M = (Path(__file__).parents[2] / "compare" / "cases" / "hertz.toml").read_text().replace(
    "[load]\n", "[load]\nM = 1e6\n")


def test_run_solver_failure_names_the_case_after_the_finished_ones(tmp_path, capsys):
    bad = tmp_path / "badm.toml"
    bad.write_text(BAD_M)
    assert main(["run", "hertz", str(bad), "--level", "0"]) == 3
    cap = capsys.readouterr()
    assert cap.out.startswith("hertz: agrees")
    err = cap.err.strip()  # (the progress bar leaves a blank line when stderr is no terminal)
    assert err.startswith("multicontact: solver did not converge in case badm: ")
    assert len(err.splitlines()) == 1
    assert main(["run", "hertz", str(bad), "--level", "0", "--json"]) == 3
    doc = json.loads(capsys.readouterr().out)
    assert doc["error"]["exit_code"] == 3 and "in case badm" in doc["error"]["message"]
    assert [r["case"]["name"] for r in doc["results"]] == ["hertz"]


def test_report_solver_failure_names_the_unit(tmp_path, capsys, monkeypatch):
    """The units finish in order and each is listed as it does: the failure is the next."""
    import analytic.errors
    import compare.report as rep

    def fake(plan, progress):
        progress("case hertz: agrees")
        raise analytic.errors.ConvergenceError("self-check failed")

    monkeypatch.setattr(rep, "build_report", fake)
    bad = tmp_path / "badm.toml"
    bad.write_text(BAD_M)
    argv = ["report", "hertz", str(bad), "-o", str(tmp_path / "r"), "--no-fig5"]
    assert main(argv) == 3
    err = capsys.readouterr().err
    assert "case hertz: agrees" in err
    assert ("multicontact: solver did not converge in case badm: self-check failed; no report "
            "was written") in err


@pytest.mark.parametrize("argv, words", [
    (["converge", "hertz", "--kind", "penalty", "--levels", "0", "1"],
     "--levels applies to --kind h"),
    (["converge", "hertz", "--kind", "h", "--values", "1", "2"],
     "--values applies to --kind penalty or domain"),
    (["fem", "hertz", "--vtk", "all"], "--vtk all applies to the VTK series written with -o"),
    (["fem", "hertz", "--force"], "--force applies to the folder of -o DIR or --export DIR"),
    (["run", "hertz", "--force"], "--force applies to the folder of --vtk DIR"),
    (["verify", "hertz", "R", "--force"], "--force applies to the report folder of -o DIR"),
    (["verify", "hertz", "R", "--fem-levels", "0", "1"], "--fem-levels applies to the report"),
    (["verify", "hertz", "R1", "R2", "-o", "OUT", "--fem-levels", "0"],
     "--fem-levels 0 is not allowed for an h-study: need at least two levels"),
    (["report", "hertz", "-o", "OUT", "--convergence", "--levels", "0", "1"],
     "--convergence without a case asks for none"),
    (["report", "--sweep", "SW", "hertz", "--no-fig5", "--vtk", "all"],
     "CASE arguments, --no-fig5, --vtk: not for a sweep report"),
    (["report", "--sweep", "SW", "--convergence"], "--convergence: not for a sweep report"),
    (["sweep", "fig5_sweep", "-o", "OUT", "--workers", "0", "--dry-run"],
     "workers=0 is not allowed: need >= 1"),
    (["sweep", "fig5_sweep", "-o", "OUT", "--workers", "2", "--scheduler", "tcp://h:8786"],
     "workers=2 does not apply to scheduler tcp://h:8786"),
])
def test_ignored_options_refused_before_anything_runs(tmp_path, capsys, monkeypatch, argv,
                                                      words):
    """Options the command would ignore: one line, exit 2, nothing computed or written."""
    import importlib

    def ran(*args, **kw):
        pytest.fail("a refused command ran")

    for mod, name in (("fem_side", "run_fem"), ("run", "run_case"),
                      ("convergence", "convergence"), ("report", "write_report")):
        monkeypatch.setattr(importlib.import_module(f"compare.{mod}"), name, ran)
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and len(err.splitlines()) == 1, err
    assert list(tmp_path.iterdir()) == []
