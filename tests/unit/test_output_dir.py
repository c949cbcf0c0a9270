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


def test_other_commands_output_needs_force(tmp_path):
    out = tmp_path / "rep"
    write(out, {"index.html": "report"})
    with pytest.raises(CaseError, match="output of `multicontact report`"):
        write(out, {"index.html": "verify"}, command="verify")
    assert tree(out) == {"index.html": "report"}
    write(out, {"index.html": "verify"}, command="verify", force=True)
    assert tree(out) == {"index.html": "verify"}


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
    plan = fileio.OutputPlan((tmp_path / "rep").resolve(), "report", ())  # planned before
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
