"""A case's name names output files and folders (``run --vtk DIR/<name>/``, a report's
``figures/<name>_0.png``): it must be one safe file name, and the cases of one report their
own names.  A case file with ``name = "/tmp/x"`` wrote its VTK series into /tmp/x (over a
user's history.pvd there), ``name = "../x"`` escaped the output folder, and two cases of one
name overwrote each other's figures."""

from __future__ import annotations

import re
from pathlib import Path
from types import SimpleNamespace

import pytest

import compare.report as rp
from compare.cases import Case, load_case, read_case
from compare.cli import main
from compare.errors import CaseError

NAME_MAX = 100  # compare.case_format.NAME_MAX: the message says it
CATTANEO = (Path(__file__).parents[2] / "compare" / "cases" / "cattaneo.toml").read_text()


def case_file(folder: Path, stem: str, name: str | None = None) -> Path:
    """The library Cattaneo case at FE level 0 as ``folder/stem.toml``, with a name key."""
    head = "" if name is None else f'name = "{name}"\n'
    path = folder / f"{stem}.toml"
    path.write_text(f"{head}{CATTANEO}\n[fem]\nlevel = 0\n", encoding="utf-8")
    return path


@pytest.mark.parametrize("name", ["/tmp/fix_cli/victimdir", "../escaped", "a/b", "a\\\\b",
                                  "..", ".", ".hidden", "x..y", "a b", "tab\\t", "é",
                                  "n" * (NAME_MAX + 1)])
def test_unsafe_name_refused_with_one_message(tmp_path, name):
    with pytest.raises(CaseError, match=r"name=.* is not allowed \(.*\): need 1 to 100 "
                       r"letters, digits, '_', '-' or '\.', not starting with '\.' and without "
                       r"'\.\.' .*\(evil.toml\)$"):
        read_case(case_file(tmp_path, "evil", name))


@pytest.mark.parametrize("name", ["cat0", "Hertz-2.v1", "_x", "-y", "n" * NAME_MAX])
def test_safe_names_accepted(tmp_path, name):
    assert read_case(case_file(tmp_path, "c", name)).name == name


def test_empty_name_refused(tmp_path):
    with pytest.raises(CaseError, match="must be a non-empty string"):
        read_case(case_file(tmp_path, "c", ""))


@pytest.mark.parametrize("stem", ["my case", ".", ".hidden"])
def test_file_name_that_cannot_be_a_case_name_refused(tmp_path, stem):
    """Without a name key the file name gives the name: the same rule, and the way out."""
    with pytest.raises(CaseError, match=rf"case file {stem}\.toml: its case name '{stem}' "
                       r"\(the file name without \.toml\) is not allowed .*rename the file or "
                       r"give the case a name = "):
        read_case(case_file(tmp_path, stem))
    assert read_case(case_file(tmp_path, stem, "ok_name")).name == "ok_name"


def test_from_profile_name_checked():
    lib = load_case("hertz")
    with pytest.raises(CaseError, match=r"name='\.\./x' is not allowed"):
        Case.from_profile(lib.profile, lib.P, E=lib.E, nu=lib.nu, mu=lib.mu, name="../x")


def test_cli_refuses_the_name_before_anything_is_written(tmp_path, capsys):
    """`run evil.toml --vtk OUT` with name = "<a folder>": exit 2, the folder untouched."""
    victim = tmp_path / "victimdir"
    victim.mkdir()
    (victim / "history.pvd").write_text("user's")
    evil = case_file(tmp_path, "evil", str(victim))
    assert main(["run", str(evil), "--vtk", str(tmp_path / "out")]) == 2
    assert f"name='{victim}' is not allowed" in capsys.readouterr().err
    assert [p.name for p in victim.iterdir()] == ["history.pvd"]
    assert (victim / "history.pvd").read_text() == "user's"
    assert not (tmp_path / "out").exists()


@pytest.fixture
def no_build(monkeypatch):
    """write_report must refuse before it computes anything: building is a test failure."""
    def build(*args, **kwargs):
        pytest.fail("the report was computed")

    monkeypatch.setattr(rp, "_build", build)


def second_case(tmp_path: Path, first: Path, which: str) -> Path | str:
    if which == "copy":
        (tmp_path / "d").mkdir()
        return case_file(tmp_path / "d", "cattaneo")
    return {"same file": first, "library": "cattaneo"}[which]


@pytest.mark.parametrize("second", ["copy", "same file", "library"])
def test_report_refuses_two_cases_of_one_name(tmp_path, no_build, second):
    first = case_file(tmp_path, "cattaneo")
    other = second_case(tmp_path, first, second)
    with pytest.raises(CaseError, match=r"two cases are named 'cattaneo' \(.*\): their report "
                       "sections, figures and VTK series would overwrite each other"):
        rp.write_report([first, other], tmp_path / "rep", convergence_cases={}, fig5=False)
    assert not (tmp_path / "rep").exists()


