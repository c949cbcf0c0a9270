"""``Case.from_profile``: a case from an analytic profile object, and its dict / TOML round trip."""

from __future__ import annotations

import re
import tomllib

import numpy as np
import pytest

from analytic import profiles
from compare import Case, CaseError
from compare.cases import case_from_dict, load_case, read_case

A_STEEL = 4 * (1 - 0.3**2) / 210e3


def two_cylinders():
    return profiles.union(profiles.cylinder(R=10.0, center=-3.0),
                          profiles.cylinder(R=5.0, center=3.0, lift=2e-4))


def test_from_profile_matches_the_toml_case() -> None:
    lib = load_case("hertz")
    prof = profiles.cylinder(**{k: v for k, v in lib.profile_spec.items() if k != "type"})
    made = Case.from_profile(prof, lib.P, E=lib.E, nu=lib.nu, mu=lib.mu, Q0=lib.Q0,
                             name=lib.name, description=lib.description,
                             **{k: v for k, v in vars(lib.fem).items()})
    assert made.summary() | {"source": ""} == lib.summary() | {"source": ""}
    x = np.linspace(-3, 3, 7)
    assert np.array_equal(made.profile.h0(x), lib.profile.h0(x))


def test_compliance_or_modulus() -> None:
    by_a = Case.from_profile(two_cylinders(), 100.0, A=A_STEEL, mu=0.5, Q0=30.0)
    by_e = Case.from_profile(two_cylinders(), 100.0, E=210e3, nu=0.3, mu=0.5, Q0=30.0)
    assert by_a.A == pytest.approx(A_STEEL, rel=1e-14) and by_a.nu == 0.3
    assert by_e.E == 210e3 and by_a.E == pytest.approx(210e3, rel=1e-14)
    assert by_e.stage2 == pytest.approx((15.0, 22.5, 30.0))


@pytest.mark.parametrize("prof", [
    two_cylinders(),
    profiles.flat_punch(-1.0, 1.0, corner_radius=0.2, corner_shape="parabolic"),
    profiles.flat_punch(-1.0, 1.0),
    profiles.wedge(0.1, 0.2, apex=0.5),
    profiles.double_wedge(1.0, 0.11, 0.07),
    profiles.biquadratic(1.0, 10.0),
    profiles.tabulated(np.linspace(-1, 1, 9), np.linspace(-1, 1, 9) ** 2, kinks=[0.0]),
], ids=lambda p: p.name)
def test_dict_and_toml_round_trip(prof, tmp_path) -> None:
    case = Case.from_profile(prof, 1.0, A=A_STEEL, mu=0.4, Q0=0.2, M=None, level=0,
                             order=2, samples={"stage2": [0.25, 1.0], "stage3": [-1.0]},
                             tolerances={"edge": 0.05}, name="mine", description='a "q"')
    again = case_from_dict(case.to_dict(), src="round trip")
    assert again.to_dict() == case.to_dict()
    assert again.stage2 == pytest.approx(case.stage2, rel=1e-15)
    text = case.to_toml()
    assert tomllib.loads(text)["profile"] == case.profile_spec
    f = tmp_path / "mine.toml"
    f.write_text(text)
    read = read_case(f)
    assert read.to_dict() == case.to_dict()
    x = np.linspace(-2, 2, 41)
    assert np.array_equal(read.profile.h0(x), prof.h0(x))


def test_applied_moment_round_trips() -> None:
    case = Case.from_profile(two_cylinders(), 100.0, A=A_STEEL, mu=0.5, M=-20.0)
    assert case.M == -20.0 and "M" in case.to_dict()["load"]
    assert case_from_dict(case.to_dict()).M == -20.0


@pytest.mark.parametrize("kwargs, words", [
    ({"P": -1.0}, "load.P=-1.0 is not allowed"),
    ({"Q0": 99.0}, "load.Q0=99.0 is not allowed"),
    ({"nu": 0.6, "A": None, "E": 1.0}, "material.nu=0.6 is not allowed"),
    ({"E": 1.0}, "give either material.A or (material.E, material.nu)"),
    ({"levle": 2}, "unknown key 'fem.levle'"),
    ({"level": 9}, "fem.level=9 is not allowed"),
])
def test_bad_arguments_name_the_value(kwargs, words) -> None:
    args = {"P": 100.0, "A": A_STEEL, "mu": 0.5, "Q0": 10.0} | kwargs
    args = {k: v for k, v in args.items() if v is not None}
    P = args.pop("P")
    with pytest.raises(CaseError, match=re.escape(words)):
        Case.from_profile(two_cylinders(), P, **args)


def test_profiles_that_do_not_describe_themselves() -> None:
    with pytest.raises(CaseError, match="not described by its params"):
        Case.from_profile(profiles.cylinder(R=10.0).with_lift(0.1), 1.0, A=A_STEEL, mu=0.5)
    nested = profiles.union(two_cylinders(), profiles.cylinder(R=1.0, center=9.0))
    with pytest.raises(CaseError, match="union's members must be simple"):
        Case.from_profile(nested, 1.0, A=A_STEEL, mu=0.5)
    hand = profiles.Profile(profiles.cylinder(R=1.0).pieces, (), (), 1.0)
    with pytest.raises(CaseError, match="'profile' cannot be described"):
        Case.from_profile(hand, 1.0, A=A_STEEL, mu=0.5)
