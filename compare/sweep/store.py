"""Sweep result store: ``DIR/results.jsonl`` and ``DIR/sweep.json`` (layout in ``docs/sweeps.md``).

``results.jsonl`` is append-only, one complete line per case record (written + flushed +
fsynced by the one coordinating process that holds ``DIR/.lock``), so an interrupted sweep
resumes by skipping the keys already there; a torn last line of a killed writer is ignored on
reading and cut before the next append.  ``sweep.json`` is the manifest, rewritten atomically
at the start of every run.
"""

from __future__ import annotations

import fcntl
import json
import os
from collections.abc import Callable
from pathlib import Path

from compare.errors import SweepError

#: Version of the record / manifest layout (``schema`` field of every record).
SCHEMA_VERSION = 1

RESULTS_FILE = "results.jsonl"
MANIFEST_FILE = "sweep.json"
LOCK_FILE = ".lock"
#: ``format`` field of every manifest: a folder is a sweep's store only when its sweep.json
#: carries it (or is a manifest of an earlier version, without it: :data:`LEGACY_FIELDS`).
MANIFEST_FORMAT = "multicontact sweep"
#: Fields of a manifest written before the ``format`` field existed (schema 1).
LEGACY_FIELDS = frozenset({"schema", "name", "description", "source", "base", "parts",
                           "report", "cases", "written"})


def _better(old: dict | None, new: dict) -> bool:
    """Dedup rule: an ok record beats a failed one; otherwise the later line wins."""
    return old is None or new["status"] == "ok" or old["status"] != "ok"


def read_records(directory: str | Path) -> dict[str, dict]:
    """Records of a sweep directory by key (deduplicated; a torn last line is ignored)."""
    path = Path(directory) / RESULTS_FILE
    out: dict[str, dict] = {}
    if not path.is_file():
        return out
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:
                continue  # torn final line of a killed writer (repaired on the next append)
            if isinstance(rec, dict) and "key" in rec and _better(out.get(rec["key"]), rec):
                out[rec["key"]] = rec
    return out


def is_manifest(doc: object) -> bool:
    """Whether ``doc`` (parsed sweep.json) is a multicontact sweep manifest: the format marker
    (or every field of a schema-1 manifest written before it), a name and a list of cases
    with keys."""
    if not isinstance(doc, dict):
        return False
    marked = doc.get("format") == MANIFEST_FORMAT or (LEGACY_FIELDS <= set(doc)
                                                      and "format" not in doc)
    cases = doc.get("cases")
    schema = SCHEMA_VERSION if "format" in doc else 1  # the legacy manifests are schema 1
    return (marked and doc.get("schema") == schema and isinstance(doc.get("name"), str)
            and isinstance(cases, list)
            and all(isinstance(c, dict) and isinstance(c.get("key"), str) for c in cases))


def store_manifest(directory: str | Path) -> dict | None:
    """The manifest of the sweep store ``directory``, or None when it has no sweep.json;
    SweepError when its sweep.json is not a multicontact sweep manifest (someone else's)."""
    path = Path(directory) / MANIFEST_FILE
    if not path.exists():
        return None
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        doc = None
    if not is_manifest(doc):
        raise SweepError(f"{path} is not a multicontact sweep manifest (\"format\": "
                         f"\"{MANIFEST_FORMAT}\", schema {SCHEMA_VERSION}, a name and a list "
                         f"of cases with keys), so {directory} is not a sweep's folder")
    return doc


def read_manifest(directory: str | Path) -> dict:
    """``DIR/sweep.json`` (SweepError naming the directory when it is not a sweep's)."""
    doc = store_manifest(directory)
    if doc is None:
        raise SweepError(f"{directory} is not a sweep directory: no {MANIFEST_FILE} "
                         "(run `multicontact sweep STUDY -o DIR` first)")
    return doc


class ResultStore:
    """Append-only JSON Lines store with an exclusive lock (one coordinator per directory).

    ``prepare(directory)``, if given, runs once the lock is held and before results.jsonl is
    touched (the runner checks the folder is this sweep's and writes the manifest there); an
    exception from it releases the lock and leaves results.jsonl as it was."""

    def __init__(self, directory: str | Path,
                 prepare: Callable[[Path], None] | None = None):
        self.dir = Path(directory)
        self.path = self.dir / RESULTS_FILE
        self._prepare = prepare
        self._fd: int | None = None
        self._lock: int | None = None

    def __enter__(self) -> ResultStore:
        self.dir.mkdir(parents=True, exist_ok=True)
        self._lock = os.open(self.dir / LOCK_FILE, os.O_CREAT | os.O_RDWR, 0o644)
        try:
            fcntl.flock(self._lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(self._lock)
            raise SweepError(f"{self.dir} is in use by another running sweep") from None
        try:
            if self._prepare is not None:
                self._prepare(self.dir)
            self._repair_tail()
            self._fd = os.open(self.path, os.O_CREAT | os.O_WRONLY | os.O_APPEND, 0o644)
        except BaseException:
            self.__exit__()
            raise
        return self

    def __exit__(self, *exc) -> None:
        for fd in (self._fd, self._lock):
            if fd is not None:
                os.close(fd)
        self._fd = self._lock = None

    def _repair_tail(self) -> None:
        """Cut a torn last line (a writer killed mid-write) so appends start on a new line."""
        if not self.path.is_file() or self.path.stat().st_size == 0:
            return
        data = self.path.read_bytes()
        if data.endswith(b"\n"):
            return
        with open(self.path, "r+b") as fh:
            fh.truncate(data.rfind(b"\n") + 1)

    def append(self, record: dict) -> None:
        """Append one record as one complete line: write, flush, fsync."""
        line = (json.dumps(record, sort_keys=True, allow_nan=False) + "\n").encode()
        view = memoryview(line)
        while view:
            view = view[os.write(self._fd, view):]
        os.fsync(self._fd)
