"""Every command that writes a folder keeps a user's files there (issue 26): refused with exit 2
and one message without --force, written beside them with --force; two reports in distinct
folders stay intact."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from compare.cli import main
from compare.fileio import OWNED_FILE

NOTE = "my notes"
#: The cheapest FE run of a library case (Hertz at level 0: ~11e3 DOFs, about a second).
FAST = ["hertz", "--level", "0"]
SWEEP = """task = "overlap"
[axes]
"load.P" = [0.01, 0.03]
[base]
profile = { type = "double_wedge", c = 1.0, phi_inner = 0.11, phi_outer = 0.07 }
material = { A = 1.0 }
load = { P = 0.05, mu = 0.3 }
"""


@pytest.fixture(scope="module")
def export(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("exp") / "ours"
    assert main(["fem", *FAST, "--export", str(out)]) == 0
    return out


def commands(tmp_path: Path, export: Path) -> dict[str, list[str]]:
    """Each command writing into the folder ``DIR`` (placeholder)."""
    sweep_file = tmp_path / "s.toml"
    sweep_file.write_text(SWEEP)
    return {"fem -o": ["fem", *FAST, "-o", "DIR"],
            "fem --export": ["fem", *FAST, "--export", "DIR"],
            "run --vtk": ["run", *FAST, "--vtk", "DIR"],
            "verify -o": ["verify", "hertz", str(export), "-o", "DIR"],
            "sweep -o": ["sweep", str(sweep_file), "-o", "DIR", "--workers", "1",
                         "--no-progress"]}


@pytest.mark.parametrize("name", ["fem -o", "fem --export", "run --vtk", "verify -o",
                                  "sweep -o"])
def test_foreign_file_survives(tmp_path, export, capsys, name):
    argv = commands(tmp_path, export)[name]
    out = tmp_path / "dir"
    out.mkdir()
    (out / "notes.txt").write_text(NOTE)
    argv = [str(out) if a == "DIR" else a for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "notes.txt" in err and "--force" in err and len(err.splitlines()) == 1
    assert [p.name for p in out.iterdir()] == ["notes.txt"]
    assert main([*argv, "--force"]) in (0, 1)
    assert (out / "notes.txt").read_text() == NOTE
    assert len(list(out.iterdir())) > 1
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


def test_sweep_report_keeps_foreign_files(tmp_path, capsys):
    sweep_file = tmp_path / "s.toml"
    sweep_file.write_text(SWEEP)
    runs = tmp_path / "runs"
    assert main(["sweep", str(sweep_file), "-o", str(runs), "--workers", "1",
                 "--no-progress"]) == 0
    (runs / "report").mkdir()
    (runs / "report" / "notes.txt").write_text(NOTE)
    assert main(["report", "--sweep", str(runs)]) == 2
    assert "notes.txt" in capsys.readouterr().err
    assert main(["report", "--sweep", str(runs), "--force"]) == 0
    assert (runs / "report" / "notes.txt").read_text() == NOTE
    assert (runs / "report" / "index.html").is_file()


def test_report_then_verify_elsewhere_leaves_both_and_interrupt_keeps_them(
        tmp_path, export, capsys, monkeypatch):
    """`report -o DIR` keeps a foreign file (refused, then --force); `make run`, then the docs'
    verify example: two folders, both intact; verifying into the report's folder is refused; an
    interrupted report leaves the previous one as it was."""
    import compare.report as rep

    monkeypatch.chdir(tmp_path)
    report = Path("report")
    report.mkdir()
    (report / "notes.txt").write_text(NOTE)
    argv = ["report", "hertz", "-o", "report", "--convergence", "--no-fig5"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "notes.txt" in err and "--force" in err and len(err.splitlines()) == 1
    assert [p.name for p in report.iterdir()] == ["notes.txt"]
    assert main([*argv, "--force"]) == 0
    assert (report / "notes.txt").read_text() == NOTE and (report / "index.html").is_file()

    def files() -> dict:
        return {p: p.read_bytes() for p in report.rglob("*") if p.is_file()}

    before = files()
    assert main(["verify", "hertz", str(export), "-o", "report"]) == 2
    assert "output of `multicontact report`" in capsys.readouterr().err
    assert main(["verify", "hertz", str(export), "-o", "verify-report"]) == 0
    assert files() == before
    assert json.loads(Path("verify-report", OWNED_FILE).read_text())["command"] == "verify"
    assert Path("verify-report", "index.html").is_file()

    def interrupted(*args, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(rep, "run_case", interrupted)
    assert main([*argv, "--force"]) == 130  # one line, "multicontact: interrupted"
    assert capsys.readouterr().err.strip().endswith("multicontact: interrupted")
    assert files() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report", "verify-report"]


def test_fem_writes_only_what_was_asked(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["fem", *FAST]) == 0
    out = capsys.readouterr().out
    assert "no files written" in out and "np.float64" not in out and "contact [" in out
    assert main(["fem", *FAST, "--export", "ours"]) == 0
    assert [p.name for p in tmp_path.iterdir()] == ["ours"]  # no unrequested hertz-vtk/
