"""Parameter sweeps: many cases from one base case, run on a process pool or dask.distributed.

A sweep file (TOML, schema in ``docs/sweeps.md``) names a base case (a library case, a case
file, or an inline ``[base]`` table in the case-file schema) and one or more *parts*; a part
has a task (what to compute per case) and parameter axes.  The cases of a part are the
Cartesian product of its axes, where a ``[zip.NAME]`` group of equally long axes counts as one
axis.  Parameters are dotted case-file keys: ``load.P``, ``profile.phi_inner``, ``fem.level``,
``profile.members.1.lift`` (union members), ...

Every case becomes a plain-data task dict executed by :func:`execute` (on a local process pool
or on dask workers), which returns one flat JSON record.  The coordinating process appends the
records to ``DIR/results.jsonl`` (one complete line per case, written + flushed + fsynced), so
an interrupted sweep resumes by skipping the keys already there.  A case's key is a hash of its
task and its resolved case table (not of its position), so extending an axis reuses the
finished cases.
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import fcntl
import hashlib
import itertools
import json
import math
import os
import signal
import socket
import sys
import threading
import time
import tomllib
import traceback
import uuid
from collections import Counter, deque
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor
from concurrent.futures import wait as futures_wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from datetime import UTC, datetime
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

import compare
from compare import case_format
from compare import cases as case_schema
from compare.errors import CaseError

#: Version of the record / manifest layout (``schema`` field of every record).
SCHEMA_VERSION = 1
RESULTS_FILE = "results.jsonl"
MANIFEST_FILE = "sweep.json"
LOCK_FILE = ".lock"
#: A case whose worker process died this many times is recorded as failed (local pool).
MAX_WORKER_DEATHS = 2
#: Seconds between checks for finished work and for an interrupt.
POLL_S = 0.2
#: Hex digits of the case key (64 bits: collisions are negligible for any realistic sweep).
KEY_DIGITS = 16
#: Exit codes of ``multicontact sweep``.
EXIT_OK, EXIT_FAILED_CASES, EXIT_BAD_INPUT = 0, 1, 2
EXIT_SIGNAL = {signal.SIGINT: 130, signal.SIGTERM: 143}

TOP_KEYS = {"name", "description", "base", "task", "axes", "zip", "set", "parts", "report"}
PART_KEYS = {"task", "axes", "zip", "set", "description"}
SPACES = {"linspace", "geomspace", "values"}


class SweepError(CaseError):
    """Bad sweep input (a :class:`CaseError`, so the CLI maps it to exit code 2)."""


# =============================================================================================
# tasks: what is computed for one case (each returns a flat dict of JSON-able metrics)
# =============================================================================================
def _normal_metrics(sol, case) -> dict:
    """Zones, loads and self-checks of an analytic normal solution."""
    m: dict[str, Any] = {"n_zones": sol.n_zones, "P": sol.P, "M": sol.M, "theta": sol.theta,
                         "extent_total": sol.extent}
    for i, ((a, b), load) in enumerate(zip(sol.zones, sol.zone_loads, strict=True)):
        m.update({f"zone{i}_a": a, f"zone{i}_b": b, f"zone{i}_width": b - a,
                  f"zone{i}_load": load})
    m["extent"] = sol.zones[-1][1] - sol.zones[-1][0]
    m["kappa"] = m["extent"] / case.profile_spec["c"] if "c" in case.profile_spec else None
    m.update({f"check_{k}": v for k, v in sol.residuals.items()})
    return m


def _solve_normal(case):
    import analytic

    return analytic.solve_normal(case.profile, case.P, case.A, case.M)


def task_analytic(case) -> dict:
    """Analytic normal solution (stage 1): zones, zone loads, extent of the right zone."""
    return _normal_metrics(_solve_normal(case), case)


def _overlapped_extent(case, theta: float) -> float:
    import analytic

    zones = analytic.overlapped(case.profile, case.P, case.A, theta).zones
    return zones[-1][1] - zones[-1][0]


def task_overlap(case) -> dict:
    """Paper Section 6 / Fig. 5: actual vs overlapped extent of the right zone, ``Pe``."""
    sol = _solve_normal(case)
    m = _normal_metrics(sol, case)
    m["extent_overlapped"] = _overlapped_extent(case, sol.theta)
    m["Pe"] = (m["extent"] - m["extent_overlapped"]) / m["extent"] * 100.0
    return m


def _fem_metrics(case, sol) -> dict:
    from compare import fem_side, metrics

    hist = fem_side.run_fem(case, sol)
    end = [s for s in hist.steps if s.stage == 1][-1]
    fe = list(end.contact_zones)
    m: dict[str, Any] = {"fe_n_zones": len(fe), "fe_P": end.reactions[0],
                         "n_dofs": hist.n_dofs, "h_min": hist.h_min}
    for i, (a, b) in enumerate(fe):
        m.update({f"fe_zone{i}_a": a, f"fe_zone{i}_b": b, f"fe_zone{i}_width": b - a})
    errs = metrics.edge_errors(sol.zones, fe)
    rel = [max(e) / (b - a) for e, (a, b) in zip(errs, sol.zones, strict=True)]
    m["edge_error_max"] = max(rel)
    match = metrics.match_zones(sol.zones, fe)[-1]
    m["extent_analytic"] = sol.zones[-1][1] - sol.zones[-1][0]
    m["extent"] = fe[match][1] - fe[match][0] if match is not None else None
    if m["extent"] is not None:
        m["extent_error"] = abs(m["extent"] - m["extent_analytic"]) / m["extent_analytic"]
    m["kappa"] = (m["extent"] / case.profile_spec["c"]
                  if "c" in case.profile_spec and m["extent"] is not None else None)
    m.update({f"fe_time_{k}": v for k, v in dict(hist.timings).items()
              if isinstance(v, (int, float))})
    return m


def task_fem(case) -> dict:
    """FE stage 1 against the analytic normal solution: FE zones, edge errors, extent."""
    return _fem_metrics(case, _solve_normal(case))


def task_fem_overlap(case) -> dict:
    """FE stage 1 plus the overlapped extent: FE points of the paper's Fig. 5 (``Pe`` of FE)."""
    sol = _solve_normal(case)
    m = _fem_metrics(case, sol)
    m["extent_overlapped"] = _overlapped_extent(case, sol.theta)
    an = m["extent_analytic"]
    m["Pe_analytic"] = (an - m["extent_overlapped"]) / an * 100.0
    fe = m["extent"]
    m["Pe"] = (fe - m["extent_overlapped"]) / fe * 100.0 if fe else None
    return m


