"""CSV files of the exchange format: reading (strict, line-numbered errors) and writing.

Two layouts (docs/external.md): a manifest ``steps.csv`` with one row per load step
(``stage, P, Q[, M, theta], file``) pointing at one node table per step, or a folder of step
files, each holding its loads as header items (``# stage = 1``, ``# P = 100`` ...).  Header lines
are ``# key = value`` with a one-word key (:data:`HEADER_KEY`); other ``#`` lines are comments.
The first other line names the columns.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from compare.errors import CaseError
from compare.external.exchange import (
    REQUIRED_COLUMNS,
    Conventions,
    ExternalResult,
    Meta,
    RawStep,
    check_columns,
    parse_header,
    status_codes,
)
from compare.fileio import owned_output, plan_output

MANIFEST = "steps.csv"
#: A header item is ``# key = value`` with key one word (letters, digits, _); it must be a known
#: key (a misspelt one is an error, not a silent comment).  Any other ``#`` line is a comment,
#: also one holding '=' (e.g. ``# solver tolerance = 1e-8``).
HEADER_KEY = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
LOAD_KEYS = ("stage", "P", "Q", "M", "theta")
MANIFEST_COLUMNS = ("stage", "P", "Q", "file")
MANIFEST_OPTIONAL = ("M", "theta", "step")
#: A step file's load header items that repeat its manifest row must agree with it to this
#: fraction of P (our own export writes both in full precision).
SAME_LOAD_RTOL = 1e-6
FORMAT_LINE = "# multicontact interface result (docs/external.md), format 1"


@dataclass(frozen=True)
class Table:
    """A parsed CSV file: header items (with their lines), column names, data rows."""

    path: Path
    items: dict
    item_lines: dict
    names: list
    rows: list  # (line number, [str, ...])


def read_table(path: Path) -> Table:
    """Split a CSV file into header items, column names and rows (line numbers kept)."""
    try:
        text = path.read_text(encoding="utf-8-sig")  # a spreadsheet's byte-order mark too
    except (OSError, UnicodeDecodeError) as exc:
        raise CaseError(f"{path}: cannot read ({exc})") from None
    items, item_lines, names, rows = {}, {}, None, []
    for no, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        if line.lstrip().startswith("#"):
            key, eq, value = line.lstrip()[1:].partition("=")
            if eq and names is None and HEADER_KEY.fullmatch(key.strip()):
                _set_item(items, item_lines, key.strip(), value.strip(), f"{path}, line {no}")
            continue
        cells = next(csv.reader([line]))
        if names is None:
            names = column_names(cells, f"{path}, line {no}")
        else:
            rows.append((no, cells))
    if names is None:
        raise CaseError(f"{path}: no column line found (expected e.g. 'x,p,q,status')")
    return Table(path, items, item_lines, names, rows)


def column_names(cells: list[str], where: str) -> list[str]:
    """The column line's names: each once, separated by commas."""
    names = [c.strip() for c in cells]
    if len(names) == 1 and (";" in names[0] or "\t" in names[0]):
        sep = "';'" if ";" in names[0] else "a tab"
        raise CaseError(f"{where}: the column line {names[0]!r} is separated by {sep}; allowed: "
                        "commas (e.g. 'x,p,q,status')")
    twice = [n for i, n in enumerate(names) if n in names[:i]]
    if twice:
        raise CaseError(f"{where}: column '{twice[0]}' given twice; each column once")
    return names


def _set_item(items: dict, lines: dict, key: str, value: str, where: str) -> None:
    if key in items and items[key] != value:
        raise CaseError(f"{where}: header '{key}' given twice ({items[key]!r} and {value!r})")
    items[key], lines[key] = value, where


def _float(text: str, where: str, col: str, allow_inf: bool = False) -> float:
    try:
        v = float(text)
    except ValueError:
        raise CaseError(f"{where}: column '{col}' value {text!r} is not a number") from None
    if math.isnan(v) or (math.isinf(v) and not (allow_inf and v > 0)):
        allowed = "finite numbers (or +inf: no contact possible)" if allow_inf else "finite numbers"
        raise CaseError(f"{where}: column '{col}' value {text!r} is not allowed; allowed: "
                        f"{allowed}")
    return v


