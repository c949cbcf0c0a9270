"""File helpers shared by :mod:`compare`: atomic text files and output directories that never
lose a user's files.

Every command that takes an output directory (``-o DIR``, ``--export DIR``, ``--vtk DIR``, the
sweep report) writes through :func:`owned_output`:

- ``DIR`` is checked before anything is computed (:func:`plan_output`): the current directory,
  the home directory, the file-system root and any folder holding one of them are refused
  outright; a ``DIR`` holding files multicontact did not write there, or the output of another
  command, is refused unless ``force`` is given.
- multicontact recognises its own output by the manifest :data:`OWNED_FILE` it writes into
  ``DIR`` (the command and every file it wrote).
- The new output is written into a temporary folder next to ``DIR``; a failure or an interrupt
  while it is being made leaves ``DIR`` as it was.  At the end, a new ``DIR`` is renamed into
  place; into an existing one, the previous output's files are swapped for the new ones in one
  transaction (rolled back if a rename fails), and files multicontact did not write are never
  touched: a new file that would overwrite one is refused.
- Directories are created with the user's umask (``tempfile.mkdtemp`` alone would make them
  0700).
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

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
    """A checked output directory: its absolute path, the command writing it, the files of
    the previous output there (relative paths; empty for a new or empty directory) and whether
    the user forced it."""

    out: Path
    command: str
    previous: tuple[str, ...]
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
    known = set(owned["files"]) if owned else set()
    return [f for f in _files(out) if f != OWNED_FILE and f not in known]


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
    the module docstring.  ``force`` allows replacing another command's output and writing
    beside files multicontact did not write (those are kept); ``expected`` names files the
    command will write, so that one that would overwrite a foreign file is refused now.
    """
    path = _folder(out, "multicontact writes only into a folder of its own, e.g. -o report",
                   "give a folder (new or one that multicontact wrote)")
    if not path.exists():
        return OutputPlan(path, command, (), force)
    owned = read_owned(path)
    foreign = _foreign(path, owned)
    clash = sorted(set(foreign) & set(expected))
    if clash and force:
        raise CaseError(f"output folder {out}: --force would overwrite files multicontact did "
                        f"not write there ({_named(clash)}); nothing was written. Choose a new "
                        f"folder{_legacy_hint(owned, foreign)}")
    if not force:
        if foreign:
            other = (f" beside the output of `multicontact {owned['command']}`"
                     if owned and owned["command"] != command else "")
            raise CaseError(
                f"output folder {out}: holds files multicontact did not write there "
                f"({_named(foreign)}){other}; nothing was written. Choose a new folder, or add "
                "--force to write beside them (only multicontact's own files there are replaced)"
                f"{_legacy_hint(owned, foreign)}")
        if owned and owned["command"] != command:
            raise CaseError(
                f"output folder {out}: holds the output of `multicontact {owned['command']}`; "
                f"nothing was written. Choose another folder for `{command}`, or add --force "
                "to replace it")
    return OutputPlan(path, command, tuple(owned["files"]) if owned else (), force)


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
    previous = sorted(set(owned["files"] if owned else ()) | set(plan.previous))
    clash = sorted(set(_foreign(plan.out, owned)) & set(files))
    if clash:
        raise CaseError(f"output folder {plan.out}: would overwrite files multicontact did not "
                        f"write there ({_named(clash)}); nothing was replaced. Choose a new "
                        "folder")
    _swap(plan.out, tmp, [f for f in previous if (plan.out / f).exists()] + [OWNED_FILE],
          files + [OWNED_FILE])


def _swap(out: Path, tmp: Path, old: list[str], new: list[str]) -> None:
    """Move the files ``old`` of ``out`` aside and the files ``new`` of ``tmp`` in; on any
    failure put everything back.  Then remove the old files and the folders they left empty."""
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
