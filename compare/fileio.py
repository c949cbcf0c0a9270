"""File helpers shared by :mod:`compare`: atomic text files and output directories that never
lose a user's files.

Every command that takes an output directory (``-o DIR``, ``--export DIR``, ``--vtk DIR``, the
sweep report) writes through :func:`owned_output`:

- ``DIR`` is checked before anything is computed (:func:`plan_output`): the current directory,
  the home directory, the file-system root and any folder holding one of them are refused
  outright; so is a ``DIR`` (or a folder of the previous output in it) where no file can be
  made; a ``DIR`` holding files multicontact did not write there, or the output of another
  command, is refused unless ``force`` is given.  With ``force`` the command writes beside
  those files and never deletes or overwrites them: a file (or folder) it writes whose name is
  taken by a file it did not write, or a folder of its output that is a file or a link there,
  is refused.
- multicontact recognises its own output by the manifest :data:`OWNED_FILE` it writes into
  ``DIR`` (the command and every file it wrote).  Only the files of the same command's previous
  output are ever replaced or removed; another command's output counts as files this command
  did not write (with ``force`` the manifest then lists the new command's files).
- The new output is written into a temporary folder next to ``DIR``; a failure or an interrupt
  while it is being made leaves ``DIR`` as it was.  At the end, a new ``DIR`` is renamed into
  place; into an existing one, the previous output's files are swapped for the new ones in one
  transaction (rolled back if a rename fails), and files the command did not write are never
  touched: a new file that would overwrite one is refused.
- A case name becomes a path only through :func:`child` (one path component, inside the
  output folder); :func:`check_apart` refuses two outputs of one command nested in each
  other.
- Directories are created with the user's umask (``tempfile.mkdtemp`` alone would make them
  0700).
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from compare.errors import CaseError

#: The manifest of an output directory: which command wrote it and its files.
OWNED_FILE = ".multicontact-output.json"
#: How many foreign files an error message names.
_NAMED = 5


def write_atomic(path: Path, text: str) -> None:
    """Write a text file atomically (temporary file in the same directory, os.replace; the
    temporary file is removed if the write fails)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def umask_mode(mode: int = 0o777) -> int:
    """``mode`` with the process's umask applied (what ``mkdir`` would give)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mode & ~mask


@dataclass(frozen=True)
class OutputPlan:
    """A checked output directory: its absolute path, the command writing it and whether the
    user forced it (what is replaced there is read from its manifest when the output is put in
    place)."""

    out: Path
    command: str
    force: bool = False


def _never(out: Path) -> str:
    """Why ``out`` may never be an output directory ('' if it may)."""
    cwd, home = Path.cwd().resolve(), Path.home().resolve()
    if out == cwd:
        return "is the current directory"
    if out == home:
        return "is your home directory"
    if out == Path(out.anchor):
        return "is the root of the file system"
    if out in cwd.parents or out in home.parents:
        return "holds the current or the home directory"
    return ""


def _files(root: Path) -> list[str]:
    """Every file (or link) under ``root``, as sorted relative POSIX paths."""
    out = []
    for base, dirs, names in os.walk(root):
        rel = Path(base).relative_to(root)
        out += [(rel / n).as_posix() for n in names]
        out += [(rel / d).as_posix() for d in dirs if (Path(base) / d).is_symlink()]
    return sorted(out)


def read_owned(out: Path) -> dict | None:
    """The manifest of ``out`` (None when there is none or it is not multicontact's)."""
    try:
        doc = json.loads((out / OWNED_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    ok = (isinstance(doc, dict) and doc.get("tool") == "multicontact"
          and isinstance(doc.get("files"), list) and isinstance(doc.get("command"), str))
    return doc if ok else None


def _foreign(out: Path, owned: dict | None) -> list[str]:
    """The files of ``out`` no multicontact command wrote (not in its manifest ``owned``)."""
    known = set(owned["files"]) if owned else set()
    return [f for f in _files(out) if f != OWNED_FILE and f not in known]


def _mine(owned: dict | None, command: str) -> set[str]:
    """The only files ``command`` may replace or remove: those of its own previous output
    according to the manifest ``owned``, and the manifest (replaced by the new one; another
    command's files in the folder are then kept as files ``command`` did not write)."""
    if owned is None:
        return set()
    return {OWNED_FILE} | (set(owned["files"]) if owned["command"] == command else set())


def _blocked(out: Path, names: Iterable[str], mine: set[str]) -> list[str]:
    """The paths (relative to ``out``) that writing ``names`` (files; a name ending in '/' is a
    folder) would overwrite or write through although the command did not write them (not in
    ``mine``): a file, folder or link where a file goes, a file or link where a folder goes."""
    bad = set()
    for name in names:
        parts = PurePosixPath(name.rstrip("/")).parts
        for k in range(1, len(parts) + 1):
            rel = "/".join(parts[:k])
            path = out / rel
            if rel in mine or not (path.exists() or path.is_symlink()):
                continue
            is_file = k == len(parts) and not name.endswith("/")
            if is_file or path.is_symlink() or not path.is_dir():
                bad.add(rel)
                break
    return sorted(bad)


def _refuse_blocked(out: str | Path, command: str, blocked: list[str], done: str,
                    hint: str = "") -> None:
    """CaseError naming the ``blocked`` paths (:func:`_blocked`), if any."""
    if blocked:
        raise CaseError(f"output folder {out}: `multicontact {command}` would overwrite (or "
                        f"write through) files it did not write there ({_named(blocked)}: names "
                        f"of files or folders it writes); they are kept and nothing was {done}. "
                        f"Choose a new folder{hint}")


def _named(files: list[str]) -> str:
    more = f" and {len(files) - _NAMED} more" if len(files) > _NAMED else ""
    return ", ".join(files[:_NAMED]) + more


def _legacy_hint(owned: dict | None, foreign: list[str]) -> str:
    if owned is None and "summary.json" in foreign:
        return (f" (a report of a multicontact older than its {OWNED_FILE} manifest: delete it "
                "once, then multicontact replaces its own reports)")
    return ""


def _folder(out: str | Path, own: str, not_file: str, inside: bool = False) -> Path:
    """``out`` resolved; CaseError when it is refused outright (:func:`_never`: ``own`` says
    what to give instead), is a file (``not_file``) or cannot be written (:func:`_probe`: in its
    parent, where the output is made and renamed into place; ``inside``: in ``out`` itself, for
    a store that writes there)."""
    path = Path(out).expanduser().resolve()
    why = _never(path)
    if why:
        raise CaseError(f"output folder {out}: refused, it {why}; {own}")
    if path.exists() and not path.is_dir():
        raise CaseError(f"output folder {out}: is a file; {not_file}")
    _probe(out, path if inside else path.parent)
    return path


def _probe(out: str | Path, where: Path) -> None:
    """CaseError now, before anything is computed, when no folder can be made in ``where`` (or
    in its nearest existing ancestor, if it is still to be made): a probe folder, removed at
    once."""
    base = next(p for p in (where, *where.parents) if p.exists())
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".multicontact-probe-", dir=base))
    except OSError as exc:
        raise CaseError(f"output folder {out}: cannot write in {base} ({exc.strerror or exc}); "
                        "nothing was computed. Give a folder where you can write") from None


def plan_output(out: str | Path, command: str, force: bool = False,
                expected: tuple[str, ...] = ()) -> OutputPlan:
    """Check the output directory ``out`` of ``command`` before anything is computed.

    Raises :class:`compare.errors.CaseError` (the CLI's exit 2) when ``out`` is refused: see
    the module docstring.  ``force`` allows writing beside files ``command`` did not write there
    (a user's files, another command's output): those are kept, never deleted or overwritten.
    ``expected`` names files the command will write (a name ending in '/': a folder), so that
    one that would overwrite a file it did not write, or a folder of it taken by a file or a
    link, is refused now rather than after the computation.  The folder itself (and the
    folders of the previous output) must be writable: the swap renames files in them.
    """
    path = _folder(out, "multicontact writes only into a folder of its own, e.g. -o report",
                   "give a folder (new or one that multicontact wrote)")
    if not path.exists():
        return OutputPlan(path, command, force)
    owned = read_owned(path)
    mine = _mine(owned, command)
    foreign = _foreign(path, owned)
    if not force:
        _refuse_unforced(out, command, owned, foreign)
    _refuse_blocked(out, command, _blocked(path, (*expected, OWNED_FILE), mine), "written",
                    _legacy_hint(owned, foreign))
    for where in _own_folders(path, mine):
        _probe(out, where)
    return OutputPlan(path, command, force)


def _refuse_unforced(out: str | Path, command: str, owned: dict | None,
                     foreign: list[str]) -> None:
    """CaseError when ``out`` holds files no multicontact command wrote (``foreign``) or the
    output of another command (without ``force``)."""
    other = owned["command"] if owned and owned["command"] != command else ""
    if foreign:
        beside = f" beside the output of `multicontact {other}`" if other else ""
        raise CaseError(
            f"output folder {out}: holds files `multicontact {command}` did not write there "
            f"({_named(foreign)}){beside}; nothing was written. Choose a new folder, or add "
            f"--force to write beside them (they are kept; only `multicontact {command}`'s own "
            f"earlier files there are replaced){_legacy_hint(owned, foreign)}")
    if other:
        raise CaseError(
            f"output folder {out}: holds the output of `multicontact {other}`; nothing was "
            f"written. Choose another folder for `{command}`, or add --force to write beside it "
            f"(its files are kept, never deleted or overwritten)")


def _own_folders(path: Path, mine: set[str]) -> list[Path]:
    """``path`` and the existing folders of the previous output ``mine`` in it: where the swap
    renames files."""
    dirs = {path} | {(path / f).parent for f in mine}
    return sorted(d for d in dirs if d.is_dir() and not d.is_symlink())


def check_apart(folders: Mapping[str, str | Path | None]) -> None:
    """CaseError when two of one command's output folders (``folders``: option -> folder,
    None or '' when not given) are the same folder or one is inside the other: each is written
    as a whole and would find the other's files in it."""
    given = [(opt, d, Path(d).expanduser().resolve()) for opt, d in folders.items() if d]
    for k, (opt1, d1, p1) in enumerate(given):
        for opt2, d2, p2 in given[k + 1:]:
            if p1 == p2 or p1 in p2.parents or p2 in p1.parents:
                raise CaseError(f"{opt1} {d1} and {opt2} {d2}: give two separate folders, "
                                "neither inside the other (each is a separate output); "
                                "nothing was computed")


def child(root: Path, name: str, suffix: str = "") -> Path:
    """``root / (name + suffix)`` for a case name in an output path: CaseError unless ``name``
    is a non-empty string making one path component (no '/', '\\' or NUL, not starting with
    '.'), so that the path stays directly inside ``root`` (case files are held to a stricter
    rule, ``compare.case_format.check_name``)."""
    part = f"{name}{suffix}" if isinstance(name, str) else ""
    if not (name and part) or part.startswith(".") or {"/", "\\", "\0"} & set(part):
        raise CaseError(f"case name {name!r} cannot name a file in the output folder: it must "
                        "be one path component (no '/' or '\\', not starting with '.'); "
                        "nothing was written there")
    return root / part


def check_store(out: str | Path, marker: str, force: bool = False) -> Path:
    """Check the folder ``out`` of a store that only adds its own files (a sweep: resumable,
    never deletes): refused outright like :func:`plan_output`; an existing folder that holds
    files but not the store's ``marker`` file is refused unless ``force``."""
    path = _folder(out, "give a folder of its own, e.g. -o runs/NAME", "give a folder",
                   inside=True)
    if path.is_dir() and not (path / marker).exists() and not force:
        foreign = _files(path)
        if foreign:
            raise CaseError(f"output folder {out}: holds other files ({_named(foreign)}) and "
                            f"no {marker}; nothing was written. Choose a new folder, or add "
                            "--force to write beside them (they are kept)")
    return path


@contextmanager
def owned_output(out: str | Path, command: str, force: bool = False,
                 plan: OutputPlan | None = None) -> Iterator[Path]:
    """Write the output of ``command`` into ``out``: yields a temporary folder to fill; on a
    normal exit its files replace the previous output in ``out`` (see the module docstring),
    on an exception ``out`` is left as it was."""
    plan = plan or plan_output(out, command, force)
    try:
        plan.out.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{plan.out.name}.tmp-", dir=plan.out.parent))
    except OSError as exc:
        raise CaseError(f"output folder {plan.out}: cannot write in {plan.out.parent} "
                        f"({exc.strerror or exc}); nothing was written") from None
    try:
        tmp.chmod(umask_mode())
        yield tmp
        _commit(plan, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _commit(plan: OutputPlan, tmp: Path) -> None:
    files = _files(tmp)
    doc = {"tool": "multicontact", "command": plan.command, "files": files}
    (tmp / OWNED_FILE).write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    if not plan.out.exists():
        os.replace(tmp, plan.out)
        return
    owned = read_owned(plan.out)
    if owned and owned["command"] != plan.command and not plan.force:  # written meanwhile
        raise CaseError(f"output folder {plan.out}: now holds the output of `multicontact "
                        f"{owned['command']}`; nothing was replaced. Choose another folder")
    mine = _mine(owned, plan.command)  # the manifest now: only this command's files go
    _refuse_blocked(plan.out, plan.command, _blocked(plan.out, files + [OWNED_FILE], mine),
                    "replaced")
    try:
        _swap(plan.out, tmp, sorted(mine), files + [OWNED_FILE])
    except OSError as exc:
        raise CaseError(f"output folder {plan.out}: cannot write in it ({exc.strerror or exc}: "
                        f"{exc.filename}); nothing was replaced, the previous output is as it "
                        "was") from None


def _swap(out: Path, tmp: Path, old: list[str], new: list[str]) -> None:
    """Move the files ``old`` of ``out`` (those that are there) aside and the files ``new`` of
    ``tmp`` in; on any failure put everything back.  Then remove the old files and the folders
    they left empty."""
    aside = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
    moved, placed = [], []
    try:
        for f in old:
            if (out / f).exists() or (out / f).is_symlink():
                (aside / f).parent.mkdir(parents=True, exist_ok=True)
                os.replace(out / f, aside / f)
                moved.append(f)
        for f in new:
            (out / f).parent.mkdir(parents=True, exist_ok=True)
            os.replace(tmp / f, out / f)
            placed.append(f)
    except BaseException:
        for f in reversed(placed):
            os.replace(out / f, tmp / f)
        for f in reversed(moved):
            os.replace(aside / f, out / f)
        shutil.rmtree(aside, ignore_errors=True)
        raise
    shutil.rmtree(aside, ignore_errors=True)
    _prune(out, {Path(f).parent for f in moved} - {Path(f).parent for f in new})


def _prune(out: Path, dirs: set[Path]) -> None:
    """Remove the folders ``dirs`` (relative to ``out``) and their parents while empty."""
    for d in sorted(dirs, key=lambda p: len(p.parts), reverse=True):
        while d.parts:
            try:
                (out / d).rmdir()
            except OSError:
                break
            d = d.parent


__all__ = ["OWNED_FILE", "OutputPlan", "check_store", "owned_output", "plan_output", "read_owned",
           "umask_mode", "write_atomic"]