def node_columns(table: Table, conv: Conventions) -> dict:
    """The node table's columns as arrays (x, p, q, status and the optional ones)."""
    check_columns(table.names, str(table.path), conv)
    if not table.rows:
        raise CaseError(f"{table.path}: no node rows after the column line")
    n = len(table.names)
    cols = {name: [] for name in table.names}
    for no, cells in table.rows:
        if len(cells) != n:
            raise CaseError(f"{table.path}, line {no}: {len(cells)} values, expected {n} "
                            f"({','.join(table.names)})")
        for name, cell in zip(table.names, cells, strict=True):
            cols[name].append(cell.strip())
    first = table.rows[0][0]
    out = {}
    if "status" in cols:
        out["status"] = status_codes(cols.pop("status"), str(table.path), first)
    for name, vals in cols.items():
        out[name] = np.array([_float(v, f"{table.path}, line {first + i}", name,
                                     allow_inf=name == "gap") for i, v in enumerate(vals)])
    return out


def _loads(get, where: str) -> tuple[int, float, float, float, float]:
    stage_text = get("stage")
    if stage_text not in ("1", "2", "3"):
        raise CaseError(f"{where}: stage {stage_text!r} is not allowed; allowed: 1, 2, 3")
    P, Q = (_float(get(k), where, k) for k in ("P", "Q"))
    M, theta = (math.nan if get(k) in (None, "") else _float(get(k), where, k)
                for k in ("M", "theta"))
    if not P > 0:
        raise CaseError(f"{where}: P = {P!r} must be > 0 (compressive normal load)")
    return int(stage_text), P, Q, M, theta


# ---------------------------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------------------------
def read_csv_result(path: Path, settings: dict | None = None) -> ExternalResult:
    """Read a manifest (file or folder holding steps.csv), a folder of step files or one step
    file; ``settings`` (key -> text) override the files' header items."""
    path = Path(path)
    if path.is_dir() and not (path / MANIFEST).is_file():
        tables = _step_files(path)
        return _result(path, tables, [_own_loads(t) for t in tables], settings or {})
    table = read_table(path / MANIFEST if path.is_dir() else path)
    if "file" not in table.names:  # a single step file
        return _result(table.path, [table], [_own_loads(table)], settings or {})
    return _result(table.path, [table], _manifest_entries(table), settings or {})


def _manifest_entries(table: Table) -> list:
    missing = [c for c in MANIFEST_COLUMNS if c not in table.names]
    if missing:
        raise CaseError(f"{table.path}: missing column '{missing[0]}'; a manifest needs "
                        f"{', '.join(MANIFEST_COLUMNS)} (optional {', '.join(MANIFEST_OPTIONAL)})")
    unknown = [c for c in table.names if c not in MANIFEST_COLUMNS + MANIFEST_OPTIONAL]
    if unknown:
        raise CaseError(f"{table.path}: unknown column '{unknown[0]}'; allowed: "
                        f"{', '.join(MANIFEST_COLUMNS + MANIFEST_OPTIONAL)}")
    out = []
    for no, cells in table.rows:
        where = f"{table.path}, line {no}"
        if len(cells) != len(table.names):
            raise CaseError(f"{where}: {len(cells)} values, expected {len(table.names)}")
        row = dict(zip(table.names, (c.strip() for c in cells), strict=True))
        step_file = table.path.parent / row["file"]
        if not step_file.is_file():
            raise CaseError(f"{where}: step file '{row['file']}' not found")
        out.append((f"{where} (step file {row['file']})", _loads(row.get, where), step_file))
    if not out:
        raise CaseError(f"{table.path}: no step rows after the column line")
    return out


def _step_files(folder: Path) -> list[Table]:
    files = sorted(folder.glob("*.csv"))
    if not files:
        raise CaseError(f"{folder}: no {MANIFEST} and no step files (*.csv) found")
    return [read_table(f) for f in files]


def _own_loads(t: Table) -> tuple:
    missing = [k for k in ("stage", "P", "Q") if k not in t.items]
    if missing:
        raise CaseError(f"{t.path}: missing header item '# {missing[0]} = ...'; without a "
                        f"{MANIFEST} every step file needs # stage, # P, # Q (# M, # theta)")
    return str(t.path), _loads(t.items.get, str(t.path)), t


