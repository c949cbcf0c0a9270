"""``verify`` of results in the exchange format: our own FE exported (CSV and VTK) must give the
metrics of ``run_case``; the CLI's outputs, report and exit codes."""

from __future__ import annotations

import json
import math

import pytest

from compare import load_case
from compare.cli import main
from compare.external import write_result
from compare.stress import STRESS_METRICS
from compare.testing import assert_agrees
from compare.verify import verify


def exported(name: str, contact_case, tmp_path_factory):
    """run_case of a library case (the session's run, shared with test_compare_agreement: read
    only here) and its history exported in the exchange format."""
    res = contact_case(name)
    folder = tmp_path_factory.mktemp("export") / name
    write_result(res.fem, folder, case=name)
    return res, folder


@pytest.fixture(scope="module")
def cattaneo(contact_case, tmp_path_factory):
    return exported("cattaneo", contact_case, tmp_path_factory)


@pytest.fixture(scope="module")
def applied_moment(contact_case, tmp_path_factory):
    return exported("applied_moment", contact_case, tmp_path_factory)


@pytest.mark.parametrize("name", ["cattaneo", "applied_moment"])
def test_round_trip_gives_the_metrics_of_run_case(name, request):
    res, folder = request.getfixturevalue(name)
    got = verify(name, folder, samples="case")
    assert got.metrics.keys() == res.metrics.keys()
    for k, v in res.metrics.items():
        if k in STRESS_METRICS:  # the exchange format has interface data only
            assert math.isnan(got.metrics[k]), k
            continue
        assert got.metrics[k] == pytest.approx(v, rel=1e-12, abs=1e-300, nan_ok=True), k
    for c_got, c_res in zip(got.checks, res.checks, strict=True):
        stress = c_res.metric in STRESS_METRICS
        assert c_got.status == ("n/a" if stress else c_res.status), c_res.name
    measured = {k for k in STRESS_METRICS if not math.isnan(res.metrics[k])}
    assert measured <= set(got.unavailable) <= set(STRESS_METRICS)
    assert "multicontact fem" in got.source


def test_every_step_sampled_and_assert_agrees(cattaneo):
    res, folder = cattaneo
    got = verify(load_case("cattaneo"), folder)
    n_steps = len(res.fem.stage(2)) + len(res.fem.stage(3))
    assert len(got.samples) == n_steps > len(res.samples)
    assert_agrees(got)
    assert got.metrics["edge_error_max"] == res.metrics["edge_error_max"]


def _negate(path, columns, out) -> None:
    """Copy a CSV file with the given data columns negated (and its header item Q: a step file
    repeats its manifest row's loads)."""
    lines = [f"# Q = {-float(ln.split('=')[1])!r}" if ln.startswith("# Q = ") else ln
             for ln in path.read_text().splitlines()]
    n_head = next(i for i, ln in enumerate(lines) if not ln.startswith("#"))
    rows = [r.split(",") for r in lines[n_head + 1:]]
    for r in rows:
        for c in columns:
            r[c] = repr(-float(r[c]))
    out.write_text("\n".join(lines[:n_head + 1] + [",".join(r) for r in rows]) + "\n")


def test_conventions_from_the_command_line(cattaneo, tmp_path, capsys):
    """p, q and Q negated in the files are undone by --set; the metrics do not change."""
    res, folder = cattaneo
    flipped = tmp_path / "flipped"
    flipped.mkdir()
    for f in folder.glob("*.csv"):  # the step tables (not the export's own manifest)
        _negate(f, [3] if f.name == "steps.csv" else [2, 3], flipped / f.name)
    assert main(["verify", "cattaneo", str(flipped), "--samples", "case", "--json",
                 "--set", "pressure_sign=-1", "--set", "shear_sign=-1"]) == 0
    got = json.loads(capsys.readouterr().out)["metrics"]
    for k, v in res.metrics.items():
        if k in STRESS_METRICS:  # interface data only
            assert got[k] is None, k
            continue
        assert got[k] is None if math.isnan(v) else got[k] == pytest.approx(v, rel=1e-12), k
    assert main(["verify", "cattaneo", str(flipped), "--set", "pressure_sign=-1"]) == 2
    err = capsys.readouterr().err  # Q falls through stage 2: out of order, or the other sign
    assert "out of load order" in err and "shear_sign = -1" in err


def test_cli_verify_json_report_and_exit_codes(cattaneo, tmp_path, capsys):
    _, folder = cattaneo
    out = tmp_path / "rep"
    assert main(["verify", "cattaneo", str(folder / "steps.csv"), "-o", str(out), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["passed"] and d["source"].startswith("multicontact fem")
    html = (out / "index.html").read_text()
    assert "Verified result: multicontact fem" in html and (out / "summary.json").is_file()
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "steps.csv").write_text("stage,P,Q,file\n1,100,0,missing.csv\n")
    assert main(["verify", "cattaneo", str(bad), "-o", str(tmp_path / "rep2")]) == 2
    err = capsys.readouterr().err.strip()
    assert "line 2" in err and "not found" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "rep2").exists() and not list(tmp_path.glob(".rep2*"))


def test_cli_fem_export_csv_and_vtk_verify_alike(tmp_path, capsys):
    csv, vtk = tmp_path / "csv", tmp_path / "vtk"
    assert main(["fem", "hertz", "--level", "0", "-o", str(vtk), "--export", str(csv)]) == 0
    capsys.readouterr()
    a = verify("hertz", csv).metrics
    b = verify("hertz", vtk / "history.pvd").metrics
    for k, v in a.items():
        assert b[k] == pytest.approx(v, rel=1e-12, abs=1e-300, nan_ok=True), k
    assert a["edge_error_max"] < 0.02 and math.isnan(a["jc_error"])
