""".ci/fastsolver.sh: the optional CHOLMOD build is tried when its prerequisites exist, not
repeated after a failure until one of them changes, and a missing one is named at the end."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / ".ci" / "fastsolver.sh"

FAKE_PYTHON = """#!/bin/sh
case "$*" in
  *sysconfig*) echo "{include}" ;;
  *tomllib*) echo "scikit-sparse==0.4.16" ;;
  "-m pip"*) echo pip >> "{calls}"; exit 1 ;;
  *) exit 1 ;;
esac
"""


def fake_venv(tmp_path: Path, include: Path) -> tuple[Path, Path]:
    """A venv whose python has its headers in ``include``, no scikit-sparse, and a pip that
    fails (each call is counted in the returned file)."""
    py = tmp_path / "venv" / "bin" / "python"
    py.parent.mkdir(parents=True)
    calls = tmp_path / "pip_calls"
    py.write_text(FAKE_PYTHON.format(include=include, calls=calls))
    py.chmod(0o755)
    return py, calls


def run(mode: str, py: Path) -> str:
    out = subprocess.run(["bash", str(SCRIPT), mode, str(py)], cwd=ROOT, capture_output=True,
                         text=True, timeout=60, check=True)
    return out.stdout + out.stderr


def pip_calls(calls: Path) -> int:
    return len(calls.read_text().split()) if calls.exists() else 0


def test_missing_headers_named_and_no_build_tried(tmp_path) -> None:
    py, calls = fake_venv(tmp_path, tmp_path / "no-such-include")
    run("install", py)
    assert pip_calls(calls) == 0
    out = run("check", py)
    assert "NOT available" in out and "no-such-include/Python.h (Debian: python3-dev)" in out


@pytest.mark.skipif(not Path("/usr/include/suitesparse/cholmod.h").is_file()
                    or shutil.which("cc") is None,
                    reason="needs SuiteSparse headers and a C compiler (the other prerequisites)")
def test_failed_build_retried_only_when_a_prerequisite_changes(tmp_path) -> None:
    include = tmp_path / "include"
    include.mkdir()
    (include / "Python.h").write_text("")
    py, calls = fake_venv(tmp_path, include)
    run("install", py)
    assert pip_calls(calls) == 1
    run("install", py)
    assert pip_calls(calls) == 1  # same prerequisites: not tried again
    assert "The build failed" in run("check", py)
    st = (include / "Python.h").stat()
    os.utime(include / "Python.h", (st.st_atime, st.st_mtime + 10))  # headers reinstalled
    run("install", py)
    assert pip_calls(calls) == 2


def test_check_names_the_blas_under_cholmod() -> None:
    """The closing line names the BLAS library CHOLMOD resolves, and calls Debian's reference
    BLAS slow (it made the level-6 history 2.3x longer, README)."""
    pytest.importorskip("sksparse.cholmod")
    if shutil.which("ldd") is None:
        pytest.skip("needs ldd")
    line = run("check", Path(sys.executable))
    assert line.startswith("multicontact: sparse backend: CHOLMOD (scikit-sparse), BLAS: ")
    if "/blas/libblas" in line:
        assert "slow reference BLAS" in line and "libopenblas0-serial" in line
