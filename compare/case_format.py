"""The case-file format: its schema, and its tables read into validated plain values.

Case files (``docs/cases.md``) are TOML with the tables ``[profile]``, ``[material]``, ``[load]``,
``[samples]``, ``[fem]`` and ``[tolerances]``.  This module holds the schema (allowed keys, their
defaults and ranges, :class:`FemSettings`) and reads each table strictly: an unknown key, a
wrong type, a missing field or a value out of range raises :class:`compare.errors.CaseError`
with one message naming the key and what is allowed.  :func:`case_fields` gives the keyword
arguments of :class:`compare.cases.Case`, which adds the object, its TOML round trip and the
case library.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from analytic import profiles
from analytic.errors import InputError as AnalyticInputError
from analytic.profiles import Profile
from compare.errors import CaseError
from compare.tolerances import DEFAULTS as DEFAULT_TOLERANCES
from fem.settings import DEFAULT_LAYOUT, GROWTH, INCOMPATIBLE_MODES, LAYOUTS

REQUIRED = object()  # marker: key without a default

#: Profile constructors and their keys (default value, or REQUIRED).
PROFILE_SCHEMAS: dict[str, dict[str, Any]] = {
    "cylinder": {"R": REQUIRED, "center": 0.0, "lift": 0.0},
    "flat_punch": {"left": REQUIRED, "right": REQUIRED, "corner_radius": 0.0, "lift": 0.0,
                   "corner_shape": "circular"},
    "wedge": {"angle_left": REQUIRED, "angle_right": REQUIRED, "apex": 0.0, "lift": 0.0},
    "biquadratic": {"c": REQUIRED, "R": REQUIRED},
    "double_wedge": {"c": REQUIRED, "phi_inner": REQUIRED, "phi_outer": REQUIRED},
    "tabulated": {"x": REQUIRED, "h": REQUIRED, "kinks": []},
}
LIST_KEYS = {"x", "h", "kinks"}
STRING_KEYS = {"corner_shape"}

TOP_KEYS = {"name", "description", "profile", "material", "load", "samples", "fem",
            "tolerances"}
MATERIAL_KEYS = {"E": REQUIRED, "nu": REQUIRED, "A": None}
LOAD_KEYS = {"P": REQUIRED, "mu": REQUIRED, "Q0": None, "Q0_ratio": None, "M": None}
SAMPLE_KEYS = {"stage2": [0.5, 0.75, 1.0], "stage3": [0.0, -0.5, -1.0]}
#: Allowed ranges of the numeric FE settings (test, what is allowed).
FEM_RANGES = {
    "level": (lambda v: -3 <= v <= 6, "-3 <= level <= 6"),
    "order": (lambda v: v in (1, 2), "1 or 2"),
    "penalty_factor": (lambda v: v > 0, "> 0"),
    "n_normal": (lambda v: v >= 1, ">= 1"),
    "n_tangential": (lambda v: v >= 1, ">= 1"),
    "size_factor": (lambda v: v >= 2, ">= 2"),
    "window_margin": (lambda v: 0 <= v <= 1, "0 <= window_margin <= 1"),
    "growth": (lambda v: 1 < v <= 2, "1 < growth <= 2"),
    "layout": (lambda v: v in LAYOUTS, " or ".join(repr(v) for v in LAYOUTS)),
}
#: A case name becomes a file and folder name of the outputs (``run --vtk DIR/<name>/``, a
#: report's ``figures/<name>_0.png``): one safe path component of at most NAME_MAX characters.
NAME_MAX = 100
NAME_PATTERN = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9_.-]*")
NAME_ALLOWED = (f"1 to {NAME_MAX} letters, digits, '_', '-' or '.', not starting with '.' and "
                "without '..' (it names output files and folders)")
DEFAULT_NU = 0.3  # used to split a given composite compliance A into (E, nu) for the FE side


@dataclass(frozen=True)
class FemSettings:
    """FE discretisation of a case.

    level: mesh refinement level (fine element = window / (48 * 2**level)); order: 1 (Q4) or
    2 (Q9); mesh_file: a meshio two-body mesh instead of the generated one ('' = generate);
    penalty_factor: k_n = penalty_factor * E / h; augmented: augmented Lagrangian (Uzawa);
    n_normal: increments of stage 1; n_tangential: equal increments of stage 2 (stage 3 has
    twice as many) added to the sample points; size_factor: body half-width / window
    half-width; window_margin: the refined window is the analytic contact span widened by
    this fraction of the span on each side; growth: element size ratio away from the window
    (fem.MeshSpec.growth); layout: 'rings' (graded rings, the default) or 'tensor' (the tensor
    product mesh); edge_nodes: put a mesh node on every analytic contact edge of the full
    normal load (the phase-locked refinement of ``converge --phase-locked``: the edge error then
    no longer swings with where the edge falls between nodes); incompatible: Q1 elements with
    incompatible modes (fem.MeshSpec.incompatible, the default; no effect on Q2).
    """

    level: int = 1
    order: int = 1
    mesh_file: str = ""
    penalty_factor: float = 100.0
    augmented: bool = False
    n_normal: int = 10
    n_tangential: int = 8
    size_factor: float = 8.0
    window_margin: float = 0.05
    growth: float = GROWTH
    layout: str = DEFAULT_LAYOUT
    edge_nodes: bool = False
    incompatible: bool = INCOMPATIBLE_MODES


#: The ``[fem]`` keys and their defaults (the type of a value follows its default).
FEM_KEYS = {f.name: f.default for f in fields(FemSettings)}


# ---------------------------------------------------------------------------------------------
# typed key access with one clear message per error
# ---------------------------------------------------------------------------------------------
def _where(src: str, key: str) -> str:
    return f"{src}: key '{key}'"


def _check_keys(table: Any, allowed, path: str, src: str) -> dict:
    if not isinstance(table, dict):
        raise CaseError(f"{_where(src, path)} must be a table, got {type(table).__name__}")
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        name = f"{path}.{unknown[0]}" if path else unknown[0]
        raise CaseError(f"{src}: unknown key '{name}'; allowed keys"
                        f"{' in [' + path + ']' if path else ''}: {', '.join(sorted(allowed))}")
    return table


def _number(table: dict, key: str, path: str, src: str, default: Any = REQUIRED) -> Any:
    full = f"{path}.{key}" if path else key
    if key not in table:
        if default is REQUIRED:
            raise CaseError(f"{src}: missing required key '{full}'")
        return default
    val = table[key]
    if isinstance(val, bool) or not isinstance(val, (int, float)):
        raise CaseError(f"{_where(src, full)} must be a number, got {type(val).__name__} "
                        f"{val!r}")
    if not math.isfinite(val):
        raise CaseError(f"{full}={val!r} is not allowed: need a finite number ({src})")
    return float(val)


def _typed(table: dict, key: str, default: Any, path: str, src: str) -> Any:
    """A key whose type follows its default (int, bool, str, float or list of numbers)."""
    full = f"{path}.{key}"
    if key not in table:
        if default is REQUIRED:
            raise CaseError(f"{src}: missing required key '{full}'")
        return default
    val = table[key]
    if isinstance(default, bool):
        ok = isinstance(val, bool)
        kind = "a boolean (true/false)"
    elif isinstance(default, int):
        ok = isinstance(val, int) and not isinstance(val, bool)
        kind = "an integer"
    elif isinstance(default, str):
        ok = isinstance(val, str)
        kind = "a string"
    elif isinstance(default, list) or key in LIST_KEYS:
        ok = isinstance(val, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                           for v in val)
        kind = "a list of numbers"
    else:
        return _number(table, key, path, src, default)
    if not ok:
        raise CaseError(f"{_where(src, full)} must be {kind}, got {type(val).__name__} {val!r}")
    return val


# ---------------------------------------------------------------------------------------------
# sections
# ---------------------------------------------------------------------------------------------
def build_profile(spec: dict, src: str = "case", path: str = "profile") -> tuple[Profile, dict]:
    """Profile from its TOML table (``type`` + constructor keys; ``union`` has ``members``)."""
    if not isinstance(spec, dict):
        raise CaseError(f"{_where(src, path)} must be a table, got {type(spec).__name__}")
    kind = spec.get("type", REQUIRED)
    allowed_types = sorted([*PROFILE_SCHEMAS, "union"])
    if kind is REQUIRED:
        raise CaseError(f"{src}: missing required key '{path}.type' (one of "
                        f"{', '.join(allowed_types)})")
    if kind not in allowed_types:
        raise CaseError(f"{path}.type={kind!r} is not allowed ({src}): need one of "
                        f"{', '.join(allowed_types)}")
    if kind == "union":
        return _union_profile(spec, src, path)
    schema = PROFILE_SCHEMAS[kind]
    _check_keys(spec, {"type", *schema}, path, src)
    kwargs = {}
    for key, default in schema.items():
        if key in STRING_KEYS or key in LIST_KEYS:
            kwargs[key] = _typed(spec, key, default, path, src)
        else:
            kwargs[key] = _number(spec, key, path, src, default)
    try:
        prof = getattr(profiles, kind)(**kwargs)
    except AnalyticInputError as exc:
        raise CaseError(f"{src}: [{path}] {exc}") from None
    return prof, {"type": kind, **kwargs}


def _union_profile(spec: dict, src: str, path: str) -> tuple[Profile, dict]:
    _check_keys(spec, {"type", "members"}, path, src)
    members = spec.get("members")
    if not isinstance(members, list) or len(members) < 1:
        raise CaseError(f"{_where(src, path + '.members')} must be a non-empty array of tables "
                        "([[profile.members]])")
    built = [build_profile(m, src, f"{path}.members[{i}]") for i, m in enumerate(members)]
    for i, (_, s) in enumerate(built):
        if s["type"] == "union":
            raise CaseError(f"{path}.members[{i}].type='union' is not allowed ({src}): "
                            "members must be simple profiles")
    try:
        prof = profiles.union(*(p for p, _ in built))
    except AnalyticInputError as exc:
        raise CaseError(f"{src}: [{path}] {exc}") from None
    return prof, {"type": "union", "members": [s for _, s in built]}


def _material(doc: dict, src: str) -> tuple[float, float]:
    if "material" not in doc:
        _missing_table("material", src)
    mat = _check_keys(doc["material"], MATERIAL_KEYS, "material", src)
    if "A" in mat:
        if "E" in mat:
            raise CaseError(f"{src}: give either material.A or (material.E, material.nu), "
                            "not both")
        A = _number(mat, "A", "material", src)
        nu = _number(mat, "nu", "material", src, DEFAULT_NU)
        _check_nu(nu, src)
        if A <= 0:
            raise CaseError(f"material.A={A!r} is not allowed: need A = 4(1 - nu^2)/E > 0 ({src})")
        return 4.0 * (1.0 - nu**2) / A, nu
    E = _number(mat, "E", "material", src)
    nu = _number(mat, "nu", "material", src)
    if E <= 0:
        raise CaseError(f"material.E={E!r} is not allowed: need E > 0 ({src})")
    _check_nu(nu, src)
    return E, nu


def _check_nu(nu: float, src: str) -> None:
    if not -1.0 < nu < 0.5:
        raise CaseError(f"material.nu={nu!r} is not allowed: need -1 < nu < 0.5 ({src})")


def _missing_table(name: str, src: str) -> None:
    raise CaseError(f"{src}: missing required table [{name}]")


def _loads(doc: dict, src: str) -> tuple[float, float, float, float | None]:
    if "load" not in doc:
        _missing_table("load", src)
    load = _check_keys(doc["load"], LOAD_KEYS, "load", src)
    P = _number(load, "P", "load", src)
    mu = _number(load, "mu", "load", src)
    if P <= 0:
        raise CaseError(f"load.P={P!r} is not allowed: need P > 0 ({src})")
    if mu <= 0:
        raise CaseError(f"load.mu={mu!r} is not allowed: need mu > 0 ({src})")
    if "Q0" in load and "Q0_ratio" in load:
        raise CaseError(f"{src}: give either load.Q0 or load.Q0_ratio (= Q0 / (mu P)), not both")
    if "Q0_ratio" in load:
        r = _number(load, "Q0_ratio", "load", src)
        if not 0.0 <= r <= 1.0:
            raise CaseError(f"load.Q0_ratio={r!r} is not allowed: need 0 <= Q0_ratio <= 1 "
                            f"({src})")
        Q0 = r * mu * P
    else:
        Q0 = _number(load, "Q0", "load", src, 0.0)
    if not 0.0 <= Q0 <= mu * P * (1 + 1e-12):
        raise CaseError(f"load.Q0={Q0!r} is not allowed: need 0 <= Q0 <= mu*P = {mu * P:g} "
                        f"({src})")
    M = _number(load, "M", "load", src, None)
    return P, mu, Q0, M


def _samples(doc: dict, Q0: float, src: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
    sam = _check_keys(doc.get("samples", {}), SAMPLE_KEYS, "samples", src)
    s2 = _typed(sam, "stage2", SAMPLE_KEYS["stage2"], "samples", src)
    s3 = _typed(sam, "stage3", SAMPLE_KEYS["stage3"], "samples", src)
    if any(not 0.0 < f <= 1.0 for f in s2) or sorted(s2) != list(s2) or len(set(s2)) != len(s2):
        raise CaseError(f"samples.stage2={s2!r} is not allowed: need strictly increasing "
                        f"fractions of Q0 in (0, 1] ({src})")
    if any(not -1.0 <= f < 1.0 for f in s3) or sorted(s3, reverse=True) != list(s3) \
            or len(set(s3)) != len(s3):
        raise CaseError(f"samples.stage3={s3!r} is not allowed: need strictly decreasing "
                        f"fractions of Q0 in [-1, 1) ({src})")
    if Q0 == 0.0:
        return (), ()
    return tuple(float(f) * Q0 for f in s2), tuple(float(f) * Q0 for f in s3)


def _fem(doc: dict, src: str, base: Path | None) -> FemSettings:
    tab = _check_keys(doc.get("fem", {}), FEM_KEYS, "fem", src)
    vals = {k: _typed(tab, k, d, "fem", src) for k, d in FEM_KEYS.items()}
    for key, (ok, allowed) in FEM_RANGES.items():
        if not ok(vals[key]):
            raise CaseError(f"fem.{key}={vals[key]!r} is not allowed: need {allowed} ({src})")
    if vals["mesh_file"]:
        mf = Path(vals["mesh_file"])
        mf = mf if mf.is_absolute() or base is None else base / mf
        if not mf.is_file():
            what = "not a regular file (a folder?)" if mf.exists() else "no such file"
            raise CaseError(f"fem.mesh_file={vals['mesh_file']!r}: {what} ({mf}) ({src}); "
                            "allowed: a mesh file meshio reads (docs/cases.md)")
        vals["mesh_file"] = str(mf)
    return FemSettings(**vals)


def _tolerances(doc: dict, src: str) -> dict:
    tab = _check_keys(doc.get("tolerances", {}), DEFAULT_TOLERANCES, "tolerances", src)
    out = dict(DEFAULT_TOLERANCES)
    for key in tab:
        val = _number(tab, key, "tolerances", src)
        if val <= 0:
            raise CaseError(f"tolerances.{key}={val!r} is not allowed: need > 0 ({src})")
        out[key] = val
    return out


def name_problem(name: str) -> str:
    """Why ``name`` cannot be a case name ('' if it can): see :data:`NAME_ALLOWED`."""
    if not isinstance(name, str):
        return f"a string is needed, got {type(name).__name__}"
    if len(name) > NAME_MAX:
        return f"it has {len(name)} characters"
    if not NAME_PATTERN.fullmatch(name) or ".." in name:
        return "it is not one plain file name"
    return ""


def check_name(name: str, src: str) -> None:
    """CaseError naming ``name`` and what is allowed when it cannot be a case name."""
    why = name_problem(name)
    if why:
        raise CaseError(f"name={name!r} is not allowed ({why}): need {NAME_ALLOWED} ({src})")


def case_fields(doc: dict, name: str = "case", src: str = "case",
                base: Path | None = None) -> dict[str, Any]:
    """Validate a parsed case table (the schema of ``docs/cases.md``) and return the keyword
    arguments of :class:`compare.cases.Case` (errors: :class:`CaseError` naming the key)."""
    _check_keys(doc, TOP_KEYS, "", src)
    name = doc.get("name", name)
    if not isinstance(name, str) or not name:
        raise CaseError(f"{_where(src, 'name')} must be a non-empty string, got {name!r}")
    if "name" in doc:
        check_name(name, src)
    desc = doc.get("description", "")
    if not isinstance(desc, str):
        raise CaseError(f"{_where(src, 'description')} must be a string, got {desc!r}")
    if "profile" not in doc:
        _missing_table("profile", src)
    prof, spec = build_profile(doc["profile"], src)
    E, nu = _material(doc, src)
    P, mu, Q0, M = _loads(doc, src)
    s2, s3 = _samples(doc, Q0, src)
    return dict(name=name, profile=prof, profile_spec=spec, P=P, E=E, nu=nu, mu=mu, Q0=Q0, M=M,
                stage2=s2, stage3=s3, fem=_fem(doc, src, base), tolerances=_tolerances(doc, src),
                description=desc, source=src)
