"""The exchange format reader: conventions, strict validation (one clear error per bad file)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from compare import CaseError, load_case
from compare.external import read_result
from compare.verify import verify

CASE = load_case("hertz")
X = np.linspace(-0.2, 0.2, 161)
#: The synthetic result is the analytic solution sampled at nodes: its metrics are those of
#: sampling alone (the edge between two nodes, located by the sqrt extrapolation).
SAMPLED_EDGE_RTOL = 2e-3


def hertz_rows(P: float) -> tuple[np.ndarray, np.ndarray]:
    import analytic

    ns = analytic.solve_normal(CASE.profile, P, CASE.A)
    p = ns.pressure(X)
    return p, np.where(p > 0, 1, 0)


def write_step(path, p, status, header="", x=X, q=None, extra=None):
    q = np.zeros_like(p) if q is None else q
    cols = {"x": x, "p": p, "q": q, "status": status} | (extra or {})
    lines = [header + ",".join(cols)]
    lines += [",".join(repr(float(v)) if k != "status" else str(int(v)) for k, v in
                       zip(cols, vals, strict=True)) for vals in zip(*cols.values(), strict=True)]
    path.write_text("\n".join(lines) + "\n")


def write_result(folder, loads=(50.0, 100.0), head="", convert=lambda p, x: (p, x),
                 load_factor=1.0):
    folder.mkdir(exist_ok=True)
    rows = []
    for k, P in enumerate(loads):
        p, st = hertz_rows(P)
        p_file, x_file = convert(p, X)
        write_step(folder / f"s{k}.csv", p_file, st, x=x_file)
        rows.append(f"1,{P * load_factor!r},0.0,0.0,s{k}.csv")
    (folder / "steps.csv").write_text(head + "stage,P,Q,M,file\n" + "\n".join(rows) + "\n")
    return folder / "steps.csv"


def test_synthetic_analytic_result_verifies(tmp_path):
    res = verify(CASE, write_result(tmp_path / "r"))
    assert res.passed
    assert res.metrics["edge_error_max"] < SAMPLED_EDGE_RTOL
    assert res.metrics["pressure_l2_error"] < 1e-12
    assert math.isnan(res.metrics["stick_edge_error_max"])
    assert set(res.unavailable) == {"stress_l2_error", "stress_shape_error"}  # no body fields


@pytest.mark.parametrize("head, convert, load_factor", [
    ("# pressure_sign = -1\n", lambda p, x: (-p, x), 1.0),
    ("# x_origin = 3.5\n", lambda p, x: (p, x + 3.5), 1.0),
    # file in mm and kPa with a case in m and MPa: P [MN/m] = 1e-3 * 1e-3 * P_file [kN/mm]
    ("# length_scale = 1e-3\n# stress_scale = 1e-3\n", lambda p, x: (p * 1e3, x * 1e3), 1e6),
])
def test_conventions_give_the_same_metrics(tmp_path, head, convert, load_factor):
    ref = verify(CASE, write_result(tmp_path / "ref")).metrics
    got = verify(CASE, write_result(tmp_path / "conv", head=head, convert=convert,
                                    load_factor=load_factor)).metrics
    for k, v in ref.items():
        assert got[k] == pytest.approx(v, rel=1e-9, abs=1e-12, nan_ok=True), k


def test_force_values_divided_by_w(tmp_path):
    ref = verify(CASE, write_result(tmp_path / "ref")).metrics
    folder = tmp_path / "force"
    write_result(folder, head="# values = force\n")
    for k, P in enumerate((50.0, 100.0)):
        p, st = hertz_rows(P)
        w = np.full(X.size, X[1] - X[0])
        write_step(folder / f"s{k}.csv", p * w, st, extra={"w": w})
    got = verify(CASE, folder).metrics
    assert got["pressure_l2_error"] == pytest.approx(ref["pressure_l2_error"], abs=1e-12)
    assert got["edge_error_max"] == pytest.approx(ref["edge_error_max"], rel=1e-9)


def test_step_files_without_manifest(tmp_path):
    folder = tmp_path / "files"
    folder.mkdir()
    for k, P in enumerate((50.0, 100.0)):
        p, st = hertz_rows(P)
        write_step(folder / f"step{k}.csv", p, st,
                   header=f"# code = mycode\n# stage = 1\n# P = {P}\n# Q = 0\n# M = 0\n")
    res = verify(CASE, folder)
    assert res.passed and "mycode" in res.source


def _bad(tmp_path, mutate) -> str:
    f = write_result(tmp_path / "bad")
    mutate(f, f.parent / "s1.csv")
    with pytest.raises(CaseError) as exc:
        verify(CASE, f)
    return str(exc.value)


def _edit(path, old, new, count=1):
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, count))


def _line(path, no, new):
    lines = path.read_text().splitlines()
    lines[no - 1] = new
    path.write_text("\n".join(lines) + "\n")


def _columns(path, **change) -> None:
    """Rewrite data columns of a step file: name -> function of the dict of column arrays."""
    lines = path.read_text().splitlines()
    n_head = next(i for i, ln in enumerate(lines) if not ln.startswith("#"))
    names = lines[n_head].split(",")
    cols = {n: np.array([float(r.split(",")[i]) for r in lines[n_head + 1:]])
            for i, n in enumerate(names)}
    cols |= {k: f(cols) for k, f in change.items()}
    rows = [",".join(str(int(v)) if k == "status" else repr(float(v)) for k, v in
                     zip(cols, vals, strict=True)) for vals in zip(*cols.values(), strict=True)]
    path.write_text("\n".join(lines[:n_head] + [",".join(cols)] + rows) + "\n")


@pytest.mark.parametrize("mutate, words", [
    (lambda m, s: _edit(s, "x,p,q,status", "x,p,status"), ["s1.csv", "missing column 'q'"]),
    (lambda m, s: _line(s, 5, "0.1,nan,0.0,1"), ["s1.csv, line 5", "'p'", "finite"]),
    (lambda m, s: _line(s, 5, "-0.1999,1.0,0.0,1"), ["s1.csv", "x must increase strictly"]),
    (lambda m, s: _line(s, 5, "-0.1975,1.0,0.0,4"), ["s1.csv, line 5", "status '4'"]),
    (lambda m, s: _line(s, 5, "-0.1975,1.0"), ["s1.csv, line 5", "2 values, expected 4"]),
    (lambda m, s: (_edit(m, "1,100.0,", "1,140.0,"), _columns(s, p=lambda c: 1.4 * c["p"])),
     ["steps.csv, line 3", "P = 140", "does not match the case"]),
    (lambda m, s: (_edit(m, "1,100.0,0.0", "1,100.0,25.0"),
                   _columns(s, q=lambda c: 0.25 * c["p"])),
     ["steps.csv, line 3", "stage-1 step", "Q = 25"]),
    (lambda m, s: _edit(m, "1,50.0,", "4,50.0,"), ["steps.csv, line 2", "stage '4'"]),
    (lambda m, s: _edit(m, "s1.csv", "nope.csv"), ["steps.csv, line 3", "'nope.csv' not found"]),
    (lambda m, s: m.write_text("# colour = red\n" + m.read_text()),
     ["unknown header key 'colour'", "allowed"]),
    (lambda m, s: m.write_text("# pressure_sign = 2\n" + m.read_text()),
     ["pressure_sign = 2 is not allowed", "1, -1"]),
    (lambda m, s: _edit(s, "x,p,q,status", "x,p,q,p"), ["s1.csv, line 1", "'p' given twice"]),
    (lambda m, s: _edit(s, "x,p,q,status", "x;p;q;status"), ["s1.csv", "separated by ';'",
                                                            "commas"]),
    (lambda m, s: _edit(m, "stage,P,Q,M,file", "stage,P,Q,m,file"), ["unknown column 'm'"]),
    # a step file's own items count in a manifest layout: a misspelt key, loads that disagree
    (lambda m, s: s.write_text("# pressure_sing = -1\n" + s.read_text()),
     ["s1.csv, line 1", "unknown header key 'pressure_sing'"]),
    (lambda m, s: s.write_text("# P = 50.0\n" + s.read_text()),
     ["s1.csv, line 1", "'P = 50.0' disagrees with the manifest's P = 100.0"]),
    (lambda m, s: s.write_text("# theta = 1e-3\n" + s.read_text()),
     ["manifest row gives no theta"]),
    (lambda m, s: _edit(m, "1,50.0,0.0,0.0,s0.csv\n1,100.0,0.0,0.0,s1.csv",
                        "1,100.0,0.0,0.0,s1.csv\n1,50.0,0.0,0.0,s0.csv"),
     ["steps.csv, line 3", "out of load order", "P = 50 after P = 100 in stage 1"]),
    (lambda m, s: _edit(m, "1,100.0,0.0,0.0,s1.csv", "1,100.0,0.0,0.5,s1.csv"),
     ["steps.csv, line 3", "sum x p w = ", "M = 0.5", "P max|x| in contact"]),
    # a net shear of 0.5 % of P at Q = 0 is 1.7 % of mu P (mu = 0.3): beyond the q check
    (lambda m, s: _columns(s, q=lambda c: c["q"] + 0.5 / 0.4),
     ["sum q w = 0.5", "Q = 0", "1% of mu P = 0.3", "net tangential traction"]),
    (lambda m, s: _columns(s, gap=lambda c: np.where(c["p"] > 0, np.inf, 0.0)),
     ["s1.csv", "gap = inf", "carries p = "]),
])
def test_bad_files_one_clear_error(tmp_path, mutate, words):
    msg = _bad(tmp_path, mutate)
    assert all(w in msg for w in words), msg
    assert "\n" not in msg


def test_missing_result_path():
    with pytest.raises(CaseError, match="no such file"):
        read_result("/nonexistent/steps.csv")


def test_assert_agrees_fails_on_an_asked_metric_the_result_lacks(tmp_path):
    """Stage-1 steps without M: moment_error is not available; asking for it fails."""
    from compare.testing import DisagreementError, assert_agrees

    f = write_result(tmp_path / "noM")
    f.write_text(f.read_text().replace("stage,P,Q,M,file", "stage,P,Q,file")
                 .replace(",0.0,0.0,s", ",0.0,s"))
    res = verify(CASE, f)
    assert "moment_error" in res.unavailable
    assert_agrees(res)
    with pytest.raises(DisagreementError, match="moment_error: the result gives no M"):
        assert_agrees(res, moment_atol=0.01)


def write_series(folder, loads=(50.0, 100.0), fields=("stage", "P", "Q", "M"), p_edit=None):
    """A .pvd series of interface .vtu lines (fem.vtk's writer) from the synthetic result."""
    import meshio

    from fem.vtk import atomic_write_mesh

    folder.mkdir(exist_ok=True)
    entries = []
    for k, P in enumerate(loads):
        p, st = hertz_rows(P)
        p = p_edit(p) if p_edit and k == 1 else p
        mesh = meshio.Mesh(np.c_[X, 0 * X, 0 * X], [("line", np.c_[np.arange(X.size - 1),
                                                                    np.arange(1, X.size)])],
                           point_data={"p": p, "q": 0 * p, "status": st.astype(np.int32)})
        values = {"stage": 1, "P": P, "Q": 0.0, "M": 0.0}
        atomic_write_mesh(mesh, folder / f"i{k}.vtu", {f: values[f] for f in fields})
        entries.append(f'<DataSet timestep="{k}" part="0" file="i{k}.vtu"/>')
    pvd = folder / "series.pvd"
    pvd.write_text('<?xml version="1.0"?><VTKFile type="Collection"><Collection>'
                   + "".join(entries) + "</Collection></VTKFile>")
    return pvd


def test_vtk_series_verifies_like_csv(tmp_path):
    a = verify(CASE, write_result(tmp_path / "csv")).metrics
    b = verify(CASE, write_series(tmp_path / "vtk")).metrics
    for k, v in a.items():
        assert b[k] == pytest.approx(v, rel=1e-12, abs=1e-300, nan_ok=True), k


@pytest.mark.parametrize("kwargs, words", [
    ({"fields": ("P", "Q")}, ["series.pvd, step 0 (i0.vtu)", "missing field data 'stage'"]),
    ({"p_edit": lambda p: np.where(p > 0, np.nan, p)}, ["step 1 (i1.vtu)", "'p' is nan"]),
])
def test_bad_vtk_series_one_clear_error(tmp_path, kwargs, words):
    with pytest.raises(CaseError) as exc:
        verify(CASE, write_series(tmp_path / "bad", **kwargs))
    assert all(w in str(exc.value) for w in words), str(exc.value)


def test_vtk_series_missing_file_and_no_interface(tmp_path):
    pvd = write_series(tmp_path / "s")
    (tmp_path / "s" / "i1.vtu").unlink()
    with pytest.raises(CaseError, match="step 1.*'i1.vtu' not found"):
        read_result(pvd)
    pvd.write_text("<VTKFile><Collection></Collection></VTKFile>")
    with pytest.raises(CaseError, match="DataSet"):
        read_result(pvd)



def test_unreadable_vtu_in_series_one_clear_error(tmp_path, capsys):
    """A corrupt interface file: one CaseError naming the step and the file (meshio alone
    would print and end the process)."""
    pvd = write_series(tmp_path / "s")
    (tmp_path / "s" / "i1.vtu").write_text("<VTKFile>cut off")
    with pytest.raises(CaseError, match=r"step 1 \(i1.vtu\): interface file .*i1.vtu' cannot be "
                       r"read by meshio .*allowed: a VTK XML unstructured grid"):
        read_result(pvd)
    assert capsys.readouterr() == ("", "")

def test_applied_moment_must_match(tmp_path):
    """An applied-moment case: the result's M at the end of stage 1 is checked against it."""
    from dataclasses import replace

    case = replace(CASE, M=5.0)
    with pytest.raises(CaseError, match=r"steps.csv, line 3.*M = 0 at the end of stage 1.*\(5"):
        verify(case, write_result(tmp_path / "m"))


def test_stage_1_only_result_against_a_case_with_q0(tmp_path):
    with pytest.raises(CaseError, match="no stage-2 steps but the case has Q0 = 18"):
        verify(load_case("cattaneo"), write_result(tmp_path / "s1"))


def test_deformed_x_with_ux_gives_the_same_metrics(tmp_path):
    ref = verify(CASE, write_result(tmp_path / "ref")).metrics
    folder = tmp_path / "deformed"
    write_result(folder, head="# x = deformed\n")
    ux = 1e-4 * np.sin(7.0 * X)  # any tangential displacement that keeps x sorted
    for k, P in enumerate((50.0, 100.0)):
        p, st = hertz_rows(P)
        write_step(folder / f"s{k}.csv", p, st, x=X + ux, extra={"ux": ux})
    got = verify(CASE, folder).metrics
    for k, v in ref.items():
        assert got[k] == pytest.approx(v, rel=1e-9, abs=1e-12, nan_ok=True), k
    (folder / "s1.csv").write_text((folder / "s1.csv").read_text().replace(",ux", ",uy"))
    with pytest.raises(CaseError, match="s1.csv: missing column 'ux'"):
        verify(CASE, folder)


def test_comment_lines_with_equals_are_comments(tmp_path):
    """Only '# key = value' with a one-word key is a header item; '# solver tol = 1e-8' and
    '# run at T=20 C' are comments (a one-word unknown key stays an error: a misspelt key)."""
    f = write_result(tmp_path / "c", head="# solver tolerance = 1e-8\n# run at T=20 C\n"
                     "# code = mine\n")
    res = verify(CASE, f)
    assert res.passed and res.source.startswith("mine")


def test_cli_json_error_object_and_nothing_written(tmp_path, capsys):
    """An input error with --json: the message on stderr and a JSON error object on stdout;
    with -o nothing is written."""
    import json

    from compare.cli import main

    f = write_result(tmp_path / "sign", head="# pressure_sign = -1\n")  # p is compressive > 0
    out = tmp_path / "report"
    assert main(["verify", "hertz", str(f), "--json", "-o", str(out)]) == 2
    captured = capsys.readouterr()
    err = json.loads(captured.out)["error"]
    assert err["kind"] == "input" and err["exit_code"] == 2
    assert "sum p w = -" in err["message"] and "sign of p" in captured.err
    assert not out.exists()


def test_external_report_names_the_code_not_a_sparse_backend(tmp_path):
    from compare.verify import write_verify_report

    f = write_result(tmp_path / "r", head="# code = MyCode 2.1\n")
    res = verify(CASE, f)
    write_verify_report(res, tmp_path / "rep")
    page = (tmp_path / "rep" / "index.html").read_text()
    md = (tmp_path / "rep" / "report.md").read_text()
    assert "CHOLMOD" not in page and "CHOLMOD" not in md
    assert "Q4" not in md and "0 DOFs" not in md and "level" not in md.split("Verified")[0]
    assert "Code **MyCode 2.1**, DOFs not given, element order not given" in md
    assert "code <b>MyCode 2.1</b> &middot; DOFs not given" in page
    assert "element" in md  # the edge error in elements is on the page


def test_byte_order_mark_is_read_past(tmp_path):
    """A spreadsheet's "CSV UTF-8" starts with a byte-order mark: the same result."""
    ref = verify(CASE, write_result(tmp_path / "ref")).metrics
    f = write_result(tmp_path / "bom")
    for path in (f, f.parent / "s1.csv"):
        path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    got = verify(CASE, f).metrics
    for k, v in ref.items():
        assert got[k] == pytest.approx(v, rel=1e-12, nan_ok=True), k


def test_step_file_items_agreeing_with_the_manifest_are_accepted(tmp_path):
    f = write_result(tmp_path / "same")
    s1 = f.parent / "s1.csv"
    s1.write_text("# stage = 1\n# P = 100.0\n# Q = 0.0\n# code = mine\n" + s1.read_text())
    assert verify(CASE, f).passed


def test_vector_point_data_one_clear_error(tmp_path):
    import meshio

    pvd = write_series(tmp_path / "s")
    mesh = meshio.read(tmp_path / "s" / "i1.vtu")
    mesh.point_data["q"] = np.zeros((X.size, 3))
    mesh.write(tmp_path / "s" / "i1.vtu")
    with pytest.raises(CaseError, match=r"step 1 \(i1.vtu\): point data 'q' has 3 components"):
        verify(CASE, pvd)


def test_pvd_steps_in_timestep_order(tmp_path):
    """ParaView orders a collection by its timesteps: so does the reader; a collection whose
    timesteps put the loads out of order is refused."""
    ref = verify(CASE, write_series(tmp_path / "s")).metrics
    pvd = tmp_path / "s" / "series.pvd"
    text = pvd.read_text()
    a, b = '<DataSet timestep="0" part="0" file="i0.vtu"/>', \
        '<DataSet timestep="1" part="0" file="i1.vtu"/>'
    pvd.write_text(text.replace(a + b, b + a))  # file order reversed, timesteps kept
    got = verify(CASE, pvd).metrics
    for k, v in ref.items():
        assert got[k] == pytest.approx(v, rel=1e-12, nan_ok=True), k
    pvd.write_text(text.replace('timestep="0"', 'timestep="2"'))  # P = 50 after P = 100
    with pytest.raises(CaseError, match="out of load order"):
        verify(CASE, pvd)


def test_a_bad_setting_is_named_as_given_by_settings(tmp_path):
    f = write_result(tmp_path / "r")
    with pytest.raises(CaseError, match=r"\(--set / settings\): pressure_sign = 0 is not "
                                        "allowed"):
        verify(CASE, f, settings={"pressure_sign": "0"})


def test_infinite_gap_only_beyond_a_sharp_corner(tmp_path):
    """gap = inf on the open nodes of a smooth profile (a code's "not evaluated") would snap
    the edges to nodes with no uncertainty: refused, naming the node."""
    f = write_result(tmp_path / "r")
    _columns(f.parent / "s1.csv", gap=lambda c: np.where(c["p"] > 0, 0.0, np.inf))
    with pytest.raises(CaseError, match=r"s1.csv.*gap = inf \(contact impossible\) at node 1, "
                                        r"x = -0.2, where the case's profile can touch"):
        verify(CASE, f)
