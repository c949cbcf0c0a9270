"""Random audit cases: profiles, loads and modes drawn from one integer seed.

Every case is a pure function of its seed (``numpy.random.default_rng(seed)``), so a seed is
the whole regression record. The profile is kept as a *spec* -- nested ``(constructor, kwargs)``
pairs of :mod:`analytic.profiles` public constructors -- from which :func:`build_profile`
builds it and :func:`constructor_call` prints the Python call that rebuilds it.

Families (non-dimensional: ``A = 1``, lengths ~ 1):

- ``cylinders``: union of 1-5 cylinders, random radii, centres and lifts;
- ``punch``: a sharp, circular-cornered or parabolic-cornered flat punch with 0-2 cylinders
  beside it;
- ``wedge``, ``double_wedge``: random angles (the paper's Fig. 4 for the double wedge);
- ``tabulated``: a smooth measured-like profile (parabola plus waves) sampled at 41 points;
- ``biquadratic``: Gladwell's punch.

Loads span ~4 decades from just above the first touch to contact widths of order the feature
size. Modes: vertical indentation, applied moment (centre of pressure inside the loaded
feature), and stick states of stage 2 or 3 on either normal mode.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from analytic import profiles
from analytic.profiles import Profile

A = 1.0
"""Composite compliance of every case (the problem scales with A P; A = 1 loses nothing)."""
FAMILIES = ("cylinders", "punch", "wedge", "double_wedge", "tabulated", "biquadratic")
FAMILY_WEIGHTS = (0.34, 0.34, 0.08, 0.08, 0.11, 0.05)
MODES = ("vertical", "moment", "stick2", "stick3")
MODE_WEIGHTS = (0.4, 0.3, 0.15, 0.15)
TABLE_POINTS = 41
"""Samples of a tabulated profile (a coarse measured profile)."""

Spec = tuple[str, dict]


@dataclass(frozen=True)
class AuditCase:
    """One audit case.

    Attributes:
        seed: the integer that reproduces the case (:func:`make_case`).
        family: profile family (see the module docstring).
        spec: ``(constructor, kwargs)``; a union's kwargs hold ``members`` (a list of specs).
        P: normal load per unit width; A: composite compliance.
        M: applied moment about x = 0 (``None``: vertical indentation).
        mode: ``vertical``, ``moment``, ``stick2`` or ``stick3``.
        mu, Q, Q0: friction coefficient, tangential load, stage-3 turning load (stick modes;
            ``Q0 = None`` in stage 2), else ``None``.
        core: ``(lo, hi)`` where the load is carried (the feature the moment centre lies in);
            the audit's window for the discretised solution starts from the returned zones.
    """

    seed: int
    family: str
    spec: Spec
    P: float
    A: float
    M: float | None
    mode: str
    mu: float | None
    Q: float | None
    Q0: float | None
    core: tuple[float, float]

    @property
    def profile(self) -> Profile:
        return build_profile(self.spec)

    @property
    def call(self) -> str:
        """The Python call that rebuilds the profile (``tabulated``: its generator)."""
        return constructor_call(self.spec, self.seed)

    def describe(self) -> str:
        """One line: seed, family, profile call, load and mode."""
        load = f"P={self.P!r}, A={self.A!r}"
        if self.M is not None:
            load += f", M={self.M!r}"
        if self.mode.startswith("stick"):
            load += f", mu={self.mu!r}, Q={self.Q!r}, Q0={self.Q0!r}"
        return f"seed {self.seed} [{self.family}, {self.mode}] {self.call}; {load}"


def build_profile(spec: Spec) -> Profile:
    """The :mod:`analytic.profiles` profile of ``spec``."""
    name, kwargs = spec
    if name == "union":
        return profiles.union(*(build_profile(m) for m in kwargs["members"]))
    return getattr(profiles, name)(**kwargs)


def constructor_call(spec: Spec, seed: int) -> str:
    """``profiles.name(k=v, ...)`` for ``spec`` (floats in full precision)."""
    name, kwargs = spec
    if name == "union":
        inner = ", ".join(constructor_call(m, seed) for m in kwargs["members"])
        return f"profiles.union({inner})"
    if name == "tabulated":
        return f"profiles.tabulated(*compare.audit.cases.table({seed}))"
    args = ", ".join(f"{k}={v!r}" for k, v in kwargs.items())
    return f"profiles.{name}({args})"


def make_case(seed: int) -> AuditCase:
    """The audit case of ``seed`` (deterministic)."""
    rng = np.random.default_rng(seed)
    family = str(rng.choice(FAMILIES, p=FAMILY_WEIGHTS))
    spec, P, core = _FAMILY_MAKERS[family](rng, seed)
    mode = str(rng.choice(MODES, p=MODE_WEIGHTS))
    moment = mode == "moment" or (mode != "vertical" and rng.random() < 0.5)
    M = P * _pressure_centre(rng, core) if moment else None
    mu, Q, Q0 = _tangential(rng, mode, P)
    return AuditCase(int(seed), family, spec, float(P), A, M, mode, mu, Q, Q0, core)


def _loguniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(10 ** rng.uniform(np.log10(lo), np.log10(hi)))


def _pressure_centre(rng: np.random.Generator, core: tuple[float, float]) -> float:
    """A centre of pressure M/P in the middle 60 % of the loaded feature."""
    mid, half = 0.5 * (core[0] + core[1]), 0.5 * (core[1] - core[0])
    return float(mid + 0.6 * half * rng.uniform(-1.0, 1.0))


def _tangential(rng: np.random.Generator, mode: str, P: float
                ) -> tuple[float | None, float | None, float | None]:
    """Stage 2: ``|Q| <= 0.95 mu P``; stage 3: ``|Q0| <= 0.95 mu P``, Q between -Q0 and Q0."""
    if mode not in ("stick2", "stick3"):
        return None, None, None
    mu = float(rng.uniform(0.2, 0.8))
    sign = float(rng.choice([-1.0, 1.0]))
    ratio = float(rng.uniform(0.05, 0.95))
    if mode == "stick2":
        return mu, sign * ratio * mu * P, None
    Q0 = sign * ratio * mu * P
    return mu, float(Q0 * rng.uniform(-0.98, 0.98)), Q0


# ---------------------------------------------------------------------------------- families
def _cylinder_members(rng: np.random.Generator, n: int, centres: np.ndarray) -> list[Spec]:
    return [("cylinder", {"R": _loguniform(rng, 0.3, 3.0), "center": float(c),
                          "lift": float(rng.uniform(0.0, 0.02))}) for c in centres[:n]]


def _cylinders(rng: np.random.Generator, seed: int) -> tuple[Spec, float, tuple[float, float]]:
    n = int(rng.integers(1, 6))
    centres = np.cumsum(rng.uniform(0.8, 2.5, n))
    centres -= centres.mean()
    members = _cylinder_members(rng, n, centres)
    P = _loguniform(rng, 1e-5, 1.0)
    pad = 0.3
    spec = ("union", {"members": members}) if n > 1 else members[0]
    return spec, P, (centres[0] - pad, centres[-1] + pad)


def _punch(rng: np.random.Generator, seed: int) -> tuple[Spec, float, tuple[float, float]]:
    b = float(rng.uniform(0.2, 1.0))
    shape = str(rng.choice(["sharp", "circular", "parabolic"]))
    rho = 0.0 if shape == "sharp" else float(b * rng.uniform(0.05, 0.5))
    punch = {"left": -b, "right": b, "corner_radius": rho, "lift": float(rng.uniform(0, 0.01)),
             "corner_shape": "circular" if shape == "sharp" else shape}
    n_cyl = int(rng.integers(0, 3))
    sides = rng.choice([-1.0, 1.0], n_cyl)
    centres = sides * (b + rho + rng.uniform(0.3, 1.5, n_cyl))
    members = [("flat_punch", punch), *_cylinder_members(rng, n_cyl, centres)]
    # circular corners end a quarter circle out: keep the contact well inside the arcs
    top = 0.3 * rho if shape == "circular" else 1.0
    P = _loguniform(rng, 1e-5, top)
    spec = ("union", {"members": members}) if n_cyl else ("flat_punch", punch)
    return spec, P, (-0.8 * b, 0.8 * b)


def _wedge(rng: np.random.Generator, seed: int) -> tuple[Spec, float, tuple[float, float]]:
    left, right = (float(v) for v in rng.uniform(0.05, 0.35, 2))
    apex = float(rng.uniform(-0.2, 0.2))
    slope = 0.5 * (np.tan(left) + np.tan(right))
    P = slope * _loguniform(rng, 1e-3, 1.0)
    width = A * P / slope  # contact width ~ A P / (pi slope) up to a log factor
    spec = ("wedge", {"angle_left": left, "angle_right": right, "apex": apex})
    return spec, P, (apex - width, apex + width)


def _double_wedge(rng: np.random.Generator, seed: int
                  ) -> tuple[Spec, float, tuple[float, float]]:
    c = float(rng.uniform(0.3, 1.5))
    inner, outer = (float(v) for v in rng.uniform(0.05, 0.35, 2))
    slope = 0.5 * (np.tan(inner) + np.tan(outer))
    P = slope * c * _loguniform(rng, 1e-3, 1.0)
    spec = ("double_wedge", {"c": c, "phi_inner": inner, "phi_outer": outer})
    return spec, P, (-c, c)


def table(seed: int) -> tuple[list[float], list[float]]:
    """The ``(x, h)`` table of the tabulated case of ``seed``: a parabola of radius R plus two
    waves, sampled at TABLE_POINTS points on [-2, 2] and shifted to ``min h = 0``."""
    rng = np.random.default_rng([seed, 7])
    R = _loguniform(rng, 0.5, 3.0)
    x = np.linspace(-2.0, 2.0, TABLE_POINTS)
    h = x**2 / (2 * R)
    for _ in range(2):
        k = rng.uniform(1.0, 4.0)
        h += rng.uniform(0.0, 0.15) / (R * k**2) * np.cos(k * x + rng.uniform(0, 2 * np.pi))
    return x.tolist(), (h - h.min()).tolist()


def _tabulated(rng: np.random.Generator, seed: int) -> tuple[Spec, float, tuple[float, float]]:
    x, h = table(seed)
    curvature = float(np.max(np.abs(np.diff(h, 2)))) / (x[1] - x[0]) ** 2
    # contact half-width sqrt(2 A P R / pi) with R >= 1 / curvature: below ~0.5 of the table
    P = _loguniform(rng, 1e-5, 0.3 * curvature)
    spec = ("tabulated", {"x": x, "h": h})
    xm = x[int(np.argmin(h))]
    return spec, P, (xm - 0.3, xm + 0.3)


def _biquadratic(rng: np.random.Generator, seed: int) -> tuple[Spec, float, tuple[float, float]]:
    c = float(rng.uniform(0.3, 1.0))
    R = _loguniform(rng, 0.5, 3.0)
    P = _loguniform(rng, 1e-5, 1.0)
    return ("biquadratic", {"c": c, "R": R}), P, (-c, c)


_FAMILY_MAKERS = {"cylinders": _cylinders, "punch": _punch, "wedge": _wedge,
                  "double_wedge": _double_wedge, "tabulated": _tabulated,
                  "biquadratic": _biquadratic}
