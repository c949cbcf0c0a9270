"""VTK series of the exchange format: a ``.pvd`` collection of ``.vtu`` interface lines.

Each interface ``.vtu`` holds the nodes as points (x = first coordinate), the point data
``p, q`` (optional ``status, w, slip, gap, ux``; other arrays are ignored) and the step's loads
as field data ``stage, P, Q`` (optional ``M, theta``), as ``fem.write_vtk`` writes them.  A
``.pvd`` listing several parts (e.g. bodies and interface) is read for the part whose ``.vtu``
files are lines with point data ``p``.  Conventions and meta data come from ``settings``.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from compare.errors import CaseError
from compare.external.exchange import (
    OPTIONAL_COLUMNS,
    REQUIRED_COLUMNS,
    ExternalResult,
    RawStep,
    check_columns,
    parse_header,
)
from fem.errors import InputError
from fem.mesh import read_meshio


def pvd_entries(path: Path) -> list[tuple[str, str]]:
    """(part, file) of every DataSet of a .pvd collection, in the order of their ``timestep``
    attributes when every DataSet has one (as ParaView shows them), else in file order."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise CaseError(f"{path}: not a readable .pvd collection ({exc})") from None
    sets = root.findall("./Collection/DataSet")
    if not sets or any("file" not in d.attrib for d in sets):
        raise CaseError(f"{path}: a .pvd needs <Collection> of <DataSet file=...> entries")
    if all("timestep" in d.attrib for d in sets):
        sets = sorted(sets, key=lambda d: _timestep(d.attrib["timestep"], path))
    return [(d.attrib.get("part", "0"), d.attrib["file"]) for d in sets]


def _timestep(text: str, path: Path) -> float:
    try:
        t = float(text)
    except ValueError:
        t = math.nan
    if not math.isfinite(t):
        raise CaseError(f"{path}: DataSet timestep {text!r} is not allowed; allowed: finite "
                        "numbers")
    return t


#: What an interface file of a series may be (the reader's error).
VTU_ALLOWED = "a VTK XML unstructured grid (.vtu) of line cells, as fem.write_vtk writes"


def _read_vtu(path: Path, where: str):
    if not path.is_file():
        raise CaseError(f"{where}: file '{path.name}' not found")
    try:
        return read_meshio(path, "interface file", VTU_ALLOWED)
    except InputError as exc:
        raise CaseError(f"{where}: {exc}") from None


def _is_interface(mesh) -> bool:
    return "p" in mesh.point_data and all(c.type == "line" for c in mesh.cells)


def _field(mesh, key: str, where: str, required: bool) -> float:
    if key not in mesh.field_data:
        if required:
            raise CaseError(f"{where}: missing field data '{key}'; an interface .vtu needs "
                            "field data stage, P, Q (optional M, theta)")
        return math.nan
    v = float(np.ravel(mesh.field_data[key])[0])
    if not math.isfinite(v):
        raise CaseError(f"{where}: field data {key} = {v!r} must be finite")
    return v


def raw_step(mesh, where: str, conv) -> RawStep:
    """One step from an interface .vtu mesh."""
    names = [n for n in mesh.point_data if n in REQUIRED_COLUMNS + OPTIONAL_COLUMNS]
    check_columns(["x", *names], where, conv)
    cols = {"x": np.asarray(mesh.points[:, 0], float)}
    for n in names:
        v = np.asarray(mesh.point_data[n], float)
        if v.ndim > 1 and v.size != v.shape[0]:
            raise CaseError(f"{where}: point data '{n}' has {v.size // v.shape[0]} components "
                            "per point; allowed: one number per point (the normal or "
                            "tangential component, in the sense of docs/external.md)")
        v = v.ravel()
        bad = np.isnan(v) | (np.isinf(v) & ((n != "gap") | (v < 0)))
        if bad.any():
            raise CaseError(f"{where}: point data '{n}' is {float(v[bad][0])!r} at point "
                            f"{int(np.flatnonzero(bad)[0])}; allowed: finite numbers")
        cols[n] = v
    if "status" in cols:
        st = cols["status"]
        odd = st[~np.isin(st, (0, 1, 2))]
        if odd.size:
            raise CaseError(f"{where}: point data 'status' has {float(odd[0])!r}; allowed: 0 "
                            "open, 1 stick, 2 slip")
        cols["status"] = st.astype(np.int8)
    stage = _field(mesh, "stage", where, True)
    if stage not in (1.0, 2.0, 3.0):
        raise CaseError(f"{where}: field data stage = {stage!r}; allowed: 1, 2, 3")
    P, Q = _field(mesh, "P", where, True), _field(mesh, "Q", where, True)
    if not P > 0:
        raise CaseError(f"{where}: P = {P!r} must be > 0 (compressive normal load)")
    return RawStep(where, int(stage), P, Q, _field(mesh, "M", where, False),
                   _field(mesh, "theta", where, False), cols)


def read_pvd_result(path: Path, settings: dict | None = None) -> ExternalResult:
    """Read the interface part of a .pvd series (see the module docstring)."""
    path = Path(path)
    conv, meta = parse_header(dict(settings or {}), f"{path} (settings)")
    entries = pvd_entries(path)
    parts = list(dict.fromkeys(part for part, _ in entries))
    steps = []
    for part in parts:
        files = [f for p, f in entries if p == part]
        first = _read_vtu(path.parent / files[0], f"{path}, part {part}")
        if not _is_interface(first):
            continue
        for k, f in enumerate(files):
            where = f"{path}, step {k} ({f})"
            mesh = first if k == 0 else _read_vtu(path.parent / f, where)
            steps.append(raw_step(mesh, where, conv))
        break
    if not steps:
        raise CaseError(f"{path}: no interface part found (a .vtu of line cells with point "
                        "data p, q, status)")
    return ExternalResult(str(path), tuple(steps), conv, meta)