def task_run(case) -> dict:
    """Both solvers and all comparison metrics: ``compare.run_case(case).metrics``."""
    return dict(compare.run_case(case).metrics)


TASKS: dict[str, Callable[[Any], dict]] = {
    "analytic": task_analytic,
    "overlap": task_overlap,
    "fem": task_fem,
    "fem_overlap": task_fem_overlap,
    "run": task_run,
}
#: Tasks drawn as curves in reports (the others are FE points, drawn as markers).
ANALYTIC_TASKS = {"analytic", "overlap"}
#: Metrics plotted by default per task (when the sweep file has no [report] table).
DEFAULT_METRICS = {
    "analytic": ["extent", "extent_total"],
    "overlap": ["extent", "extent_overlapped", "Pe"],
    "fem": ["edge_error_max", "extent_error"],
    "fem_overlap": ["edge_error_max", "extent_error", "Pe"],
    "run": ["edge_error_max", "stick_edge_error_max", "pressure_l2_error", "shear_l2_error"],
}


# =============================================================================================
# records: one flat JSON object per case (schema in docs/sweeps.md)
# =============================================================================================
def _jsonable(value: Any) -> Any:
    """Plain JSON value: numpy scalars -> Python, nan/inf -> None, tuples -> lists."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if value is None or isinstance(value, str):
        return value
    return str(value)


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def _record(task: dict, status: str, metrics: dict, error: dict | None,
            t0: float, started: str) -> dict:
    return {"schema": SCHEMA_VERSION, "key": task["key"], "sweep": task["sweep"],
            "part": task["part"], "task": task["task"], "index": task["index"],
            "params": task["params"], "status": status, "metrics": _jsonable(metrics),
            "error": error,
            "timings": {"wall_s": time.perf_counter() - t0, "started": started,
                        "finished": _now()},
            "worker": {"host": socket.gethostname(), "pid": os.getpid()}}


def _error(exc: BaseException) -> dict:
    tb = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__, limit=-6))
    return {"type": type(exc).__name__, "message": str(exc), "traceback": tb}


def execute(task: dict) -> dict:
    """Run one sweep case (plain-data ``task``) and return its record; never raises."""
    t0, started = time.perf_counter(), _now()
    try:
        base = Path(task["base_dir"]) if task.get("base_dir") else None
        case = case_schema.case_from_dict(task["case"], name=task["name"], src=task["name"],
                                          base=base)
        metrics = TASKS[task["task"]](case)
    except Exception as exc:  # noqa: BLE001 - a failing case is recorded, the sweep goes on
        return _record(task, "failed", {}, _error(exc), t0, started)
    return _record(task, "ok", metrics, None, t0, started)


def infrastructure_failure(task: dict, message: str) -> dict:
    """Record of a case whose worker died or whose result never came back."""
    rec = _record(task, "failed", {}, {"type": "WorkerLost", "message": message,
                                       "traceback": ""}, time.perf_counter(), _now())
    rec["worker"] = None
    return rec


# =============================================================================================
# sweep file -> cases
# =============================================================================================
@dataclass(frozen=True)
class SweepCase:
    """One case of a sweep: its key, part, task, position, parameter values and case table."""

    key: str
    part: str
    task: str
    index: int
    params: dict
    case: dict

    def as_task(self, sweep: Sweep) -> dict:
        """The plain-data task shipped to a worker."""
        return {"key": self.key, "sweep": sweep.name, "part": self.part, "task": self.task,
                "index": self.index, "params": self.params, "case": self.case,
                "name": f"{sweep.name}/{self.part}#{self.index}",
                "base_dir": str(sweep.base_dir) if sweep.base_dir else None}


@dataclass(frozen=True)
class Part:
    """A part of a sweep: a task and its axes (each axis: a tuple of parameter names)."""

    name: str
    task: str
    axes: tuple[tuple[str, ...], ...]
    values: tuple[tuple[tuple, ...], ...]  # per axis: tuple of value tuples
    fixed: dict = field(default_factory=dict)

    @property
    def parameters(self) -> list[str]:
        return [p for axis in self.axes for p in axis]


@dataclass(frozen=True)
class Sweep:
    """A validated sweep: base case table, parts, the cases in order and report settings."""

    name: str
    description: str
    source: str
    base: dict
    base_dir: Path | None
    parts: tuple[Part, ...]
    cases: tuple[SweepCase, ...]
    report: dict
    spec: dict

    def manifest(self) -> dict:
        """Plain-data description written to ``DIR/sweep.json``."""
        parts = [{"name": p.name, "task": p.task, "axes": [list(a) for a in p.axes],
                  "parameters": p.parameters, "fixed": p.fixed} for p in self.parts]
        cases = [{"key": c.key, "part": c.part, "task": c.task, "index": c.index,
                  "params": c.params} for c in self.cases]
        return {"schema": SCHEMA_VERSION, "name": self.name, "description": self.description,
                "source": self.source, "base": self.base, "parts": parts,
                "report": self.report, "cases": cases, "written": _now()}


def _fail(src: str, msg: str) -> SweepError:
    return SweepError(f"{src}: {msg}")


def allowed_parameters(base: dict) -> list[str]:
    """Dotted case keys a sweep may vary for this base case table."""
    prof = base.get("profile", {})
    out = []
    if prof.get("type") == "union":
        for i, mem in enumerate(prof.get("members", [])):
            keys = case_format.PROFILE_SCHEMAS.get(mem.get("type"), {})
            out += [f"profile.members.{i}.{k}" for k in keys]
    else:
        out += [f"profile.{k}" for k in case_format.PROFILE_SCHEMAS.get(prof.get("type"), {})]
    for sec, keys in (("material", case_format.MATERIAL_KEYS), ("load", case_format.LOAD_KEYS),
                      ("samples", case_format.SAMPLE_KEYS), ("fem", case_format.FEM_KEYS),
                      ("tolerances", case_format.DEFAULT_TOLERANCES)):
        out += [f"{sec}.{k}" for k in keys]
    return out


def _set(doc: dict, param: str, value: Any) -> None:
    """Set a dotted parameter in a case table (creating missing sections)."""
    parts = param.split(".")
    node: Any = doc
    for p in parts[:-1]:
        node = node[int(p)] if isinstance(node, list) else node.setdefault(p, {})
    node[parts[-1]] = value


def _axis_values(spec: Any, where: str, src: str) -> list:
    """Values of one axis: a non-empty list, or {linspace|geomspace = [a, b, n]}/{values=[]}."""
    if isinstance(spec, dict):
        if len(spec) != 1 or next(iter(spec)) not in SPACES:
            raise _fail(src, f"axis {where} must be a list or a table with exactly one of "
                        f"{', '.join(sorted(SPACES))}, got {spec!r}")
        kind, arg = next(iter(spec.items()))
        if kind == "values":
            return _axis_values(arg, where, src)
        return _space(kind, arg, where, src)
    if not isinstance(spec, list):
        raise _fail(src, f"axis {where} must be a list of values, got {type(spec).__name__} "
                    f"{spec!r}")
    if not spec:
        raise _fail(src, f"axis {where} is empty: give at least one value")
    if any(isinstance(v, (dict, list)) for v in spec):
        raise _fail(src, f"axis {where} must hold numbers, strings or booleans, got {spec!r}")
    return list(spec)


def _space(kind: str, arg: Any, where: str, src: str) -> list:
    ok = (isinstance(arg, list) and len(arg) == 3
          and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in arg)
          and isinstance(arg[2], int))
    if not ok or arg[2] < 1:
        raise _fail(src, f"axis {where}: {kind} needs [start, stop, n] with integer n >= 1, "
                    f"got {arg!r}")
    if kind == "geomspace" and (arg[0] <= 0 or arg[1] <= 0):
        raise _fail(src, f"axis {where}: geomspace needs start, stop > 0, got {arg!r}")
    fn = np.linspace if kind == "linspace" else np.geomspace
    vals = [float(v) for v in fn(arg[0], arg[1], arg[2])]
    if all(isinstance(v, int) for v in arg) and all(v.is_integer() for v in vals):
        return [int(v) for v in vals]  # e.g. mesh levels: linspace = [0, 3, 4]
    return vals


def _check_param(param: Any, allowed: list[str], where: str, src: str) -> str:
    if not isinstance(param, str) or param not in allowed:
        raise _fail(src, f"unknown parameter {param!r} in {where}; parameters of this base case: "
                    f"{', '.join(allowed)}")
    return param


def _parse_axes(tab: dict, part: str, allowed: list[str], src: str
                ) -> tuple[tuple[tuple[str, ...], ...], tuple[tuple[tuple, ...], ...]]:
    """Axes in the order written: each [axes] entry is one axis, each zip group one axis."""
    axes: list[tuple[str, ...]] = []
    values: list[tuple[tuple, ...]] = []
    for section in (k for k in tab if k in ("axes", "zip")):
        parse = _plain_axes if section == "axes" else _zip_axes
        for names, vals in parse(_table(tab[section], f"[{part}.{section}]", src), part,
                                 allowed, src):
            axes.append(names)
            values.append(vals)
    seen = Counter(p for a in axes for p in a)
    dup = [p for p, n in seen.items() if n > 1]
    if dup:
        raise _fail(src, f"parameter {dup[0]!r} appears in more than one axis of part "
                    f"'{part}'")
    return tuple(axes), tuple(values)


def _plain_axes(tab: dict, part: str, allowed: list[str], src: str):
    for param, spec in tab.items():
        _check_param(param, allowed, f"[{part}.axes]", src)
        yield (param,), tuple((v,) for v in _axis_values(spec, f"'{param}'", src))


def _zip_axes(tab: dict, part: str, allowed: list[str], src: str):
    for gname, group in tab.items():
        where = f"[{part}.zip.{gname}]"
        group = _table(group, where, src)
        if not group:
            raise _fail(src, f"zip group {where} is empty: give at least one axis")
        cols = {_check_param(p, allowed, where, src): _axis_values(s, f"'{p}' in {where}", src)
                for p, s in group.items()}
        lengths = {p: len(v) for p, v in cols.items()}
        if len(set(lengths.values())) != 1:
            raise _fail(src, f"zip group {where} has axes of different lengths "
                        f"{lengths}: zipped axes must be equally long")
        yield tuple(cols), tuple(zip(*cols.values(), strict=True))


def _table(value: Any, where: str, src: str) -> dict:
    if not isinstance(value, dict):
        raise _fail(src, f"{where} must be a table, got {type(value).__name__} {value!r}")
    return value


def _parse_part(name: str, tab: dict, allowed: list[str], src: str) -> Part:
    unknown = sorted(set(tab) - PART_KEYS)
    if unknown:
        raise _fail(src, f"unknown key {unknown[0]!r} in part '{name}'; allowed: "
                    f"{', '.join(sorted(PART_KEYS))}")
    task = tab.get("task", "analytic")
    if task not in TASKS:
        raise _fail(src, f"task={task!r} is not allowed in part '{name}': need one of "
                    f"{', '.join(TASKS)}")
    if task == "run" and not hasattr(compare, "run_case"):
        raise _fail(src, f"task 'run' in part '{name}' needs compare.run_case, which this "
                    "version of compare does not provide; use task 'fem' or 'analytic'")
    fixed = _table(tab.get("set", {}), f"[{name}.set]", src)
    for p in fixed:
        _check_param(p, allowed, f"[{name}.set]", src)
    axes, values = _parse_axes(tab, name, allowed, src)
    return Part(name, task, axes, values, dict(fixed))


def case_key(task: str, case: dict) -> str:
    """Stable key of a case: hash of its task and resolved case table (name excluded)."""
    body = {k: v for k, v in case.items() if k not in ("name", "description")}
    text = json.dumps({"task": task, "case": body}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:KEY_DIGITS]


def _part_cases(part: Part, base: dict, base_dir: Path | None, src: str) -> list[SweepCase]:
    out = []
    for index, combo in enumerate(itertools.product(*part.values)):
        params = {p: v for axis, vals in zip(part.axes, combo, strict=True)
                  for p, v in zip(axis, vals, strict=True)}
        doc = copy.deepcopy(base)
        for p, v in {**part.fixed, **params}.items():
            _set(doc, p, v)
        try:
            case_schema.case_from_dict(doc, src=f"{src} [{part.name}] {params}", base=base_dir)
        except ValueError as exc:  # CaseError, or a profile constructor's own ValueError
            raise SweepError(f"{src}: case {index} of part '{part.name}' is not valid: "
                             f"{exc or type(exc).__name__}") from None
        out.append(SweepCase(case_key(part.task, doc), part.name, part.task, index, params,
                             doc))
    return out


def _resolve_base(spec: Any, src: str, here: Path | None) -> tuple[dict, Path | None]:
    """Base case table: inline table, library case name or case-file path."""
    if isinstance(spec, dict):
        return copy.deepcopy(spec), here
    if not isinstance(spec, str) or not spec:
        raise _fail(src, "missing 'base': a library case name, a case file or a [base] table")
    lib = case_schema.library_dir() / f"{spec}.toml"
    path = lib if lib.is_file() else (here / spec if here and not Path(spec).is_absolute()
                                      else Path(spec))
    if not path.is_file():
        raise _fail(src, f"base={spec!r} is neither a library case "
                    f"({', '.join(case_schema.list_cases()) or 'none'}) nor a case file")
    try:
        return tomllib.loads(path.read_text(encoding="utf-8")), path.parent
    except tomllib.TOMLDecodeError as exc:
        raise _fail(src, f"base case file {path.name} is not valid TOML: {exc}") from None


def sweep_from_dict(doc: dict, name: str = "sweep", src: str = "sweep",
                    here: Path | None = None) -> Sweep:
    """Validate a parsed sweep table and expand it into its cases (errors: SweepError)."""
    unknown = sorted(set(doc) - TOP_KEYS)
    if unknown:
        raise _fail(src, f"unknown key {unknown[0]!r}; allowed: {', '.join(sorted(TOP_KEYS))}")
    base, base_dir = _resolve_base(doc.get("base"), src, here)
    single = {k: doc[k] for k in PART_KEYS - {"description"} if k in doc}
    if single and "parts" in doc:
        raise _fail(src, f"give either [parts.NAME] tables or top-level {sorted(single)}, "
                    "not both")
    parts_doc = _table(doc.get("parts", {"main": single}), "[parts]", src)
    if not parts_doc:
        raise _fail(src, "[parts] is empty: give at least one part")
    allowed = allowed_parameters(base)
    parts = tuple(_parse_part(n, _table(t, f"[parts.{n}]", src), allowed, src)
                  for n, t in parts_doc.items())
    cases = [c for p in parts for c in _part_cases(p, base, base_dir, src)]
    report = _table(doc.get("report", {}), "[report]", src)
    return Sweep(str(doc.get("name", name)), str(doc.get("description", "")), src, base,
                 base_dir, parts, tuple(cases), report, doc)


def studies_dir() -> Path:
    """Directory of the library studies shipped with the package."""
    return Path(str(resources.files("compare") / "studies"))


def _is_sweep_file(path: Path) -> bool:
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError):
        return False
    return "base" in doc and bool({"parts", "axes", "zip", "task"} & set(doc))


def list_studies() -> list[str]:
    """Names of the library sweep studies (other TOML files in the directory are skipped)."""
    return sorted(p.stem for p in studies_dir().glob("*.toml") if _is_sweep_file(p))


def load_sweep(name_or_path: str | Path) -> Sweep:
    """A library study by name (e.g. ``"fig5"``) or a sweep file by path."""
    text = str(name_or_path)
    path = studies_dir() / f"{text}.toml"
    if not path.is_file():
        path = Path(text)
    if not path.is_file():
        raise SweepError(f"unknown sweep {text!r}: not a library study "
                         f"({', '.join(list_studies())}) and not a file")
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise SweepError(f"{path.name}: not valid TOML: {exc}") from None
    return sweep_from_dict(doc, name=path.stem, src=path.name, here=path.parent.resolve())


# =============================================================================================
# result store: DIR/results.jsonl (append-only, one complete line per record) + DIR/sweep.json
# =============================================================================================
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


def read_manifest(directory: str | Path) -> dict:
    path = Path(directory) / MANIFEST_FILE
    if not path.is_file():
        raise SweepError(f"{directory} is not a sweep directory: no {MANIFEST_FILE}")
    return json.loads(path.read_text(encoding="utf-8"))


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


class ResultStore:
    """Append-only JSON Lines store with an exclusive lock (one coordinator per directory)."""

    def __init__(self, directory: str | Path):
        self.dir = Path(directory)
        self.path = self.dir / RESULTS_FILE
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
        self._repair_tail()
        self._fd = os.open(self.path, os.O_CREAT | os.O_WRONLY | os.O_APPEND, 0o644)
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


# =============================================================================================
# runners: local process pool, dask.distributed
# =============================================================================================
class _Stop:
    """Signal flag set by SIGINT / SIGTERM handlers (installed only in the main thread)."""

    def __init__(self):
        self.signum: int | None = None
        self._old: dict = {}

    def __enter__(self) -> _Stop:
        if threading.current_thread() is threading.main_thread():
            for s in (signal.SIGINT, signal.SIGTERM):
                self._old[s] = signal.signal(s, self._handle)
        return self

    def _handle(self, signum, frame) -> None:
        self.signum = signum

    def __exit__(self, *exc) -> None:
        for s, h in self._old.items():
            signal.signal(s, h)

    def __bool__(self) -> bool:
        return self.signum is not None


def _task_fn() -> Callable[[dict], dict]:
    """``execute`` by its importable name (not ``__main__.execute`` under ``python -m``)."""
    import importlib

    return importlib.import_module("compare.sweep").execute


#: Seconds between a worker's checks that the coordinating process is still alive.
COORDINATOR_POLL_S = 0.25
#: Exit status of a worker that ended itself because its coordinator was gone.
EXIT_ORPHANED = 75


def _proc_stat(pid: int) -> list[str] | None:
    """The fields of ``/proc/PID/stat`` after the command name (state first), or None."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return stat[stat.rfind(")") + 2:].split()


