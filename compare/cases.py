"""Cases: one contact problem with its FE settings, from TOML files or built in Python.

A case is a frozen :class:`Case`.  Case files follow the schema in ``docs/cases.md``; they are
validated strictly: an unknown key, a wrong type, a missing field or a value out of range
raises :class:`compare.errors.CaseError` with one message naming the key and what is allowed.
The library of cases ships in ``compare/cases/*.toml``; :func:`load_case` accepts a library
name or a path.
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import dataclass, field, replace
from importlib import resources
from numbers import Integral
from pathlib import Path
from typing import Any

import numpy as np

from analytic import _validate as check
from analytic import profiles
from analytic.errors import InputError as AnalyticInputError
from analytic.profiles import Profile
from compare.errors import CaseError
from compare.tolerances import DEFAULTS as DEFAULT_TOLERANCES

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
FEM_KEYS = {"level": 1, "order": 1, "mesh_file": "", "penalty_factor": 100.0,
            "augmented": False, "n_normal": 10, "n_tangential": 8, "size_factor": 8.0,
            "window_margin": 0.05, "growth": 1.2}
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
}
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
    this fraction of the span on each side; growth: element size ratio away from the window.
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
    growth: float = 1.2


@dataclass(frozen=True)
class Case:
    """One verification case: profile, material, loads, Q samples, FE settings, tolerances.

    Units are consistent but arbitrary (forces per unit width).  ``P`` > 0 normal load,
    ``Q0`` tangential amplitude (0 <= Q0 <= mu P), ``M`` applied moment about x = 0 (None:
    vertical indentation, rotation locked).  ``stage2`` / ``stage3`` are the sampled Q values
    (absolute, not fractions) where stick zones and shear are compared.  ``tolerances`` maps
    the names of :mod:`compare.tolerances` to values.  ``source`` is the file (or '').
    """

    name: str
    profile: Profile = field(compare=False)
    profile_spec: dict
    P: float
    E: float
    nu: float
    mu: float
    Q0: float
    M: float | None = None
    stage2: tuple[float, ...] = ()
    stage3: tuple[float, ...] = ()
    fem: FemSettings = FemSettings()
    tolerances: dict = field(default_factory=lambda: dict(DEFAULT_TOLERANCES))
    description: str = ""
    source: str = ""

    def __post_init__(self) -> None:
        for key, value in _checked_fields(self).items():
            object.__setattr__(self, key, value)

    @property
    def A(self) -> float:
        """Composite compliance ``4 (1 - nu^2) / E``."""
        return 4.0 * (1.0 - self.nu**2) / self.E

    def with_fem(self, **changes: Any) -> Case:
        """The same case with some FE settings changed (e.g. ``level=2``)."""
        bad = set(changes) - set(FEM_KEYS)
        if bad:
            raise CaseError(f"unknown FE setting(s) {sorted(bad)}: allowed {sorted(FEM_KEYS)}")
        return replace(self, fem=replace(self.fem, **changes))

    @classmethod
    def from_profile(cls, profile: Profile, P: float, *, mu: float, A: float | None = None,
                     E: float | None = None, nu: float | None = None, Q0: float = 0.0,
                     M: float | None = None, name: str = "case", description: str = "",
                     samples: dict | None = None, tolerances: dict | None = None,
                     **fem: Any) -> Case:
        """A case from an :mod:`analytic.profiles` object, without writing TOML.

        Give the material as ``A`` (composite compliance ``4 (1 - nu^2) / E``; ``nu`` defaults
        to 0.3 for the FE side) or as ``E`` and ``nu``.  ``samples`` and ``tolerances`` are the
        case file's ``[samples]`` (fractions of Q0) and ``[tolerances]`` tables; ``**fem`` are
        FE settings (``level=2, order=2, ...``, see :class:`FemSettings`).  Everything is
        validated as a case file is (:class:`CaseError` names the bad value).  The profile must
        describe itself (``profile.name`` and ``profile.params``, as the constructors of
        :mod:`analytic.profiles` record them): the case is rebuilt from that description, so
        it round-trips through :meth:`to_dict` / :meth:`to_toml`, and a description that does
        not reproduce ``profile.h0`` is a :class:`CaseError`.
        """
        material = {k: v for k, v in (("A", A), ("E", E), ("nu", nu)) if v is not None}
        load = {"P": P, "mu": mu, "Q0": Q0, **({} if M is None else {"M": M})}
        doc = {"name": name, "description": description, "profile": profile_spec(profile),
               "material": material, "load": load, "samples": samples or {}, "fem": fem,
               "tolerances": tolerances or {}}
        case = case_from_dict(doc, name=name, src=f"Case.from_profile({name})")
        _check_same_gap(profile, case.profile)
        return case

    def to_dict(self) -> dict:
        """The case in the case-file schema (``case_from_dict(case.to_dict())`` rebuilds it)."""
        load = {"P": self.P, "mu": self.mu, "Q0": self.Q0}
        if self.M is not None:
            load["M"] = self.M
        doc = {"name": self.name, "description": self.description, "profile": self.profile_spec,
               "material": {"E": self.E, "nu": self.nu}, "load": load,
               "fem": vars(self.fem).copy(), "tolerances": dict(self.tolerances)}
        if self.Q0 > 0:
            doc["samples"] = {"stage2": [q / self.Q0 for q in self.stage2],
                              "stage3": [q / self.Q0 for q in self.stage3]}
        return doc

    def to_toml(self) -> str:
        """The case as a TOML case file (``read_case`` of the written text rebuilds it)."""
        return toml_text(self.to_dict())

    def summary(self) -> dict:
        """Plain-data description (for JSON / reports)."""
        return {"name": self.name, "description": self.description, "profile": self.profile_spec,
                "P": self.P, "E": self.E, "nu": self.nu, "A": self.A, "mu": self.mu,
                "Q0": self.Q0, "M": self.M, "stage2": list(self.stage2),
                "stage3": list(self.stage3), "fem": vars(self.fem).copy(),
                "tolerances": dict(self.tolerances), "source": self.source}


def _checked_fields(case: Case) -> dict[str, Any]:
    """The numeric fields of a :class:`Case` as floats / tuples, or :class:`CaseError` naming
    the field, its value and what is allowed (the checks of :mod:`analytic._validate`)."""
    try:
        check.instance("profile", case.profile, Profile, "an analytic.profiles.Profile")
        check.instance("fem", case.fem, FemSettings, "a compare.cases.FemSettings")
        if not isinstance(case.name, str) or not case.name:
            raise check.refuse("name", case.name, "a non-empty string")
        P, mu = check.positive("P", case.P, "load"), check.positive("mu", case.mu)
        out = {"P": P, "mu": mu, "E": check.positive("E", case.E, "Young's modulus"),
               "nu": check.real("nu", case.nu, "-1 < nu < 0.5", lambda v: -1 < v < 0.5),
               "Q0": check.real("Q0", case.Q0, f"0 <= Q0 <= mu*P = {mu * P:g}",
                                lambda v: 0 <= v <= mu * P * (1 + 1e-12)),
               "M": check.optional_real("M", case.M, "a finite moment or None")}
        _check_fem_settings(case.fem)
        for key in ("stage2", "stage3"):
            out[key] = tuple(check.vector(key, getattr(case, key), 0).tolist())
        if not isinstance(case.tolerances, dict):
            raise check.refuse("tolerances", case.tolerances, "a dict of tolerance names to values")
        for key, val in case.tolerances.items():
            check.positive(f"tolerances.{key}", val)
    except AnalyticInputError as exc:
        raise CaseError(f"Case {case.name!r}: {exc}") from None
    return out


def _check_fem_settings(fem: FemSettings) -> None:
    """Types (those of :data:`FEM_KEYS`) and :data:`FEM_RANGES` of constructed FE settings."""
    for key, default in FEM_KEYS.items():
        val = getattr(fem, key)
        if isinstance(default, bool) or isinstance(default, str):
            if type(val) is not type(default):
                raise check.refuse(f"fem.{key}", val, f"a {type(default).__name__}")
            continue
        need = FEM_RANGES[key][1]
        if isinstance(default, int) and (isinstance(val, bool) or not isinstance(val, Integral)):
            raise check.refuse(f"fem.{key}", val, f"an integer, {need}")
        check.real(f"fem.{key}", val, need, FEM_RANGES[key][0])


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
            raise CaseError(f"fem.mesh_file={vals['mesh_file']!r}: no such file ({mf}) ({src})")
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


# ---------------------------------------------------------------------------------------------
# profiles and cases written out
# ---------------------------------------------------------------------------------------------
def profile_spec(profile: Profile) -> dict:
    """The ``[profile]`` table of a profile built by :mod:`analytic.profiles`.

    From ``profile.name`` and ``profile.params``; a union becomes ``type = "union"`` with its
    members.  A profile that does not describe itself (built by hand, or a union of unions)
    raises :class:`CaseError`.
    """
    if profile.name == "union":
        members = [_simple_spec(n, p, "union member") for n, p in profile.params["members"]]
        return {"type": "union", "members": members}
    return _simple_spec(profile.name, profile.params, "profile")


def _simple_spec(kind: str, params: dict, what: str) -> dict:
    if kind not in PROFILE_SCHEMAS:
        raise CaseError(f"{what} of type {kind!r} cannot be described in a case: need one of "
                        f"{', '.join(sorted(PROFILE_SCHEMAS))} (a union's members must be simple "
                        "profiles), as built by analytic.profiles")
    return {"type": kind, **{k: _plain(v) for k, v in params.items()}}


def _plain(value: Any) -> Any:
    """TOML-ready value: str as is, numbers as float, sequences as lists of floats."""
    if isinstance(value, str):
        return value
    if isinstance(value, (list, tuple)) or hasattr(value, "tolist"):
        values = value.tolist() if hasattr(value, "tolist") else value
        return [float(v) for v in values] if isinstance(values, list) else float(values)
    return float(value)


#: Relative agreement of h0 between a profile and the one rebuilt from its description (both come
#: from the same constructor with the same arguments: any difference is a stale description).
SAME_GAP_RTOL = 1e-12
SAME_GAP_POINTS = 2001  # samples of h0 over the profile's features +- their span


def _check_same_gap(given: Profile, rebuilt: Profile) -> None:
    feats = [v for pc in given.pieces for v in (pc.lo, pc.hi) if math.isfinite(v)]
    feats += [0.5 * (m[0] + m[1]) for m in given.local_minima()]
    lo, hi = min(feats), max(feats)
    pad = max(hi - lo, given.scale)
    x = np.linspace(lo - pad, hi + pad, SAME_GAP_POINTS)
    ha, hb = given.h0(x), rebuilt.h0(x)
    fin = np.isfinite(ha)
    scale = float(np.max(np.abs(ha[fin]), initial=0.0))
    if not (np.array_equal(fin, np.isfinite(hb))
            and np.allclose(ha[fin], hb[fin], rtol=SAME_GAP_RTOL, atol=SAME_GAP_RTOL * scale)):
        worst = float(np.max(np.abs(np.where(fin, ha - hb, 0.0))))
        raise CaseError(f"profile {given.name!r} is not described by its params "
                        f"{given.params!r}: rebuilt h0 differs by up to {worst:.3g} (e.g. "
                        "after Profile.with_lift); build it with analytic.profiles constructors")


def toml_text(doc: dict) -> str:
    """A case-file dict as TOML (scalars first, then tables; union members as
    ``[[profile.members]]``)."""
    lines = [f"{k} = {_toml_value(v)}" for k, v in doc.items() if not isinstance(v, dict)]
    for key, table in doc.items():
        if isinstance(table, dict):
            lines += _toml_table(key, table)
    return "\n".join(lines) + "\n"


def _toml_table(path: str, table: dict) -> list[str]:
    out = ["", f"[{path}]"]
    out += [f"{k} = {_toml_value(v)}" for k, v in table.items()
            if not (isinstance(v, list) and v and isinstance(v[0], dict))]
    for k, v in table.items():
        if isinstance(v, list) and v and isinstance(v[0], dict):
            for member in v:
                out += ["", f"[[{path}.{k}]]"] + [f"{mk} = {_toml_value(mv)}"
                                                  for mk, mv in member.items()]
    return out


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return json.dumps(v)  # a JSON string is a valid TOML basic string
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ("nan" if math.isnan(v) else
                                                 ("inf" if v > 0 else "-inf"))
    return "[" + ", ".join(_toml_value(e) for e in v) + "]"


# ---------------------------------------------------------------------------------------------
# public
# ---------------------------------------------------------------------------------------------
def case_from_dict(doc: dict, name: str = "case", src: str = "case",
                   base: Path | None = None) -> Case:
    """Validate a parsed case table and build the :class:`Case` (errors: :class:`CaseError`)."""
    _check_keys(doc, TOP_KEYS, "", src)
    name = doc.get("name", name)
    if not isinstance(name, str) or not name:
        raise CaseError(f"{_where(src, 'name')} must be a non-empty string, got {name!r}")
    desc = doc.get("description", "")
    if not isinstance(desc, str):
        raise CaseError(f"{_where(src, 'description')} must be a string, got {desc!r}")
    if "profile" not in doc:
        _missing_table("profile", src)
    prof, spec = build_profile(doc["profile"], src)
    E, nu = _material(doc, src)
    P, mu, Q0, M = _loads(doc, src)
    s2, s3 = _samples(doc, Q0, src)
    return Case(name=name, profile=prof, profile_spec=spec, P=P, E=E, nu=nu, mu=mu, Q0=Q0, M=M,
                stage2=s2, stage3=s3, fem=_fem(doc, src, base), tolerances=_tolerances(doc, src),
                description=desc, source=src)


def read_case(path: str | Path) -> Case:
    """Load and validate one TOML case file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise CaseError(f"cannot read case file {path}: {exc.strerror}") from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise CaseError(f"{path.name}: not valid TOML: {exc}") from None
    return case_from_dict(doc, name=path.stem, src=path.name, base=path.parent)


def library_dir() -> Path:
    """Directory of the case library shipped with the package."""
    return Path(str(resources.files("compare") / "cases"))


def list_cases() -> list[str]:
    """Names of the library cases (sorted)."""
    return sorted(p.stem for p in library_dir().glob("*.toml"))


def load_case(name_or_path: str | Path | Case) -> Case:
    """A library case by name (e.g. ``"hertz"``) or a case file by path."""
    if isinstance(name_or_path, Case):
        return name_or_path
    text = str(name_or_path)
    lib = library_dir() / f"{text}.toml"
    if lib.is_file():
        return read_case(lib)
    path = Path(text)
    if path.suffix == ".toml" or path.exists():
        if not path.is_file():
            raise CaseError(f"case file {text!r} does not exist")
        return read_case(path)
    raise CaseError(f"unknown case {text!r}: not a library case ({', '.join(list_cases())}) "
                    "and not a .toml file")
