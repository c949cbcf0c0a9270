"""The CalculiX driver without ccx: the deck writer, the .frd reader and the command line.

tests/data/calculix_tiny holds a deck written by ``calculix.deck`` for Cattaneo on a tiny grid
(:data:`TINY`, two increments per stage) and the ``.frd`` ccx 2.20 wrote for it (40 kB).
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from compare.cases import load_case
from compare.errors import CaseError
from compare.external import calculix as ccx
from compare.external.driver import LANDING_RTOL, DriverError, check_landed
from compare.verify import verify

DATA = Path(__file__).resolve().parents[1] / "data" / "calculix_tiny"
#: The grid of the stored tiny run (n_span, growth, size_factor) and its largest increment.
TINY = {"n_span": 4, "growth": 3.0, "size_factor": 2.0}
TINY_INCREMENT = 1.0


@pytest.fixture(scope="module")
def cattaneo():
    case = load_case("cattaneo")
    return case, ccx.grid(case, 0, **TINY)


def _keywords(text: str) -> list[str]:
    return [ln.split(",")[0] for ln in text.splitlines() if ln.startswith("*")]


def test_deck_has_the_three_stages(cattaneo):
    case, g = cattaneo
    text = ccx.deck(case, g)
    kw = _keywords(text)
    for k in ("*NODE", "*ELEMENT", "*SURFACE", "*MATERIAL", "*ELASTIC", "*SOLID SECTION",
              "*EQUATION", "*SURFACE INTERACTION", "*SURFACE BEHAVIOR", "*FRICTION",
              "*CONTACT PAIR", "*BOUNDARY", "*STEP", "*STATIC", "*CLOAD", "*NODE FILE",
              "*CONTACT FILE", "*END STEP", "*CHANGE FRICTION"):
        assert k in kw, k
    assert kw.count("*STEP") == 3 and kw.count("*END STEP") == 3
    assert "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR" in text
    assert "*CONTACT PAIR, INTERACTION=SI, TYPE=NODE TO SURFACE\nSLAVE, MASTER" in text
    assert text.count("TYPE=CPE4") == 2
    # friction ~0 in stage 1, the case's mu from stage 2 on
    mu1, mu2 = re.findall(r"\*FRICTION\n([^,]+),", text)
    assert float(mu1) == ccx.MU_STAGE1 and float(mu2) == case.mu
    assert text.index("*CHANGE FRICTION") > text.index("*END STEP")
    loads = re.findall(r"REF, (\d), (\S+)", text)
    assert ("2", ccx._num(-case.P)) in loads and ("1", ccx._num(case.Q0)) in loads
    assert ("1", ccx._num(-case.Q0)) in loads
    # the top is one rigid body: every other top node tied to the reference node, u and v
    assert text.count("\n2\n") == 2 * (len(g.top) - 1)


def test_deck_fields_fit_ccx(cattaneo):
    """ccx reads at most 20 characters per field (a longer one stops it with a *NODE error)."""
    case, g = cattaneo
    lines = ccx.deck(case, g).splitlines()
    heading = lines.index("*HEADING") + 1
    for k, ln in enumerate(lines):
        if not ln.startswith("*") and k != heading:
            assert all(len(f.strip()) <= 20 for f in ln.split(",")), ln


def test_grid_geometry(cattaneo):
    case, g = cattaneo
    x, y = g.xy.T
    body1 = np.unique(g.elements[:g.n_elem1])
    # body 1's bottom is the profile, body 2's top is flat, both on the same x
    bottom1 = np.sort(g.slave_nodes)
    assert np.allclose(y[bottom1], case.profile.h0(x[bottom1]), rtol=1e-12, atol=1e-15)
    assert np.all(y[body1] >= 0) and np.all(y[np.setdiff1d(np.arange(len(x)), body1)] <= 0)
    # counter-clockwise quads with positive area
    a, b, c = (g.xy[g.elements[:, k]] for k in range(3))
    area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    assert np.all(area > 0)
    # the fine size resolves the span with n_span elements at level 0, half of it at level 1
    assert ccx.grid(case, 1, **TINY).h == pytest.approx(g.h / 2)
    assert g.h == pytest.approx((g.span[1] - g.span[0]) * (1 + 2 * ccx.MARGIN) / TINY["n_span"])


def test_stored_deck_is_the_writers(cattaneo):
    """The stored .frd belongs to this grid: same elements, same nodes."""
    case, g = cattaneo
    stored = (DATA / "cattaneo_tiny.inp").read_text()
    assert _keywords(stored) == _keywords(ccx.deck(case, g, TINY_INCREMENT))
    assert np.allclose(_nodes(stored), g.xy, rtol=1e-9, atol=1e-12)
    assert _elements(stored) == _elements(ccx.deck(case, g))


def _elements(text: str) -> str:
    return text.split("*ELEMENT")[1] + text.split("*ELEMENT")[2].split("*NSET")[0]


def _nodes(text: str) -> np.ndarray:
    rows = text.split("*NODE\n")[1].split("\n*")[0].splitlines()
    return np.array([[float(v) for v in r.split(",")[1:]] for r in rows])


def test_frd_reader_on_stored_run(cattaneo):
    case, g = cattaneo
    frd = ccx.read_frd(DATA / "cattaneo_tiny.frd")
    assert len(frd.elements) == len(g.elements)
    assert {s.name for s in frd.sets} == {"FORC", "CONTACT"}
    contact = next(s for s in frd.sets if s.name == "CONTACT")
    assert contact.components[3:5] == ("CPRESS", "CSHEAR1")
    steps = ccx.increments(frd, g, case.mu)
    assert [s.stage for s in steps] == [1, 1, 2, 2, 3, 3]
    assert [s.time for s in steps] == pytest.approx([0.5, 1, 1.5, 2, 2.5, 3])
    # load control: the reactions are the applied loads (force residual of ccx ~1e-6)
    want = [(50, 0), (100, 0), (100, 9), (100, 18), (100, 0), (100, -18)]
    for s, (P, Q) in zip(steps, want, strict=True):
        assert (s.P, s.Q) == pytest.approx((P, Q), abs=1e-4)
    # the tractions integrate to the reactions (the contact output is read and mapped right)
    ccx.check_balance(steps, g.xy[g.slave_nodes, 0], case.mu, case.P)
    end = steps[3]
    assert np.all(end.p[end.status > 0] > 0) and np.all(end.p[end.status == 0] == 0)
    # three contact nodes on this grid, all sticking (|q| <= 0.81 mu p)
    assert list(end.status) == [0, 0, 1, 1, 1, 0, 0]
    assert np.all(np.abs(end.q) < case.mu * end.p * (1 - ccx.SLIP_RTOL) + (end.status == 0))


def test_stored_run_converts_and_verifies(cattaneo, tmp_path):
    case, g = cattaneo
    manifest = ccx.convert(case, g, DATA / "cattaneo_tiny.frd", tmp_path, 1.0, "CalculiX 2.20")
    res = verify(case, manifest)
    assert res.fem.n_dofs == 2 * len(g.xy) and "CalculiX" in res.source
    assert len(res.fem.stage(2)) == 2 and len(res.fem.stage(3)) == 2
    assert not res.passed  # 4 elements across the contact: nothing is resolved


def test_frd_reader_names_the_bad_line(tmp_path):
    bad = tmp_path / "bad.frd"
    text = (DATA / "cattaneo_tiny.frd").read_text().splitlines()
    k = next(i for i, ln in enumerate(text) if ln.startswith(" -1") and "CONTACT" not in ln
             and i > 200)
    text[k] = " -1      xxxx"
    bad.write_text("\n".join(text) + "\n")
    with pytest.raises(DriverError, match=f"line {k + 1}"):
        ccx.read_frd(bad)
    with pytest.raises(DriverError, match="cannot read"):
        ccx.read_frd(tmp_path / "missing.frd")


def test_landing_check():
    case = load_case("cattaneo")
    ok = [(1, case.P * (1 - 0.5 * LANDING_RTOL), 0.0), (2, case.P, case.Q0 * 1.005)]
    check_landed("X", case, ok)
    with pytest.raises(DriverError, match=r"P = 107\.5 .* misses"):
        check_landed("X", case, [(1, 107.5, 0.0), (2, 107.5, case.Q0)])
    with pytest.raises(DriverError, match=r"Q0 = 13\.29 .* misses"):
        check_landed("X", case, [(1, case.P, 0.0), (2, case.P, 13.29)])


def test_moment_cases_are_refused():
    case = load_case("applied_moment")
    with pytest.raises(CaseError, match="vertical indentation only"):
        ccx.deck(case, ccx.grid(replace(case, M=None), 0, **TINY))


def test_deck_only_cli(tmp_path, capsys):
    assert ccx.main(["hertz", str(tmp_path / "o"), "--deck-only"]) == 0
    deck = tmp_path / "o" / "ccx" / "hertz.inp"
    assert deck.is_file() and str(deck) in capsys.readouterr().out
    assert _keywords(deck.read_text()).count("*STEP") == 1  # Q0 = 0: stage 1 only


def test_cli_errors_are_one_line(tmp_path, capsys, monkeypatch):
    assert ccx.main(["no_such_case", str(tmp_path / "o"), "--deck-only"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "error:" in err and "Traceback" not in err
    monkeypatch.setenv("PATH", str(tmp_path))  # no ccx
    assert ccx.main(["hertz", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "apt-get install calculix-ccx" in err and err.count("\n") == 1


def test_sharp_punch_contact_only_where_the_gap_is_finite():
    """Beyond a sharp corner h0 = inf: those faces are no contact candidates and body 1 keeps
    the corner's height there (no nan in the deck)."""
    case = load_case("sharp_punch")
    g = ccx.grid(case, 0, **TINY)
    x = g.xy[g.slave_nodes, 0]
    assert np.all(np.isfinite(case.profile.h0(x))) and np.all(np.isfinite(g.xy))
    assert "nan" not in ccx.deck(case, g).lower()


