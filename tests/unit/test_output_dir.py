"""Output folders (compare.fileio.owned_output): a user's files are never lost, the previous
output is replaced in one transaction, refused folders stay untouched."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import pytest

from compare import fileio
from compare.errors import CaseError
from compare.fileio import OWNED_FILE, check_store, owned_output, plan_output


def write(out: Path, files: dict[str, str], command: str = "report", force: bool = False):
    with owned_output(out, command, force) as tmp:
        for name, text in files.items():
            (tmp / name).parent.mkdir(parents=True, exist_ok=True)
            (tmp / name).write_text(text)


def tree(root: Path) -> dict[str, str]:
    return {p.relative_to(root).as_posix(): p.read_text() for p in sorted(root.rglob("*"))
            if p.is_file() and p.name != OWNED_FILE}


def test_new_folder_has_manifest_and_umask_modes(tmp_path):
    old = os.umask(0o022)
    try:
        write(tmp_path / "rep", {"index.html": "a", "vtk/c/x.vtu": "b"})
    finally:
        os.umask(old)
    out = tmp_path / "rep"
    doc = json.loads((out / OWNED_FILE).read_text())
    assert doc["command"] == "report" and doc["files"] == ["index.html", "vtk/c/x.vtu"]
    for d in (out, out / "vtk", out / "vtk" / "c"):
        assert stat.S_IMODE(d.stat().st_mode) == 0o755, d  # not mkdtemp's 0700
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


@pytest.mark.parametrize("where", ["cwd", "home", "root", "parent of cwd"])
def test_current_home_root_and_their_parents_refused_outright(tmp_path, monkeypatch, where):
    work = tmp_path / "a" / "work"
    work.mkdir(parents=True)
    monkeypatch.chdir(work)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    (tmp_path / "home").mkdir()
    target = {"cwd": ".", "home": "~", "root": "/", "parent of cwd": ".."}[where]
    for force in (False, True):
        with pytest.raises(CaseError, match="refused"):
            plan_output(target, "report", force)
        with pytest.raises(CaseError, match="refused"):
            check_store(target, "sweep.json", force)
    assert list(work.iterdir()) == [] and list((tmp_path / "home").iterdir()) == []


def test_foreign_file_refused_then_kept_with_force(tmp_path):
    out = tmp_path / "rep"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    with pytest.raises(CaseError, match=r"did not write there \(notes.txt\)"):
        write(out, {"index.html": "new"})
    assert tree(out) == {"notes.txt": "mine"}
    write(out, {"index.html": "new"}, force=True)
    assert tree(out) == {"index.html": "new", "notes.txt": "mine"}
    write(out, {"report.md": "newer"}, force=True)  # the previous report's files go
    assert tree(out) == {"notes.txt": "mine", "report.md": "newer"}


def test_own_output_replaced_without_force_and_emptied_folders_removed(tmp_path):
    out = tmp_path / "rep"
    write(out, {"index.html": "1", "vtk/a/x.vtu": "1", "vtk/b/y.vtu": "1"})
    write(out, {"index.html": "2", "vtk/b/z.vtu": "2"})
    assert tree(out) == {"index.html": "2", "vtk/b/z.vtu": "2"}
    assert not (out / "vtk" / "a").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_other_commands_output_needs_force_and_is_kept(tmp_path):
    """--force writes beside another command's output and never deletes or overwrites it
    (it deleted it: `run --vtk FX --force` into `fem -o` output left only the run's files)."""
    out = tmp_path / "rep"
    write(out, {"history.pvd": "fem", "bodies_0001.vtu": "fem"}, command="fem")
    with pytest.raises(CaseError, match=r"output of `multicontact fem`.*--force to write beside "
                       r"it \(its files are kept"):
        write(out, {"cat0/history.pvd": "run"}, command="run")
    assert tree(out) == {"history.pvd": "fem", "bodies_0001.vtu": "fem"}
    write(out, {"cat0/history.pvd": "run"}, command="run", force=True)
    assert tree(out) == {"history.pvd": "fem", "bodies_0001.vtu": "fem",
                         "cat0/history.pvd": "run"}
    assert json.loads((out / OWNED_FILE).read_text())["files"] == ["cat0/history.pvd"]
    write(out, {"cat0/history.pvd": "run 2"}, command="run", force=True)  # its own: replaced
    assert tree(out) == {"history.pvd": "fem", "bodies_0001.vtu": "fem",
                         "cat0/history.pvd": "run 2"}


def test_force_never_overwrites_another_commands_file(tmp_path):
    out = tmp_path / "rep"
    write(out, {"index.html": "report"})
    with pytest.raises(CaseError, match=r"would overwrite .*\(index.html"):
        plan_output(out, "verify", True, expected=("index.html",))
    with pytest.raises(CaseError, match=r"would overwrite .*\(index.html"):
        write(out, {"index.html": "verify"}, command="verify", force=True)
    assert tree(out) == {"index.html": "report"}
    assert json.loads((out / OWNED_FILE).read_text())["command"] == "report"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_force_never_overwrites_a_foreign_file(tmp_path):
    out = tmp_path / "rep"
    out.mkdir()
    (out / "index.html").write_text("mine")
    with pytest.raises(CaseError, match="overwrite"):
        plan_output(out, "report", True, expected=("index.html",))
    with pytest.raises(CaseError, match="overwrite"):  # not announced: caught at the swap
        write(out, {"index.html": "new", "other": "x"}, force=True)
    assert tree(out) == {"index.html": "mine"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_failure_while_writing_leaves_previous_output(tmp_path):
    out = tmp_path / "rep"
    write(out, {"index.html": "old", "f/a.png": "old"})
    (out / "notes.txt").write_text("mine")
    with pytest.raises(KeyboardInterrupt), owned_output(out, "report", force=True) as tmp:
        (tmp / "index.html").write_text("half")
        raise KeyboardInterrupt
    assert tree(out) == {"index.html": "old", "f/a.png": "old", "notes.txt": "mine"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_failure_during_the_swap_rolls_back(tmp_path, monkeypatch):
    out = tmp_path / "rep"
    write(out, {"index.html": "old", "f/a.png": "old", "f/b.png": "old"})
    (out / "notes.txt").write_text("mine")
    real, calls = os.replace, []

    def flaky(src, dst):
        calls.append(dst)
        if len(calls) == 7:  # 4 old files (with the manifest) aside, 2 new ones in
            raise KeyboardInterrupt
        real(src, dst)

    monkeypatch.setattr(fileio.os, "replace", flaky)
    with pytest.raises(KeyboardInterrupt):
        write(out, {"index.html": "new", "f/a.png": "new", "g/c.png": "new"}, force=True)
    monkeypatch.setattr(fileio.os, "replace", real)
    assert tree(out) == {"index.html": "old", "f/a.png": "old", "f/b.png": "old",
                         "notes.txt": "mine"}
    assert json.loads((out / OWNED_FILE).read_text())["files"] == ["f/a.png", "f/b.png",
                                                                   "index.html"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_a_file_is_not_a_folder(tmp_path):
    (tmp_path / "rep").write_text("x")
    with pytest.raises(CaseError, match="is a file"):
        plan_output(tmp_path / "rep", "report")


def test_store_folder_checked(tmp_path):
    out = tmp_path / "runs"
    assert check_store(out, "sweep.json") == out  # new
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    with pytest.raises(CaseError, match="no sweep.json"):
        check_store(out, "sweep.json")
    check_store(out, "sweep.json", force=True)
    (out / "sweep.json").write_text("{}")
    check_store(out, "sweep.json")  # a sweep folder resumes


def test_folder_taken_by_another_command_meanwhile_is_not_replaced(tmp_path):
    out = tmp_path / "rep"
    with pytest.raises(CaseError, match="now holds the output of `multicontact fem`"), \
            owned_output(out, "report") as tmp:
        (tmp / "index.html").write_text("report")
        write(out, {"history.pvd": "fem"}, command="fem")  # another run, same folder
    assert tree(out) == {"history.pvd": "fem"}


def test_unwritable_place_refused_before_anything_is_computed(tmp_path, monkeypatch):
    """A folder that cannot be made (under a file; a parent refusing writes) is refused by the
    plan with the OS's reason, not by a traceback after the run; the probe leaves nothing."""
    (tmp_path / "afile").write_text("x")
    with pytest.raises(CaseError, match=r"output folder .*: cannot write in .*afile \(Not a "
                       r"directory\); nothing was computed"):
        plan_output(tmp_path / "afile" / "rep", "report")
    with pytest.raises(CaseError, match="cannot write in"):
        check_store(tmp_path / "afile" / "runs", "sweep.json")

    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(fileio.tempfile, "mkdtemp", refuse)
    for out in (tmp_path / "new" / "rep", tmp_path):
        with pytest.raises(CaseError, match=r"cannot write in .* \(Permission denied\)"):
            plan_output(out / "rep", "report")
    plan = fileio.OutputPlan((tmp_path / "rep").resolve(), "report")  # planned before
    with pytest.raises(CaseError, match=r"cannot write in .* \(Permission denied\); nothing was "
                       "written"), owned_output(tmp_path / "rep", "report", plan=plan):
        pytest.fail("written without a temporary folder")
    monkeypatch.undo()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]


def test_store_probed_inside_an_existing_folder(tmp_path, monkeypatch):
    """A sweep writes inside its folder: that is where it is probed (the parent may be
    read-only), and a writable folder passes."""
    out = tmp_path / "runs"
    out.mkdir()
    seen = []
    real = fileio.tempfile.mkdtemp
    monkeypatch.setattr(fileio.tempfile, "mkdtemp",
                        lambda **kw: seen.append(kw["dir"]) or real(**kw))
    assert check_store(out, "sweep.json") == out.resolve()
    plan_output(tmp_path / "rep", "report")
    assert seen == [out.resolve(), tmp_path.resolve()]
    assert sorted(p.name for p in out.iterdir()) == []


@pytest.mark.parametrize("expected", [("figures/",), ("figures/a.png",)])
def test_file_where_a_folder_goes_refused_before_computing(tmp_path, expected):
    """A user's FILE named like a folder the command writes (`figures` in a report folder) is
    refused by the plan, with its name; it gave a FileExistsError after the computation."""
    out = tmp_path / "rep"
    out.mkdir()
    (out / "figures").write_text("mine")
    with pytest.raises(CaseError, match=r"would overwrite .*\(figures: names of files or "
                       r"folders it writes\); they are kept and nothing was written"):
        plan_output(out, "report", True, expected=("index.html", *expected))
    with pytest.raises(CaseError, match=r"\(figures: .*nothing was replaced"):  # unannounced
        write(out, {"index.html": "new", "figures/a.png": "new"}, force=True)
    assert tree(out) == {"figures": "mine"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_link_where_a_folder_goes_is_not_written_through(tmp_path):
    """A link in the folder where the command writes a folder is refused: its files would land
    wherever the link points."""
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "history.pvd").write_text("theirs")
    out = tmp_path / "rep"
    out.mkdir()
    (out / "vtk").symlink_to(elsewhere, target_is_directory=True)
    with pytest.raises(CaseError, match=r"\(vtk: "):
        plan_output(out, "report", True, expected=("vtk/",))
    with pytest.raises(CaseError, match=r"\(vtk: "):
        write(out, {"vtk/history.pvd": "new"}, force=True)
    assert [p.name for p in elsewhere.iterdir()] == ["history.pvd"]
    assert (elsewhere / "history.pvd").read_text() == "theirs"


def test_foreign_file_beside_own_folder_is_fine_with_force(tmp_path):
    """A user's file inside a folder the command writes is kept: the command writes beside it."""
    out = tmp_path / "rep"
    (out / "figures").mkdir(parents=True)
    (out / "figures" / "notes.txt").write_text("mine")
    plan_output(out, "report", True, expected=("figures/",))
    write(out, {"figures/a.png": "new"}, force=True)
    write(out, {"index.html": "newer"}, force=True)
    assert tree(out) == {"figures/notes.txt": "mine", "index.html": "newer"}


def test_unwritable_own_output_refused_before_computing(tmp_path, monkeypatch):
    """Rerunning into one's own earlier output that cannot be written (chmod 555, chattr +i)
    is refused by the plan ("cannot write in" the folder), not by a PermissionError traceback
    after the computation: the folder itself and the folders of its previous output are
    probed."""
    out = tmp_path / "rep"
    write(out, {"index.html": "old", "figures/a.png": "old"})
    real = fileio.tempfile.mkdtemp
    for locked in (out, out / "figures"):
        def refuse(locked=locked, **kw):
            if Path(kw["dir"]) == locked.resolve():
                raise PermissionError(1, "Operation not permitted")
            return real(**kw)

        monkeypatch.setattr(fileio.tempfile, "mkdtemp", refuse)
        with pytest.raises(CaseError, match=rf"cannot write in {locked.resolve()} \(Operation "
                           r"not permitted\); nothing was computed"):
            plan_output(out, "report")
    monkeypatch.undo()
    assert tree(out) == {"index.html": "old", "figures/a.png": "old"}


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes in a 0555 folder")
def test_read_only_own_output_refused_before_computing(tmp_path):
    out = tmp_path / "rep"
    write(out, {"index.html": "old"})
    out.chmod(0o555)
    try:
        with pytest.raises(CaseError, match="cannot write in .*rep"):
            plan_output(out, "report")
    finally:
        out.chmod(0o755)


def test_a_failing_swap_is_one_clear_error_and_rolled_back(tmp_path, monkeypatch):
    """An OS error while the files are swapped in (a folder made read-only meanwhile) is a
    CaseError (exit 2), and the previous output stays."""
    out = tmp_path / "rep"
    write(out, {"index.html": "old"})
    real = os.replace

    def refuse(src, dst):  # the new file cannot go in (putting the old one back can)
        if ".rep.tmp-" in str(src) and Path(dst) == out.resolve() / "index.html":
            raise PermissionError(13, "Permission denied", str(dst))
        real(src, dst)

    monkeypatch.setattr(fileio.os, "replace", refuse)
    with pytest.raises(CaseError, match=r"cannot write in it \(Permission denied: .*index.html\);"
                       " nothing was replaced"):
        write(out, {"index.html": "new"})
    monkeypatch.undo()
    assert tree(out) == {"index.html": "old"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


@pytest.mark.parametrize(("a", "b"), [("x/vtk", "x"), ("x", "x/vtk"), ("x", "x"),
                                      ("x/./vtk/..", "x")])
def test_nested_output_folders_refused(tmp_path, a, b):
    """`fem -o X/vtk --export X` wrote X/vtk, then refused X for holding it: two outputs of one
    command must be separate folders, checked before anything is computed."""
    with pytest.raises(CaseError, match=r"-o .* and --export .*: give two separate folders, "
                       "neither inside the other"):
        fileio.check_apart({"-o": tmp_path / a, "--export": tmp_path / b})


def test_separate_output_folders_pass(tmp_path):
    fileio.check_apart({"-o": tmp_path / "x", "--export": tmp_path / "xy", "--vtk": None})
    fileio.check_apart({"-o": tmp_path / "a" / "x", "--export": tmp_path / "a" / "y"})


@pytest.mark.parametrize("name", ["../escaped", "/tmp/victim", "a/b", "a\\b", "", ".", "..",
                                  ".hidden", "x\0y"])
def test_case_name_never_leaves_the_output_folder(tmp_path, name):
    with pytest.raises(CaseError, match="cannot name a file in the output folder"):
        fileio.child(tmp_path, name, "_0.png")
    assert list(tmp_path.iterdir()) == []


def test_case_name_child(tmp_path):
    assert fileio.child(tmp_path, "cat0") == tmp_path / "cat0"
    assert fileio.child(tmp_path, "cat0", "_bodies.png") == tmp_path / "cat0_bodies.png"