def process_identity(pid: int) -> tuple[int, str]:
    """``(pid, start time)``: a pid reused by a later process has another start time (Linux
    ``/proc``; elsewhere the start time is '' and only the pid is checked)."""
    fields = _proc_stat(pid)
    return pid, fields[19] if fields else ""


def is_alive(identity: tuple[int, str]) -> bool:
    """Whether the process ``identity`` (from :func:`process_identity`) still runs (a zombie,
    killed but not yet reaped, counts as gone)."""
    pid, start = identity
    if start:
        fields = _proc_stat(pid)
        return fields is not None and fields[19] == start and fields[0] not in ("Z", "X")
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def watch_coordinator(identity: tuple[int, str]) -> None:
    """End this (worker) process when the coordinator ``identity`` is gone, e.g. killed by
    SIGKILL, which it cannot forward: a daemon thread polls it every COORDINATOR_POLL_S.  Once
    the workers are gone, the forkserver and resource tracker they kept open exit too."""
    def watch() -> None:
        while is_alive(identity):
            time.sleep(COORDINATOR_POLL_S)
        os._exit(EXIT_ORPHANED)

    threading.Thread(target=watch, name="multicontact-coordinator-watch", daemon=True).start()


def _init_worker(coordinator: tuple[int, str]) -> None:
    """Pool workers leave Ctrl-C to the coordinator (which stops them and keeps the records)
    and end themselves when the coordinator dies."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    watch_coordinator(coordinator)


def _pool(workers: int) -> ProcessPoolExecutor:
    import multiprocessing as mp

    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(["compare.sweep", "analytic", "fem"])
    return ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_init_worker,
                               initargs=(process_identity(os.getpid()),))


def _kill_pool(pool: ProcessPoolExecutor) -> None:
    """Stop a pool now: cancel queued work and terminate the worker processes we started."""
    procs = list(getattr(pool, "_processes", {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        if p.is_alive():
            p.terminate()
    for p in procs:
        p.join(timeout=5)


def run_local(tasks: list[dict], workers: int, stop: _Stop) -> Iterator[dict]:
    """Run tasks on a local process pool (``workers`` in flight), yielding records as they end.

    A worker process that dies breaks the pool: the cases it held are resubmitted to a fresh
    pool; a case present at ``MAX_WORKER_DEATHS`` deaths is recorded as failed.
    """
    queue, deaths = deque(tasks), Counter()
    while queue and not stop:
        pool, inflight = _pool(workers), {}
        try:
            while (queue or inflight) and not stop:
                while queue and len(inflight) < workers:
                    t = queue.popleft()
                    inflight[pool.submit(_task_fn(), t)] = t
                done, _ = futures_wait(inflight, timeout=POLL_S, return_when=FIRST_COMPLETED)
                for fut in done:
                    t = inflight.pop(fut)
                    if isinstance(fut.exception(), BrokenProcessPool):
                        inflight[fut] = t
                        raise fut.exception()
                    yield fut.result()
        except BrokenProcessPool:
            for t in inflight.values():
                deaths[t["key"]] += 1
                if deaths[t["key"]] >= MAX_WORKER_DEATHS:
                    yield infrastructure_failure(t, f"worker process died {deaths[t['key']]} "
                                                 "times while running this case")
                else:
                    queue.appendleft(t)
        finally:
            _kill_pool(pool)


def _dask():
    try:
        import distributed
    except ImportError:
        raise SweepError("--scheduler needs dask.distributed, which is not installed: "
                         "pip install 'multicontact[cluster]'") from None
    return distributed


@contextlib.contextmanager
def dask_client(scheduler: str, workers: int):
    """A dask Client on ``scheduler`` (an address), or on a new LocalCluster if 'local'."""
    distributed = _dask()
    if scheduler == "local":
        with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                      dashboard_address=None) as cluster, \
                distributed.Client(cluster) as client:
            yield client
        return
    try:
        client = distributed.Client(scheduler, timeout="20s")
    except (OSError, TimeoutError) as exc:
        raise SweepError(f"cannot connect to the dask scheduler {scheduler!r}: {exc}") from None
    with client:
        yield client


def run_dask(tasks: list[dict], client, stop: _Stop) -> Iterator[dict]:
    """Submit all tasks to a dask cluster and yield records as they finish.

    A worker that dies has its cases rescheduled by the scheduler; a case that kills
    ``distributed.scheduler.allowed-failures`` workers comes back as KilledWorker and is
    recorded as failed.  Futures are keyed by the case key, so a resubmitted case is one task.
    """
    distributed = _dask()
    by_key = {f"multicontact-sweep-{t['key']}": t for t in tasks}
    futs = [client.submit(_task_fn(), t, key=k, pure=False) for k, t in by_key.items()]
    ac = distributed.as_completed(futs)
    try:
        while not ac.is_empty() and not stop:
            if not ac.has_ready():
                time.sleep(POLL_S / 4)
                continue
            for fut in ac.next_batch(block=False):
                t = by_key[fut.key]
                try:
                    yield fut.result()
                except Exception as exc:  # noqa: BLE001 - KilledWorker, lost data, ...
                    yield infrastructure_failure(t, f"{type(exc).__name__}: {exc}")
                fut.release()
    finally:
        client.cancel([f for f in futs if not f.done()])


# =============================================================================================
# run_sweep: resume, progress, interrupt
# =============================================================================================
@dataclass(frozen=True)
class SweepOutcome:
    """Counts of one ``run_sweep`` call.

    total: cases in the (selected parts of the) sweep; skipped: already finished before this
    run; ok / failed: finished in this run; remaining: not finished (interrupt);
    signal: the signal number that stopped the run, or None; elapsed_s: wall time.
    """

    directory: str
    total: int
    skipped: int
    ok: int
    failed: int
    remaining: int
    signal: int | None
    elapsed_s: float
    run_id: str

    @property
    def throughput_per_min(self) -> float:
        n = self.ok + self.failed
        return 60.0 * n / self.elapsed_s if self.elapsed_s > 0 else float("nan")


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)))


def _progress(enabled: bool, total: int, done: int):
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    prog = Progress(TextColumn("[bold]sweep"), BarColumn(),
                    TextColumn("done {task.fields[ok]}  failed {task.fields[failed]}  "
                               "remaining {task.fields[remaining]}"),
                    TimeElapsedColumn(), console=Console(stderr=True), disable=not enabled)
    tid = prog.add_task("sweep", total=total, completed=done, ok=done, failed=0,
                        remaining=total - done)
    return prog, tid


def pending_cases(sweep: Sweep, directory: str | Path, parts: list[str] | None = None,
                  retry_failed: bool = False) -> tuple[list[SweepCase], int]:
    """Cases still to run (and how many of the selected are already finished)."""
    if parts:
        bad = sorted(set(parts) - {p.name for p in sweep.parts})
        if bad:
            raise SweepError(f"unknown part {bad[0]!r}: this sweep has "
                             f"{', '.join(p.name for p in sweep.parts)}")
    chosen = [c for c in sweep.cases if not parts or c.part in parts]
    done = read_records(directory)
    finished = {k for k, r in done.items() if r["status"] == "ok" or not retry_failed}
    todo = [c for c in chosen if c.key not in finished]
    return todo, len(chosen) - len(todo)


def run_sweep(sweep: Sweep | str | Path, directory: str | Path, *, workers: int | None = None,
              scheduler: str | None = None, parts: list[str] | None = None,
              retry_failed: bool = False, progress: bool = True) -> SweepOutcome:
    """Run the unfinished cases of a sweep into ``directory`` and return the counts.

    ``scheduler``: None = local process pool with ``workers`` processes; ``"local"`` = a dask
    LocalCluster with ``workers`` processes; ``"tcp://host:port"`` = an existing dask
    scheduler.  SIGINT / SIGTERM stop the run after keeping every finished record.
    """
    sweep = sweep if isinstance(sweep, Sweep) else load_sweep(sweep)
    workers = workers or default_workers()
    if workers < 1:
        raise SweepError(f"workers={workers!r} is not allowed: need >= 1")
    run_id, t0 = uuid.uuid4().hex[:12], time.perf_counter()
    with ResultStore(directory) as store, _Stop() as stop:
        write_atomic(store.dir / MANIFEST_FILE, json.dumps(_jsonable(sweep.manifest()), indent=1))
        todo, skipped = pending_cases(sweep, directory, parts, retry_failed)
        counts = Counter()
        prog, tid = _progress(progress, len(todo) + skipped, skipped)
        with prog, _runner(todo, sweep, workers, scheduler, stop) as records:
            for rec in records:
                rec["run"] = run_id
                store.append(rec)
                counts[rec["status"]] += 1
                prog.update(tid, advance=1, ok=skipped + counts["ok"], failed=counts["failed"],
                            remaining=len(todo) - counts.total())
    return SweepOutcome(str(directory), len(todo) + skipped, skipped, counts["ok"],
                        counts["failed"], len(todo) - counts.total(), stop.signum,
                        time.perf_counter() - t0, run_id)


@contextlib.contextmanager
def _runner(todo: list[SweepCase], sweep: Sweep, workers: int, scheduler: str | None,
            stop: _Stop):
    tasks = [c.as_task(sweep) for c in todo]
    if not tasks:
        yield iter(())
        return
    with contextlib.ExitStack() as stack:
        if scheduler is None:
            gen = run_local(tasks, workers, stop)
        else:
            gen = run_dask(tasks, stack.enter_context(dask_client(scheduler, workers)), stop)
        stack.callback(gen.close)
        yield gen


# =============================================================================================
# CLI: `multicontact sweep` (registered by compare.cli through add_sweep_parser)
# =============================================================================================
def add_sweep_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``sweep`` subcommand (and ``report --sweep DIR`` if a report parser exists)."""
    p = subparsers.add_parser("sweep", help="run a parameter sweep (process pool or dask)",
                              description=__doc__.split("\n\n")[0])
    p.add_argument("study", help="sweep file (.toml) or library study name "
                   f"({', '.join(list_studies())})")
    p.add_argument("-o", "--output", required=True, help="result directory (resumable)")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes (default: available cores)")
    p.add_argument("--scheduler", default=None,
                   help="dask scheduler address tcp://host:port, or 'local' for a dask "
                        "LocalCluster (default: local process pool, no dask needed)")
    p.add_argument("--part", action="append", default=None,
                   help="run only this part (repeatable)")
    p.add_argument("--retry-failed", action="store_true", help="run failed cases again")
    p.add_argument("--dry-run", action="store_true", help="list the cases to run and stop")
    p.add_argument("--json", action="store_true", help="print the outcome as JSON")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sweep, handler=cmd_sweep)
    report = subparsers.choices.get("report")
    if report is not None:
        _hook_report(report)
    return p


