"""Cases: one contact problem with its FE settings, from TOML files or built in Python.

A case is a frozen :class:`Case`.  Case files follow the schema in ``docs/cases.md``; they are
validated strictly (:mod:`compare.case_format` reads the tables: an unknown key, a wrong type, a
missing field or a value out of range raises :class:`compare.errors.CaseError` with one message
naming the key and what is allowed), and a case is written back as TOML
(:meth:`Case.to_toml`).  The library of cases ships in ``compare/cases/*.toml``;
:func:`load_case` accepts a library name or a path.
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from importlib import resources
from numbers import Integral
from pathlib import Path
from typing import Any

import numpy as np

from analytic import _validate as check
from analytic.errors import InputError as AnalyticInputError
from analytic.profiles import Profile
from compare.case_format import (
    FEM_KEYS,
    FEM_RANGES,
    NAME_ALLOWED,
    PROFILE_SCHEMAS,
    FemSettings,
    case_fields,
    name_problem,
)
from compare.errors import CaseError
from compare.tolerances import DEFAULTS as DEFAULT_TOLERANCES


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
            if key in FEM_RANGES and not FEM_RANGES[key][0](val):
                raise check.refuse(f"fem.{key}", val, FEM_RANGES[key][1])
            continue
        need = FEM_RANGES[key][1]
        if isinstance(default, int) and (isinstance(val, bool) or not isinstance(val, Integral)):
            raise check.refuse(f"fem.{key}", val, f"an integer, {need}")
        check.real(f"fem.{key}", val, need, FEM_RANGES[key][0])


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
    return Case(**case_fields(doc, name, src, base))


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
    if "name" not in doc:
        _check_stem(path)
    return case_from_dict(doc, name=path.stem, src=path.name, base=path.parent)


def _check_stem(path: Path) -> None:
    """CaseError when the file name of a case file without a ``name`` key cannot be its case
    name (it names output files and folders)."""
    why = name_problem(path.stem)
    if why:
        raise CaseError(f"case file {path.name}: its case name {path.stem!r} (the file name "
                        f"without .toml) is not allowed ({why}): need {NAME_ALLOWED}; rename "
                        "the file or give the case a name = \"...\" key")


def check_unique_names(cases: Sequence[Case], what: str) -> None:
    """CaseError when two of ``cases`` have the same name: their output files (``what``, e.g.
    "report figures and VTK series") would overwrite each other."""
    seen: dict[str, str] = {}
    for case in cases:
        if case.name in seen:
            first, second = seen[case.name] or "given", case.source or "given"
            where = f"{first} twice" if first == second else f"{first} and {second}"
            raise CaseError(f"two cases are named {case.name!r} ({where}): their {what} would "
                            "overwrite each other; give each case once, each case file with "
                            "its own name = \"...\"")
        seen[case.name] = case.source


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
            what = "is not a regular file (a folder?)" if path.exists() else "does not exist"
            raise CaseError(f"case file {text!r} {what}; allowed: a library case "
                            f"({', '.join(list_cases())}) or a .toml case file")
        return read_case(path)
    raise CaseError(f"unknown case {text!r}: not a library case ({', '.join(list_cases())}) "
                    "and not a .toml file")
