"""Verification report: files, links, JSON, and rendering in headless Chromium."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from compare.errors import CaseError
from compare.report import write_report

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


class Links(HTMLParser):
    def __init__(self):
        super().__init__()
        self.refs, self.ids = [], set()

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.add(a["id"])
        for key in ("href", "src"):
            if a.get(key):
                self.refs.append(a[key])


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("rep") / "report"
    write_report(["hertz", "cattaneo"], out, convergence_cases={"hertz": (-1, 0)}, fig5=False)
    return out


def test_files_and_summary(report):
    for name in ("index.html", "report.md", "summary.json"):
        assert (report / name).is_file()
    s = json.loads((report / "summary.json").read_text())
    assert s["passed"] is True
    assert [c["case"]["name"] for c in s["cases"]] == ["hertz", "cattaneo"]
    assert s["cases"][1]["metrics"]["stick_edge_error_max"] < 0.06
    assert s["convergence"][0]["kind"] == "h"
    assert not list(report.parent.glob(".report.tmp-*"))


def test_html_self_contained_and_links_resolve(report):
    text = (report / "index.html").read_text()
    p = Links()
    p.feed(text)
    embedded = [r for r in p.refs if r.startswith("data:image/png;base64,")]
    assert len(embedded) >= 7  # pressure x2, shear, cycle, contact region, convergence
    # (+ pyvista pictures)
    for ref in p.refs:
        if ref.startswith("data:"):
            continue
        if ref.startswith("#"):
            assert ref[1:] in p.ids, ref
        else:
            assert (report / ref).is_file(), f"broken link {ref}"
    assert "vtk/cattaneo/history.pvd" in p.refs
    for ref in re.findall(r"\]\(([^)]+)\)", (report / "report.md").read_text()):
        assert (report / ref).is_file(), f"broken markdown link {ref}"


def test_case_header_backend_dofs_elements_verdict_time(report):
    text = (report / "index.html").read_text()
    s = json.loads((report / "summary.json").read_text())
    heads = re.findall(r'<p class="head">(.*?)</p>', text)
    assert len(heads) == len(s["cases"])
    for head, case in zip(heads, s["cases"], strict=True):
        fe = case["fem"]
        assert f"backend <b>{fe['backend']}</b>" in head and f"{fe['n_dofs']} DOFs" in head
        assert "Q4 (linear)" in head and "run time" in head
        assert case["verdict"].startswith("agrees; worst: ") and case["verdict"] in head
    assert ('class="loud"' in text) == any(c["fem"]["backend"] != "cholmod" for c in s["cases"])
    md = (report / "report.md").read_text()
    assert all(f"Backend **{c['fem']['backend']}**" in md for c in s["cases"])


def test_pvd_series_files_exist(report):
    pvd = (report / "vtk" / "cattaneo" / "history.pvd").read_text()
    files = re.findall(r'file="([^"]+)"', pvd)
    assert files and all((report / "vtk" / "cattaneo" / f).is_file() for f in files)


def test_pyvista_picture_or_reason(report):
    s = json.loads((report / "summary.json").read_text())
    for c in s["cases"]:
        assert c["render"] or c["render_note"]
        if c["render"]:
            assert (report / c["render"]).stat().st_size > 10_000


@pytest.mark.skipif(CHROMIUM is None, reason="headless Chromium not installed (Debian package "
                    "'chromium'); the report rendering check needs it")
def test_renders_in_headless_chromium(report, tmp_path):
    shot = tmp_path / "shot.png"
    subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu",
                    "--disable-background-networking", "--disable-component-update",
                    "--disable-sync", "--no-first-run", f"--user-data-dir={tmp_path / 'profile'}",
                    f"--screenshot={shot}", "--window-size=1200,2000",
                    (report / "index.html").as_uri()], capture_output=True, timeout=120,
                   check=False)
    assert shot.is_file(), "chromium wrote no screenshot"
    import matplotlib.image as mpimg

    rgb = mpimg.imread(shot)[..., :3]
    assert rgb.std() > 0.05, "blank screenshot"
    non_white = np.mean(rgb.min(axis=2) < 0.9)
    assert non_white > 0.05, f"only {non_white:.1%} of the page is not white"
    saturation = rgb.max(axis=2) - rgb.min(axis=2)
    coloured = np.mean(saturation > 0.3)  # plot lines/points, pyvista colours, pass marks
    assert coloured > 0.005, f"figures not visible: {coloured:.2%} coloured pixels"


#: Figures of a case with tangential load (the stick-slip map and the shear need Q0 > 0).
FIGURES = ("pressure (stage 1 end), per zone", "shear (stages 2 and 3), per zone",
           "contact region: sigma_xx and interface status", "surface sxx (body 2)",
           "subsurface max shear: analytic | FE",
           "stick-slip map over the cycle and Ruiz parameter")
NORMAL_ONLY = {"shear (stages 2 and 3), per zone",
               "stick-slip map over the cycle and Ruiz parameter"}


def _sections(text: str) -> dict[str, str]:
    """Case id -> its part of the page (up to the next h2)."""
    parts = re.split(r'(?=<h2 id=")', text)
    return {re.match(r'<h2 id="([^"]+)"', p).group(1): p for p in parts if p.startswith("<h2")}


def test_every_figure_of_every_case_is_on_the_page(report):
    """Each case has every figure (h3 title, then an embedded PNG), the mesh picture or the
    reason, the same figures as files linked from report.md; the convergence section says its
    verdict in words and leaves out what a normal-only case does not have."""
    text = (report / "index.html").read_text()
    md = (report / "report.md").read_text()
    s = json.loads((report / "summary.json").read_text())
    parts = _sections(text)
    for case in s["cases"]:
        name = case["case"]["name"]
        sec = parts[name]
        want = [t for t in FIGURES if case["case"]["Q0"] > 0 or t not in NORMAL_ONLY]
        titles = re.findall(r"<h3>(.*?)</h3>", sec)
        assert titles[:len(want)] == want, titles
        for t in want:
            after = sec.split(f"<h3>{t}</h3>", 1)[1]
            assert after.startswith('<img alt="'), t
            assert after.split("src=", 1)[1].startswith('"data:image/png;base64,'), t
            assert f"![{t}](figures/{name}_" in md
        assert "von Mises stress around each contact zone" in sec
        assert ('pyvista picture' in sec) == bool(case["render"])
    conv = parts["conv-hertz"]
    assert "True" not in conv and "False" not in conv
    assert "converges" in conv and "Richardson" in conv
    assert ">stick_edge_error_max<" not in conv and ">shear_l2_error<" not in conv
    assert ">pressure_l2_error<" in conv
    assert "all 2 cases agree" in text


@pytest.mark.slow
def test_default_suite_report(tmp_path):
    """`make run`'s report: every case agrees, and it stays light (issue 26: at most 20 MB;
    it was 143 MB with a VTK series of every sampled step)."""
    s = write_report(out_dir=tmp_path / "report")
    assert s["passed"] and s["fig5"]
    assert (tmp_path / "report" / "study_fig5.html").is_file()
    size = sum(f.stat().st_size for f in (tmp_path / "report").rglob("*") if f.is_file())
    assert size <= 20e6, f"report of {size / 1e6:.1f} MB"


def test_failure_midway_leaves_no_partial_report(tmp_path, monkeypatch):
    import compare.report as rep

    def boom(case, *a, **k):
        raise RuntimeError("solver exploded")

    monkeypatch.setattr(rep, "run_case", boom)
    out = tmp_path / "report"
    with pytest.raises(RuntimeError, match="exploded"):
        write_report(["hertz"], out, convergence_cases={}, fig5=False)
    assert list(tmp_path.iterdir()) == []


def test_foreign_files_refused_before_anything_is_computed(tmp_path, monkeypatch):
    """A folder holding a file the report did not write is refused (CaseError) before any case
    runs, and the file is kept (tests/validation/test_output_dirs.py: --force and the CLI)."""
    import compare.report as rep

    def never(*a, **k):
        raise AssertionError("a case ran")

    monkeypatch.setattr(rep, "run_case", never)
    out = tmp_path / "report"
    out.mkdir()
    (out / "stale.txt").write_text("old")
    with pytest.raises(CaseError, match="did not write"):
        write_report(["hertz"], out, convergence_cases={}, fig5=False)
    assert [p.name for p in out.iterdir()] == ["stale.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]