def test_on_the_cone_but_not_moving_is_stick(cattaneo):
    """Right after the stage-3 reversal ccx leaves nodes on the friction cone that no longer
    move: they stick (status from the cone alone gave an 18 % stick-edge error)."""
    case, g = cattaneo
    frd = ccx.read_frd(DATA / "cattaneo_tiny.frd")
    contact = [s for s in frd.sets if s.name == "CONTACT"][-1]
    forc = [s for s in frd.sets if s.name == "FORC"][-1]
    comps = contact.components
    ip, iq, isl = (comps.index(k) for k in ("CPRESS", "CSHEAR1", "CSLIP1"))
    on_cone = {n: [*v] for n, v in contact.values.items()}
    for v in on_cone.values():
        v[iq] = case.mu * v[ip]  # every contact node on the cone

    def block(step, inc, slip):
        vals = {n: [*v[:isl], v[isl] + slip, *v[isl + 1:]] for n, v in on_cone.items()}
        return (ccx.FrdSet(step, inc, float(inc), "FORC", forc.components, forc.values),
                ccx.FrdSet(step, inc, float(inc), "CONTACT", comps, vals))

    moved = 10 * ccx.SLIP_MOVE_ATOL * g.h
    fake = ccx.Frd(frd.elements, (*block(2, 1, 0.0), *block(2, 2, moved), *block(3, 3, moved)))
    first, slipping, reversed_ = ccx.increments(fake, g, case.mu)
    closed = first.status > 0
    assert closed.any()
    assert np.all(slipping.status[closed] == 2)   # on the cone and moving
    assert np.all(reversed_.status[closed] == 1)  # on the cone, not moving