def test_report_refuses_two_studies_of_one_name(tmp_path, no_build):
    named_hertz = case_file(tmp_path, "other", "hertz")
    with pytest.raises(CaseError, match="two cases are named 'hertz'.*convergence figures"):
        rp.write_report([], tmp_path / "rep", convergence_cases={"hertz": (0, 1),
                                                                  str(named_hertz): (0, 1)},
                        fig5=False)


def test_report_refuses_a_case_name_that_leaves_its_folder(tmp_path, no_build):
    """A case built in Python is not read from a file: its name is checked where it becomes a
    path."""
    lib = load_case("hertz")
    for name in ("../escaped", "a b"):  # the case files' rule (compare.case_format.check_name)
        case = Case(name=name, profile=lib.profile, profile_spec=lib.profile_spec, P=lib.P,
                    E=lib.E, nu=lib.nu, mu=lib.mu, Q0=0.0)
        with pytest.raises(CaseError, match=rf"name='{re.escape(name)}' is not allowed"):
            rp.write_report([case], tmp_path / "rep", convergence_cases={}, fig5=False)
        assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("clash", ["figures", "vtk", "vtk/cattaneo"])
def test_report_refuses_a_file_where_its_folders_go(tmp_path, no_build, clash):
    """A user's FILE named like a report folder: refused before computing, even with force
    (it was a FileExistsError traceback after the whole report)."""
    out = tmp_path / "rep"
    (out / clash).parent.mkdir(parents=True, exist_ok=True)
    (out / clash).write_text("mine")
    with pytest.raises(CaseError, match=rf"\({clash}: names of files or folders it writes\)"):
        rp.write_report(["cattaneo"], out, convergence_cases={}, fig5=False, force=True)
    assert (out / clash).read_text() == "mine"


def test_report_convergence_figure_found_for_a_study_given_by_path(tmp_path, monkeypatch):
    """`report --convergence cases/cat0.toml`: the study's figure was filed under the path and
    looked up under the case name (KeyError after the whole report)."""
    case = read_case(case_file(tmp_path, "cat0"))
    study = SimpleNamespace(case_name="cat0", orders={"pressure_l2_error": 1.0},
                            verdict=lambda: "converges", summary=lambda: {})
    monkeypatch.setattr(rp, "convergence", lambda case, levels: study)
    monkeypatch.setattr(rp.figures, "convergence_figure", lambda st: b"png")
    monkeypatch.setattr(rp, "_render", lambda sections, jobs, root: None)
    seen = {}
    monkeypatch.setattr(rp, "_write_documents",
                        lambda root, sections, studies, conv_figs, *rest: seen.update(conv_figs))
    root = tmp_path / "rep"
    root.mkdir()
    rp._build([], {str(tmp_path / "cat0.toml"): (case, (0, 1))}, False, root, lambda m: None,
              0.0, workers=1)
    assert seen == {"cat0": b"png"}
    assert (root / "figures" / "cat0_convergence.png").read_bytes() == b"png"


@pytest.mark.parametrize("out, export", [("x/vtk", "x"), ("x", "x/exp"), ("x", "x")])
def test_fem_nested_output_folders_refused_before_computing(tmp_path, capsys, out, export):
    """`fem -o X/vtk --export X` wrote X/vtk and then refused X ("holds files multicontact did
    not write"): nested (or equal) output folders are refused before the FE runs."""
    code = main(["fem", str(case_file(tmp_path, "c")), "-o", str(tmp_path / out),
                 "--export", str(tmp_path / export)])
    assert code == 2
    assert "give two separate folders, neither inside the other" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_run_vtk_refuses_two_cases_of_one_name(tmp_path, capsys):
    (tmp_path / "sub").mkdir()
    one, two = case_file(tmp_path, "c"), case_file(tmp_path / "sub", "c")
    assert main(["run", str(one), str(two), "--vtk", str(tmp_path / "v")]) == 2
    assert "two cases are named 'c'" in capsys.readouterr().err
    assert not (tmp_path / "v").exists()


def test_report_cli_plans_the_whole_folder_before_its_banner(tmp_path, capsys):
    """`report` checks its case folders (vtk/<name>/) with the rest, before it announces the
    run: one plan (compare.report.plan_report) serves the check and the build."""
    out = tmp_path / "rep"
    (out / "vtk").mkdir(parents=True)
    (out / "vtk" / "c").write_text("a user's file")
    argv = ["report", str(case_file(tmp_path, "c")), "-o", str(out), "--no-fig5", "--force",
            "--convergence"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "vtk/c" in err and "multicontact report: 1 case" not in err
    assert (out / "vtk" / "c").read_text() == "a user's file"