def _hook_report(report: argparse.ArgumentParser) -> None:
    """``report --sweep DIR``: route to the sweep report, else to the case report."""
    report.add_argument("--sweep", metavar="DIR", default=None,
                        help="write the report of a sweep directory into DIR/report")
    original = report.get_default("func") or report.get_default("handler")

    def route(args) -> int:
        if getattr(args, "sweep", None):
            return cmd_sweep_report(args)
        return original(args)

    report.set_defaults(func=route, handler=route)


def cmd_sweep_report(args) -> int:
    from compare.sweep_report import write_sweep_report

    try:
        out = write_sweep_report(args.sweep)
    except SweepError as exc:
        print(f"multicontact report: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    print(f"sweep report: {out / 'index.html'} and {out / 'report.md'}")
    return EXIT_OK


def _dry_run(sweep: Sweep, args) -> int:
    todo, skipped = pending_cases(sweep, args.output, args.part, args.retry_failed)
    if args.json:
        print(json.dumps({"to_run": [c.params | {"part": c.part} for c in todo],
                          "finished": skipped}))
    else:
        print(f"{sweep.name}: {len(todo)} cases to run, {skipped} finished")
        for c in todo:
            print(f"  {c.part}#{c.index} {c.task} {c.params}")
    return EXIT_OK


def cmd_sweep(args) -> int:
    """Entry of ``multicontact sweep`` (exit 0 all ok, 1 a case failed, 2 bad input, 130/143
    interrupted)."""
    try:
        sweep = load_sweep(args.study)
        if args.dry_run:
            return _dry_run(sweep, args)
        res = run_sweep(sweep, args.output, workers=args.workers, scheduler=args.scheduler,
                        parts=args.part, retry_failed=args.retry_failed,
                        progress=not args.no_progress and not args.json)
    except SweepError as exc:
        print(f"multicontact sweep: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    _print_outcome(res, args.json)
    if res.signal is not None:
        return EXIT_SIGNAL.get(res.signal, 130)
    return EXIT_FAILED_CASES if res.failed or _failed_in_store(sweep, args) else EXIT_OK


def _failed_in_store(sweep: Sweep, args) -> bool:
    recs = read_records(args.output)
    return any(recs[c.key]["status"] != "ok" for c in sweep.cases
               if c.key in recs and (not args.part or c.part in args.part))


def _print_outcome(res: SweepOutcome, as_json: bool) -> None:
    if as_json:
        print(json.dumps(vars(res) | {"throughput_per_min": res.throughput_per_min}))
        return
    state = "interrupted" if res.signal is not None else "finished"
    print(f"sweep {state}: {res.ok} ok, {res.failed} failed, {res.skipped} already done, "
          f"{res.remaining} remaining of {res.total} ({res.elapsed_s:.1f} s) -> "
          f"{Path(res.directory) / RESULTS_FILE}")
    if res.signal is not None:
        print("run the same command again to resume (finished cases are skipped)")


def main(argv: list[str] | None = None) -> int:
    """Stand-alone entry (``python -m compare.sweep``) with the sweep and report commands."""
    parser = argparse.ArgumentParser(prog="multicontact")
    sub = parser.add_subparsers(dest="command", required=True)
    add_sweep_parser(sub)
    rep = sub.add_parser("report", help="report of a sweep directory")
    rep.add_argument("--sweep", metavar="DIR", required=True)
    rep.set_defaults(func=cmd_sweep_report)
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
