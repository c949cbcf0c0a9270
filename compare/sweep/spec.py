"""Sweep files: parsing, validation and expansion into cases.

A sweep file (TOML, schema in ``docs/sweeps.md``) names a base case (a library case, a case
file, or an inline ``[base]`` table in the case-file schema) and one or more *parts*; a part
has a task (what to compute per case) and parameter axes.  The cases of a part are the
Cartesian product of its axes, where a ``[zip.NAME]`` group of equally long axes counts as one
axis.  Parameters are dotted case-file keys: ``load.P``, ``profile.phi_inner``, ``fem.level``,
``profile.members.1.lift`` (union members), ...  A case's key is a hash of its task and its
resolved case table (not of its position), so extending an axis reuses the finished cases.
Bad input raises :class:`compare.errors.SweepError` naming the bad key or value.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
import tomllib
from collections import Counter
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

import compare
from compare import case_format
from compare import cases as case_schema
from compare.errors import SweepError
from compare.sweep.store import MANIFEST_FORMAT, SCHEMA_VERSION
from compare.sweep.tasks import TASKS, utc_now

#: Hex digits of the case key (64 bits: collisions are negligible for any realistic sweep).
KEY_DIGITS = 16
#: Most cases of a sweep (and points of one axis): every case is expanded, validated (~0.3 ms)
#: and listed in sweep.json (~120 bytes) before the first one runs, so 1e4 cases take ~3 s.
MAX_CASES = 10_000

TOP_KEYS = {"name", "description", "base", "task", "axes", "zip", "set", "parts", "report"}
PART_KEYS = {"task", "axes", "zip", "set", "description"}
SPACES = {"linspace", "geomspace", "values"}


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
        return {"format": MANIFEST_FORMAT, "schema": SCHEMA_VERSION, "name": self.name,
                "description": self.description, "source": self.source, "base": self.base,
                "parts": parts, "report": self.report, "cases": cases, "written": utc_now()}


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
    if arg[2] > MAX_CASES:
        raise _fail(src, f"axis {where}: {kind} n = {arg[2]} is not allowed: a sweep has at "
                    f"most {MAX_CASES} cases (split it into several sweeps)")
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


def _check_size(parts: tuple[Part, ...], src: str) -> None:
    """Refuse a sweep of more than MAX_CASES cases before expanding it."""
    sizes = {p.name: math.prod(len(v) for v in p.values) for p in parts}
    total = sum(sizes.values())
    if total > MAX_CASES:
        each = ", ".join(f"part '{n}': {k}" for n, k in sizes.items())
        raise _fail(src, f"{total} cases ({each}) are not allowed: a sweep has at most "
                    f"{MAX_CASES} cases (split it into several sweeps)")


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
    _check_size(parts, src)
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
