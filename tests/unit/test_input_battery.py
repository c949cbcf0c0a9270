"""Hostile-input battery: every public constructor and solver argument gets NaN, +-inf, None,
wrong types, empty and degenerate values.

Each call must raise exactly the promised exception (``analytic.InputError``,
``fem.InputError``, ``compare.CaseError``) -- never a raw Python error or a returned result --
and its message must name the parameter as ``name=``.  A second part feeds valid numbers in
odd containers (numpy scalars, 0-d and 1-element arrays) and requires finite results.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pytest

import analytic
import fem
from analytic import profiles
from compare.cases import Case, FemSettings
from compare.errors import CaseError

NAN, INF = float("nan"), float("inf")
#: Bad values of any numeric scalar parameter (None is valid for optional ones: added below).
SCALAR_BAD = [NAN, INF, -INF, "1.0", [1.0, 2.0], 1j, True, object(), np.array([[1.0, 2.0]])]
#: Bad values of a 1-D numeric sequence parameter.
VECTOR_BAD = ["abc", [[1.0, 2.0], [3.0, 4.0]], ["a", "b"], [1.0, NAN], [INF, 1.0], {}]
#: Bad FE windows: one (xmin, xmax) or one pair per zone is allowed (so no generic 2-D vector).
WINDOW_BAD = ["abc", ["a", "b"], [1.0, NAN], [INF, 1.0], {}, [1.0, -1.0], [0.0], [0.0, 1.0, 2.0],
              [[0.0, 1.0], [2.0, 1.5]], [[0.0, 1.0, 2.0]], [[[0.0, 1.0]]]]
#: Bad values of a parameter that takes an object (profile, solution, settings).
OBJECT_BAD = [None, 1.0, "cylinder", [1.0]]

TAB_X = [0.0, 1.0, 2.0, 3.0, 4.0]
TAB_H = [2.0, 0.5, 0.0, 0.5, 2.0]


def _cyl() -> profiles.Profile:
    return profiles.cylinder(1.0)


_NORMAL: dict = {}


def _hertz() -> analytic.NormalSolution:
    if "n" not in _NORMAL:
        _NORMAL["n"] = analytic.solve_normal(_cyl(), 0.5, 1.0)
    return _NORMAL["n"]


def _case(**kw) -> Case:
    base = dict(name="battery", profile=_cyl(), profile_spec={"type": "cylinder", "R": 1.0},
                P=1.0, E=1.0, nu=0.3, mu=0.5, Q0=0.2)
    return Case(**{**base, **kw})


def _fem(**kw):
    base = dict(h0=lambda x: x**2 / 2, P0=1.0, Q0=0.1, mu=0.3, E=1.0, nu=0.3,
                window=(-1.0, 1.0))
    return fem.solve_history(**{**base, **kw})


# (function id, call(**kwargs), exception, {parameter: (kind, degenerate values)}); kind is
# "scalar", "optional" (None allowed), "vector", "optvector" (None allowed), "object" or "none"
# (degenerate values only).
TARGETS: list[tuple[str, Callable, type, dict]] = [
    ("cylinder", lambda **k: profiles.cylinder(**{"R": 1.0, **k}), analytic.InputError,
     {"R": ("scalar", [0.0, -1.0]), "center": ("scalar", [1e200]), "lift": ("scalar", [])}),
    ("flat_punch", lambda **k: profiles.flat_punch(**{"left": -1.0, "right": 1.0, **k}),
     analytic.InputError,
     {"left": ("scalar", [1.0, 2.0]), "right": ("scalar", [-1.0, -2.0]),
      "corner_radius": ("scalar", [-0.1]), "lift": ("scalar", []),
      "corner_shape": ("object", ["elliptic", ""])}),
    ("wedge", lambda **k: profiles.wedge(**{"angle_left": 0.1, "angle_right": 0.2, **k}),
     analytic.InputError,
     {"angle_left": ("scalar", [0.0, -0.1, math.pi / 2]), "angle_right": ("scalar", [2.0]),
      "apex": ("scalar", []), "lift": ("scalar", [])}),
    ("biquadratic", lambda **k: profiles.biquadratic(**{"c": 1.0, "R": 1.0, **k}),
     analytic.InputError, {"c": ("scalar", [0.0, -1.0, 1e-200]), "R": ("scalar", [0.0])}),
    ("double_wedge",
     lambda **k: profiles.double_wedge(**{"c": 1.0, "phi_inner": 0.1, "phi_outer": 0.2, **k}),
     analytic.InputError,
     {"c": ("scalar", [0.0]), "phi_inner": ("scalar", [0.0, 1.6]),
      "phi_outer": ("scalar", [-0.2])}),
    ("tabulated", lambda **k: profiles.tabulated(**{"x": TAB_X, "h": TAB_H, **k}),
     analytic.InputError,
     {"x": ("vector", [[], [0.0, 1.0], [4.0, 3.0, 2.0, 1.0, 0.0], [0, 1, 1, 2, 3]]),
      "h": ("vector", [[], [1.0, 0.0, 1.0], [1.0, -0.5, 0.0, 1.0, 2.0]]),
      "kinks": ("vector", [[0.5, 0.6, 0.7]])}),
    ("union", lambda profiles: analytic.profiles.union(*profiles), analytic.InputError,
     {"profiles": ("none", [(), (1.0,), (_cyl(), None), (_cyl(), "cylinder"), [[_cyl()]]])}),
    ("solve_normal", lambda **k: analytic.solve_normal(**{"profile": _cyl(), "P": 0.5,
                                                          "A": 1.0, **k}),
     analytic.InputError,
     {"profile": ("object", []), "P": ("scalar", [0.0, -1.0]), "A": ("scalar", [0.0, -1.0]),
      "M": ("optional", [])}),
    ("solve_normal_fixed_rotation",
     lambda **k: analytic.solve_normal_fixed_rotation(**{"profile": _cyl(), "P": 0.5, "A": 1.0,
                                                         "theta": 0.0, **k}),
     analytic.InputError,
     {"profile": ("object", []), "P": ("scalar", [0.0]), "A": ("scalar", [-1.0]),
      "theta": ("scalar", [])}),
    ("load_curve", lambda **k: analytic.load_curve(**{"profile": _cyl(), "loads": [0.1, 0.2],
                                                      "A": 1.0, **k}),
     analytic.InputError,
     {"profile": ("object", []), "loads": ("vector", [[], [0.0, 1.0], [-1.0]]),
      "A": ("scalar", [0.0]), "M": ("optional", []), "theta": ("optional", [])}),
    ("solve_stick", lambda **k: analytic.solve_stick(**{"normal": _hertz(), "mu": 0.5,
                                                        "Q": 0.1, **k}),
     analytic.InputError,
     {"normal": ("object", []), "mu": ("scalar", [0.0, -1.0]), "Q": ("scalar", [0.3, -0.3]),
      "Q0": ("optional", [0.3]), "allow_full_slip": ("none", [None, 1, "yes"])}),
    ("cycle", lambda **k: analytic.cycle(**{"normal": _hertz(), "mu": 0.5, "Q0": 0.1, **k}),
     analytic.InputError,
     {"normal": ("object", []), "mu": ("scalar", [0.0]), "Q0": ("scalar", [0.0, 0.25, -0.1]),
      "n": ("scalar", [6, 7.5, 0, -8])}),
    ("overlapped", lambda **k: analytic.overlapped(**{"profile": _cyl(), "P": 0.5, "A": 1.0,
                                                      **k}),
     analytic.InputError,
     {"profile": ("object", []), "P": ("scalar", [0.0]), "A": ("scalar", [0.0]),
      "theta": ("scalar", [])}),
    ("fig5_data", lambda **k: analytic.fig5_data(**{"phi1": 0.1, "phi2": 0.2, "loads": [0.01],
                                                    **k}),
     analytic.InputError,
     {"phi1": ("scalar", [0.0, 2.0]), "phi2": ("scalar", [-1.0]), "c": ("scalar", [0.0]),
      "A": ("scalar", [0.0]), "loads": ("optvector", [[], [-0.1]])}),
    ("fem.solve_history", _fem, fem.InputError,
     {"P0": ("scalar", [0.0, -1.0]), "Q0": ("scalar", [-0.1, 0.4]), "mu": ("scalar", [0.0]),
      "E": ("scalar", [0.0, -1.0]), "nu": ("scalar", [0.5, -1.0]), "M": ("optional", []),
      "h0": ("object", []), "mesh": ("none", [1.0, [1.0]]),
      "contact": ("none", [1.0, "penalty"]), "increments": ("none", [3, "x"]),
      "kinks": ("vector", []), "window": ("none", WINDOW_BAD),
      "vtk_dir": ("none", [1.0]), "backend": ("object", ["umfpack"])}),
    ("Case", _case, CaseError,
     {"P": ("scalar", [0.0]), "E": ("scalar", [0.0]), "nu": ("scalar", [0.5]),
      "mu": ("scalar", [0.0]), "Q0": ("scalar", [-0.1, 0.6]), "M": ("optional", []),
      "profile": ("object", []), "name": ("none", ["", None, 3]),
      "stage2": ("vector", []), "stage3": ("vector", []), "fem": ("object", []),
      "tolerances": ("none", [None, {"edge_rel": -1.0}, {"edge_rel": NAN}])}),
]

# settings dataclasses: a bad field reaches the same validation through solve_history / Case
SETTINGS: list[tuple[str, Callable, type, dict]] = [
    ("MeshSpec", lambda **k: _fem(mesh=fem.MeshSpec(**k)), fem.InputError,
     {"level": [7, -4, 1.5, NAN], "order": [3, 0, None], "W": [0.0, INF], "H": [-1.0],
      "n_window": [1, NAN], "growth": [1.0, 3.0, NAN], "margin": [-0.1, NAN],
      "size_factor": [1.0, INF], "layout": ["ring", None, 1], "incompatible": ["yes", None, 1]}),
    ("ContactSettings", lambda **k: _fem(contact=fem.ContactSettings(**k)), fem.InputError,
     {"k_n": [0.0, NAN], "k_t": [-1.0], "penalty_factor": [0.0, INF, None],
      "augmented": [None, "yes"], "pen_tol": [0.0, NAN], "max_uzawa": [0, 2.5],
      "newton_tol": [0.0, 1.0, NAN], "max_newton": [0, None], "max_cutbacks": [-1, INF]}),
    ("LoadPath", lambda **k: _fem(increments=fem.LoadPath(**k)), fem.InputError,
     {"n_normal": [0, 1.5, None], "n_tangential": [0, NAN], "stage2": [[NAN], []],
      "stage3": [[INF], "x"]}),
    ("FemSettings", lambda **k: _case(fem=FemSettings(**k)), CaseError,
     {"level": [7, 1.5, None], "order": [3], "penalty_factor": [0.0, NAN],
      "augmented": [1, None], "n_normal": [0], "n_tangential": [NAN], "size_factor": [1.0],
      "window_margin": [2.0, INF], "growth": [1.0, None], "mesh_file": [None, 3],
      "layout": ["ring", None], "edge_nodes": [1, None], "incompatible": [1, "yes", None]}),
]


def _generic(kind: str) -> list:
    return {"scalar": [None, *SCALAR_BAD], "optional": SCALAR_BAD,
            "vector": [None, *VECTOR_BAD], "optvector": VECTOR_BAD, "object": OBJECT_BAD,
            "none": []}[kind]


def _cases() -> list:
    out = []
    for fid, call, exc, params in TARGETS:
        for name, (kind, degenerate) in params.items():
            for i, bad in enumerate([*_generic(kind), *degenerate]):
                out.append(pytest.param(call, exc, name, name, bad, id=f"{fid}-{name}-{i}"))
    for fid, call, exc, fields in SETTINGS:
        for name, bads in fields.items():
            named = f"fem.{name}" if fid == "FemSettings" else name
            for i, bad in enumerate(bads):
                out.append(pytest.param(call, exc, name, named, bad, id=f"{fid}-{name}-{i}"))
    return out


BATTERY = _cases()


@pytest.mark.parametrize(("call", "exc", "param", "named", "bad"), BATTERY)
def test_bad_argument_raises_the_promised_error_naming_it(call, exc, param, named, bad) -> None:
    with pytest.raises(Exception) as info:
        call(**{param: bad})
    assert type(info.value) is exc, f"{type(info.value).__name__}: {info.value}"
    assert re.search(rf"\b{re.escape(named)}[=\[.]", str(info.value)), str(info.value)
    assert "need" in str(info.value)


def test_battery_size() -> None:
    """The battery covers every listed public function with at least 8 bad values each."""
    assert len(BATTERY) >= 400
    ids = {p.id.split("-")[0] for p in BATTERY}
    assert len(ids) == len(TARGETS) + len(SETTINGS)


ODD_NUMBERS = [np.float64(0.5), np.float32(0.5), np.array(0.5), np.array([0.5]), [0.5], 1,
               np.int64(1)]


@pytest.mark.parametrize("P", ODD_NUMBERS, ids=[f"{type(v).__name__}-{i}"
                                                for i, v in enumerate(ODD_NUMBERS)])
def test_numpy_scalars_and_one_element_arrays_are_accepted(P) -> None:
    sol = analytic.solve_normal(profiles.cylinder(np.float32(1.0)), P, np.array([1.0]),
                                M=np.float64(0.0))
    assert isinstance(sol.P, float) and sol.P == float(np.asarray(P).ravel()[0])
    values = [v for z in sol.zones for v in z] + list(sol.zone_loads) + [sol.M, sol.theta]
    assert np.all(np.isfinite(values))
    stick = analytic.solve_stick(sol, np.array(0.5), np.float64(0.1 * sol.P))
    assert np.all(np.isfinite(stick.shear(np.linspace(*sol.zones[0], 5))))


def test_case_converts_numpy_fields() -> None:
    case = _case(P=np.float64(2.0), mu=np.array([0.5]), stage2=np.array([0.1, 0.2]))
    assert type(case.P) is float and type(case.mu) is float
    assert case.stage2 == (0.1, 0.2)
    assert replace(case, Q0=np.float32(0.5)).Q0 == 0.5
