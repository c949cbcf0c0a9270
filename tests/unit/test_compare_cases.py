"""Case files: schema validation (one clear message per error) and the shipped library."""

from __future__ import annotations

import pytest

from compare.cases import case_from_dict, library_dir, list_cases, load_case, read_case
from compare.errors import CaseError


def doc(**over):
    d = {"profile": {"type": "cylinder", "R": 10.0},
         "material": {"E": 200000.0, "nu": 0.3},
         "load": {"P": 100.0, "mu": 0.3, "Q0_ratio": 0.5}}
    for key, val in over.items():
        section, _, name = key.partition("__")
        if name:
            d.setdefault(section, {})[name] = val
        else:
            d[section] = val
    return d


def test_valid_case_builds():
    c = case_from_dict(doc())
    assert c.Q0 == pytest.approx(0.5 * 0.3 * 100.0)
    assert c.A == pytest.approx(4 * (1 - 0.09) / 200000.0)
    assert c.stage2 == pytest.approx((7.5, 11.25, 15.0))


@pytest.mark.parametrize("bad, words", [
    (doc(profile__Rx=1.0), ["unknown key 'profile.Rx'", "R, center, lift, type"]),
    (doc(extra={"a": 1}), ["unknown key 'extra'"]),
    (doc(load__P="heavy"), ["'load.P' must be a number", "str"]),
    (doc(fem__level=1.5), ["'fem.level' must be an integer"]),
    (doc(material={"E": 1.0}), ["missing required key 'material.nu'"]),
    (doc(material__nu=0.5), ["material.nu=0.5 is not allowed", "-1 < nu < 0.5"]),
    (doc(load={"P": 100.0, "mu": 0.3, "Q0": 31.0}), ["load.Q0=31.0 is not allowed",
                                                     "Q0 <= mu*P = 30"]),
    (doc(profile={"type": "sphere"}), ["profile.type='sphere' is not allowed", "cylinder"]),
    (doc(samples__stage2=[0.5, 0.2]), ["samples.stage2", "increasing"]),
    (doc(tolerances__edge=-1.0), ["tolerances.edge=-1.0 is not allowed"]),
    (doc(tolerances__edgy=0.1), ["unknown key 'tolerances.edgy'"]),
])
def test_bad_input_names_key_and_allowed(bad, words):
    with pytest.raises(CaseError) as exc:
        case_from_dict(bad, src="t.toml")
    msg = str(exc.value)
    assert "\n" not in msg
    for w in words:
        assert w in msg


def test_missing_table():
    d = doc()
    del d["load"]
    with pytest.raises(CaseError, match=r"missing required table \[load\]"):
        case_from_dict(d)


def test_compliance_only_material():
    c = case_from_dict(doc(material={"A": 2e-5}))
    assert c.A == pytest.approx(2e-5) and c.nu == 0.3


def test_union_profile_and_toml_file(tmp_path):
    f = tmp_path / "two.toml"
    f.write_text('[profile]\ntype = "union"\n[[profile.members]]\ntype = "cylinder"\nR = 10.0\n'
                 'center = -1.0\n[[profile.members]]\ntype = "cylinder"\nR = 10.0\ncenter = 1.0\n'
                 'lift = 0.0005\n[material]\nE = 2e5\nnu = 0.3\n[load]\nP = 100.0\nmu = 0.3\n')
    c = read_case(f)
    assert c.name == "two" and c.Q0 == 0.0 and c.stage2 == ()
    assert c.profile.h0([-1.0])[0] == pytest.approx(0.0)
    assert c.profile.h0([1.0])[0] == pytest.approx(0.0005)


def test_invalid_toml_syntax(tmp_path):
    f = tmp_path / "broken.toml"
    f.write_text("[profile\n")
    with pytest.raises(CaseError, match="not valid TOML"):
        read_case(f)


def test_library_complete_and_valid():
    names = set(list_cases())
    assert {"hertz", "cattaneo", "rounded_punch", "sharp_punch", "biquadratic_separate",
            "biquadratic_merged", "double_wedge_a", "double_wedge_b", "double_wedge_c",
            "two_cylinders_unequal", "three_cylinders", "punch_and_cylinder",
            "applied_moment"} <= names
    for n in names:
        c = load_case(n)
        assert c.description and 0 <= c.Q0 <= c.mu * c.P


def test_unknown_case_name():
    with pytest.raises(CaseError, match="unknown case 'nope'"):
        load_case("nope")


def test_a_folder_is_not_a_case_file_nor_a_mesh_file(tmp_path):
    (tmp_path / "c.toml").mkdir()
    with pytest.raises(CaseError, match=r"case file .*c.toml' is not a regular file \(a folder"):
        load_case(tmp_path / "c.toml")
    f = tmp_path / "m.toml"
    f.write_text((library_dir() / "hertz.toml").read_text()
                 + f'\n[fem]\nmesh_file = "{tmp_path}"\n')
    with pytest.raises(CaseError, match=r"fem.mesh_file=.*: not a regular file \(a folder\?\)"):
        read_case(f)
