"""The ``multicontact`` command line: outputs and exit codes (0 agree, 1 fail, 2 bad input)."""

from __future__ import annotations

import json

import pytest

from compare.cli import main

BASE = """[profile]
type = "cylinder"
R = 10.0
[material]
E = 200000.0
nu = 0.3
[load]
P = 100.0
mu = 0.3
Q0 = 15.0
"""


def write(tmp_path, text: str, name: str = "case.toml"):
    f = tmp_path / name
    f.write_text(text)
    return str(f)


@pytest.mark.parametrize("text, words", [
    (BASE + "colour = 'red'\n", "unknown key 'load.colour'"),
    (BASE.replace("P = 100.0", "P = 'x'"), "'load.P' must be a number"),
    (BASE.replace("R = 10.0", ""), "missing required key 'profile.R'"),
    (BASE.replace("nu = 0.3", "nu = 0.5"), "material.nu=0.5 is not allowed"),
    (BASE.replace("Q0 = 15.0", "Q0 = 31.0"), "load.Q0=31.0 is not allowed"),
])
@pytest.mark.parametrize("command", ["run", "report"])
def test_bad_input_exit_2_one_message_no_report(tmp_path, capsys, text, words, command):
    case = write(tmp_path, text)
    out = tmp_path / "rep"
    argv = [command, "hertz", case] + (["-o", str(out)] if command == "report" else [])
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and len(err.splitlines()) == 1
    assert not out.exists() and not list(tmp_path.glob(".rep*"))


def test_list_json(capsys):
    assert main(["list", "--json"]) == 0
    names = [c["name"] for c in json.loads(capsys.readouterr().out)]
    assert "hertz" in names and "double_wedge_a" in names


def test_solve_json(capsys):
    assert main(["solve", "cattaneo", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    a, b = d["zones"][0]
    assert b == pytest.approx(-a) and len(d["samples"]) == 6


def test_run_agrees_exit_0_and_fails_exit_1(tmp_path, capsys):
    assert main(["run", "hertz", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d[0]["passed"] is True
    strict = write(tmp_path, BASE + "[tolerances]\nedge = 1e-9\n", "strict.toml")
    assert main(["run", strict]) == 1
    assert "FAIL" in capsys.readouterr().out


def test_fem_writes_vtk(tmp_path, capsys):
    out = tmp_path / "vtk"
    assert main(["fem", "hertz", "-o", str(out), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert (out / "history.pvd").is_file() and d["stage_ends"][0]["stage"] == 1


def test_plain_numbers_round_off_and_version(capsys):
    """`solve` prints round-off as 0 with its scale and no numpy reprs; --version works."""
    assert main(["solve", "hertz"]) == 0
    out = capsys.readouterr().out
    assert "M = 0 (round-off: " in out and "np." not in out
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and capsys.readouterr().out.startswith("multicontact ")


@pytest.mark.parametrize("argv, words", [
    (["converge", "hertz", "--levels", "0"], "--levels 0 is not allowed for an h-study"),
    (["converge", "hertz", "--levels", "1", "0"], "--levels 1 0 is not allowed"),
    (["converge", "hertz", "--kind", "domain", "--values", "12", "6"], "--values 12 6 is not"),
    (["report", "-o", "REP", "--levels", "1", "0"], "--levels 1 0 is not allowed"),
    (["report", "-o", "REP", "--convergence", "hertz", "--levels", "0"], "--levels 0 is not"),
    (["report", "-o", "afile/REP"], "cannot write in"),
])
def test_study_and_output_refused_before_any_run(tmp_path, capsys, monkeypatch, argv, words):
    """A study out of refining order, or an output folder that cannot be written: exit 2, one
    line, before any solve (the analytic solution is never reached)."""
    import importlib

    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("x")
    cv = importlib.import_module("compare.convergence")
    monkeypatch.setattr(cv, "solve_case", lambda case: pytest.fail("a refused run was solved"))
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and len(err.splitlines()) == 1, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]


def test_report_levels_apply_to_the_default_study(tmp_path, monkeypatch):
    """`report --levels` without --convergence sets the default study's levels (it was ignored)."""
    import importlib

    rep = importlib.import_module("compare.report")
    seen = {}

    def fake(plan, progress):
        seen.update({name: levels for name, (_, levels) in plan.studies.items()})
        return {"index": str(tmp_path / "index.html"), "passed": True, "elapsed_seconds": 0.0}

    monkeypatch.setattr(rep, "build_report", fake)
    monkeypatch.setattr("compare.cli._size", lambda path: "0 B")
    main(["report", "hertz", "-o", str(tmp_path / "r"), "--levels", "0", "1", "2", "--no-fig5"])
    assert seen == {"hertz": (0, 1, 2)}
    main(["report", "hertz", "-o", str(tmp_path / "r")])
    assert seen == {"hertz": rep.DEFAULT_STUDY_LEVELS}