def _result(source: Path, header_tables: list, entries: list, settings: dict) -> ExternalResult:
    tables = [tab if isinstance(tab, Table) else read_table(tab) for _, _, tab in entries]
    own, step_files = {id(t) for t in header_tables}, []
    for (where, loads, _), table in zip(entries, tables, strict=True):
        if id(table) not in own:  # a manifest's step file: its load items repeat its row
            check_step_loads(table, loads, where)
            step_files.append(table)
    items, lines = {}, {}
    for t in header_tables + step_files:
        for k, v in t.items.items():
            if k not in LOAD_KEYS:
                _set_item(items, lines, k, v, t.item_lines[k])
    items.update(settings)
    lines.update(dict.fromkeys(settings, f"{source} (--set / settings)"))
    conv, meta = parse_header(items, str(source), lines)
    raw = [RawStep(where, *loads, node_columns(table, conv))
           for (where, loads, _), table in zip(entries, tables, strict=True)]
    return ExternalResult(str(source), tuple(raw), conv, meta)


def check_step_loads(table: Table, loads: tuple, where: str) -> None:
    """A manifest's step file may repeat its loads as header items (our own export writes its
    stage, P and Q); each must agree with the manifest row (P and Q to SAME_LOAD_RTOL of P, M
    and theta to SAME_LOAD_RTOL of themselves): the loads are the manifest's."""
    row = dict(zip(LOAD_KEYS, loads, strict=True))
    for key in (k for k in LOAD_KEYS if k in table.items):
        text, at = table.items[key], table.item_lines[key]
        ref = row[key]
        if key == "stage":
            same = text == str(ref)
        elif math.isnan(ref):
            raise CaseError(f"{at}: header '{key} = {text}' in a step file whose manifest row "
                            f"gives no {key}; give {key} in the manifest ({where})")
        else:
            value = _float(text, at, key)
            floor = SAME_LOAD_RTOL * row["P"] if key in ("P", "Q") else 1e-12
            same = abs(value - ref) <= max(SAME_LOAD_RTOL * abs(ref), floor)
        if not same:
            raise CaseError(f"{at}: header '{key} = {text}' disagrees with the manifest's {key} "
                            f"= {ref!r} ({where}); give the loads in {MANIFEST} only, or the "
                            "same in both")


# ---------------------------------------------------------------------------------------------
# writing (our own FE history -> manifest + one file per step), atomically
# ---------------------------------------------------------------------------------------------
def _num(v: float) -> str:
    return "" if v is None or (isinstance(v, float) and math.isnan(v)) else repr(float(v))


def step_text(step) -> str:
    """Node table of one FemStep (x, w, p, q, status, slip, gap) with full precision."""
    it = step.interface
    lines = [f"{FORMAT_LINE}\n# stage = {step.stage}\n# P = {_num(step.P)}\n# Q = {_num(step.Q)}",
             "x,w,p,q,status,slip,gap"]
    cols = (it.x, it.w, it.p, it.q, it.status, it.slip, it.gap)
    for row in zip(*(np.asarray(c).tolist() for c in cols), strict=True):
        x, w, p, q, s, sl, g = row
        lines.append(f"{x!r},{w!r},{p!r},{q!r},{int(s)},{sl!r},{g!r}")
    return "\n".join(lines) + "\n"


def manifest_text(hist, meta: Meta) -> str:
    """steps.csv of a history: header (meta, our conventions) and one row per step."""
    conv = Conventions()
    head = [FORMAT_LINE] + [f"# {f.name} = {getattr(meta, f.name)}" for f in fields(Meta)]
    head += [f"# {f.name} = {getattr(conv, f.name)}" for f in fields(Conventions)]
    rows = [f"{s.index},{s.stage},{_num(s.P)},{_num(s.Q)},{_num(s.M)},{_num(s.plate[2])},"
            f"{step_name(s.index)}" for s in hist.steps]
    return "\n".join(head + ["step,stage,P,Q,M,theta,file"] + rows) + "\n"


def step_name(index: int) -> str:
    return f"step_{index:04d}.csv"


def write_csv_result(hist, directory: str | Path, meta: Meta, force: bool = False) -> Path:
    """Write ``hist`` (fem.FemHistory) as manifest + step files into ``directory``.

    Written through :func:`compare.fileio.owned_output` (a folder holding files multicontact
    did not write is refused unless ``force``; the previous export is replaced atomically).
    Returns the manifest path.
    """
    plan = plan_output(directory, "export", force, expected=(MANIFEST,))
    with owned_output(directory, "export", force, plan) as tmp:
        for s in hist.steps:
            (tmp / step_name(s.index)).write_text(step_text(s), encoding="utf-8")
        (tmp / MANIFEST).write_text(manifest_text(hist, meta), encoding="utf-8")
    return plan.out / MANIFEST


__all__ = ["MANIFEST", "REQUIRED_COLUMNS", "read_csv_result", "write_csv_result"]
