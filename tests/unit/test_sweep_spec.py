"""Sweep files: expansion into cases, keys, validation errors, result store (no solver runs)."""

from __future__ import annotations

import json
import tomllib

import pytest

from compare import sweep as sw
from compare.sweep.cli import EXIT_BAD_INPUT
from compare.sweep.store import RESULTS_FILE, ResultStore
from compare.sweep.tasks import jsonable

BASE = """
[base]
profile = { type = "double_wedge", c = 1.0, phi_inner = 0.11, phi_outer = 0.07 }
material = { A = 1.0 }
load = { P = 0.05, mu = 0.3 }
"""


def spec(body: str) -> dict:
    return tomllib.loads(body + "\n" + BASE)


def test_product_and_zip_expand_in_written_order():
    s = sw.sweep_from_dict(spec("""
task = "analytic"
[zip.angles]
"profile.phi_inner" = [0.11, 0.18, 0.07]
"profile.phi_outer" = [0.07, 0.18, 0.11]
[axes]
"load.P" = [0.01, 0.02]
"fem.level" = { linspace = [0, 2, 3] }
"""))
    assert len(s.cases) == 3 * 2 * 3
    first = s.cases[0].params
    assert first == {"profile.phi_inner": 0.11, "profile.phi_outer": 0.07, "load.P": 0.01,
                     "fem.level": 0}
    pairs = {(c.params["profile.phi_inner"], c.params["profile.phi_outer"]) for c in s.cases}
    assert pairs == {(0.11, 0.07), (0.18, 0.18), (0.07, 0.11)}
    assert s.cases[-1].params["fem.level"] == 2
    assert s.cases[-1].case["profile"]["phi_inner"] == 0.07
    assert len({c.key for c in s.cases}) == len(s.cases)


def test_geomspace_and_set():
    s = sw.sweep_from_dict(spec("""
[parts.a]
task = "overlap"
set = { "load.mu" = 0.5 }
axes = { "load.P" = { geomspace = [1e-3, 1e-1, 3] } }
"""))
    assert [c.params["load.P"] for c in s.cases] == pytest.approx([1e-3, 1e-2, 1e-1])
    assert all(c.case["load"]["mu"] == 0.5 for c in s.cases)


def test_keys_depend_on_content_not_position():
    short = sw.sweep_from_dict(spec('task = "analytic"\naxes = { "load.P" = [0.01, 0.02] }'))
    longer = sw.sweep_from_dict(spec('task = "analytic"\naxes = { "load.P" = [0.005, 0.01, '
                                     '0.02] }'))
    other = sw.sweep_from_dict(spec('task = "overlap"\naxes = { "load.P" = [0.01, 0.02] }'))
    assert {c.key for c in short.cases} < {c.key for c in longer.cases}
    assert not {c.key for c in short.cases} & {c.key for c in other.cases}


def test_union_member_parameter():
    doc = tomllib.loads("""
task = "analytic"
axes = { "profile.members.1.lift" = [0.0005, 0.001] }
[base]
material = { A = 1.0 }
load = { P = 0.05, mu = 0.3 }
[base.profile]
type = "union"
members = [{ type = "cylinder", R = 1.0, center = -1.0 },
           { type = "cylinder", R = 1.0, center = 1.0 }]
""")
    s = sw.sweep_from_dict(doc)
    assert [c.case["profile"]["members"][1]["lift"] for c in s.cases] == [0.0005, 0.001]
    assert s.base["profile"]["members"][1].get("lift") is None  # base not mutated


@pytest.mark.parametrize("body, words", [
    ('task = "analytic"\naxes = { "load.P" = [] }', ["'load.P'", "empty"]),
    ('task = "analytic"\naxes = { "load.PP" = [1.0] }', ["unknown parameter", "'load.PP'",
                                                          "load.P"]),
    ('task = "analytic"\naxes = { "profile.R" = [1.0] }', ["unknown parameter", "profile.R"]),
    ('task = "analytic"\n[zip.g]\n"load.P" = [0.01, 0.02]\n"load.mu" = [0.3]',
     ["different lengths", "'load.P': 2", "'load.mu': 1"]),
    ('task = "analytic"\n[zip.g]', ["zip group", "empty"]),
    ('task = "magic"\naxes = { "load.P" = [0.01] }', ["task='magic'", "analytic"]),
    ('task = "analytic"\naxes = { "load.P" = { linspace = [0, 1] } }', ["linspace", "[start"]),
    ('task = "analytic"\naxes = { "load.P" = [0.01], "load.mu" = [0.3] }\n[zip.g]\n'
     '"load.P" = [0.02]', ["more than one axis"]),
    ('task = "analytic"\naxes = { "load.P" = [-1.0] }', ["case 0", "load.P=-1.0"]),
    ('task = "analytic"\nfoo = 1', ["unknown key 'foo'"]),
])
def test_bad_sweep_files_give_one_clear_error(body, words):
    with pytest.raises(sw.SweepError) as exc:
        sw.sweep_from_dict(spec(body), src="bad.toml")
    msg = str(exc.value)
    assert msg.startswith("bad.toml: ")
    assert "\n" not in msg
    for w in words:
        assert w in msg


def test_bad_base():
    with pytest.raises(sw.SweepError, match="neither a library case"):
        sw.sweep_from_dict({"base": "no_such_case", "task": "analytic"})
    with pytest.raises(sw.SweepError, match="missing 'base'"):
        sw.sweep_from_dict({"task": "analytic"})


@pytest.mark.parametrize("body", ['axes = { "load.P" = [] }', 'axes = { "nope" = [1] }',
                                  '[zip.g]\n"load.P" = [0.01, 0.02]\n"load.mu" = [0.3]'])
def test_cli_exit_2_and_one_line(tmp_path, capsys, body):
    f = tmp_path / "s.toml"
    f.write_text('task = "analytic"\n' + body + "\n" + BASE)
    assert sw.main(["sweep", str(f), "-o", str(tmp_path / "out")]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert err.startswith("multicontact: error: s.toml: ")
    assert len(err.splitlines()) == 1
    assert not (tmp_path / "out" / RESULTS_FILE).exists()


def test_library_study_expands():
    s = sw.load_sweep("fig5_sweep")
    per_pair = {}
    for c in s.cases:
        pair = (c.params["profile.phi_inner"], c.params["profile.phi_outer"])
        per_pair.setdefault((c.part, pair), []).append(c.params["load.P"])
    pairs = {(0.11, 0.07), (0.18, 0.18), (0.07, 0.11)}
    assert {p for _, p in per_pair} == pairs
    assert all(len(v) >= 30 for (part, _), v in per_pair.items() if part == "analytic")
    assert all(len(v) >= 5 for (part, _), v in per_pair.items() if part == "fe")


def rec(key: str, status: str, tag: int) -> dict:
    return {"key": key, "status": status, "tag": tag}


def test_store_dedup_and_torn_tail(tmp_path):
    with ResultStore(tmp_path) as st:
        st.append(rec("a", "failed", 1))
        st.append(rec("a", "ok", 2))
        st.append(rec("a", "failed", 3))  # a late failed duplicate must not hide the ok one
        st.append(rec("b", "ok", 4))
        st.append(rec("b", "ok", 5))
    with open(tmp_path / RESULTS_FILE, "a") as fh:
        fh.write('{"key": "c", "status": "ok"')  # writer killed mid-line
    got = sw.read_records(tmp_path)
    assert {k: r["tag"] for k, r in got.items()} == {"a": 2, "b": 5}
    with ResultStore(tmp_path) as st:  # reopening cuts the torn line
        st.append(rec("c", "ok", 6))
    lines = (tmp_path / RESULTS_FILE).read_text().splitlines()
    assert len(lines) == 6 and all(json.loads(x) for x in lines)
    assert sw.read_records(tmp_path)["c"]["tag"] == 6


def test_store_is_exclusive(tmp_path):
    with ResultStore(tmp_path), pytest.raises(sw.SweepError, match="in use"):
        with ResultStore(tmp_path):
            pass


def test_records_are_plain_json():
    import numpy as np

    out = jsonable({"a": np.float64(1.5), "b": float("nan"), "c": (np.int64(2), np.inf),
                        "d": np.bool_(True)})
    assert out == {"a": 1.5, "b": None, "c": [2, None], "d": True}
    json.dumps(out, allow_nan=False)


def test_report_of_a_directory_that_is_not_a_sweep_says_what_to_run(tmp_path):
    from compare.errors import SweepError
    from compare.sweep.report import write_sweep_report

    hint = r"not a sweep directory: no sweep\.json \(run `multicontact sweep STUDY -o DIR` first\)"
    with pytest.raises(SweepError, match=hint):
        write_sweep_report(tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_report_plot_legend_outside_the_panels_and_labelled_axes(monkeypatch):
    """Issue 26: a legend inside a panel covered the curves; now one legend under the
    panels, the y axis named, and the case tables headed by the sweep file's labels."""
    from compare.sweep import report as rp

    monkeypatch.setattr(rp, "_png", lambda fig: fig)
    man = {"parts": [{"name": "an", "task": "overlap", "parameters": ["load.P"]},
                     {"name": "fe", "task": "fem_overlap", "parameters": ["load.P"]}]}
    rows = [{"part": p, "status": "ok", "load.P": P, "extent": P ** 0.5, "index": i}
            for p in ("an", "fe") for i, P in enumerate((0.01, 0.04, 0.09))]
    labels = {"load.P": "P A / c", "extent": "actual extent"}
    spec = {"x": "load.P", "y": ["extent"], "panels": [], "series": []}
    fig = rp.plot_figure(spec, rows, man, labels, "plot1").png
    assert not any(ax.get_legend() for ax in fig.axes) and len(fig.legends) == 1
    assert fig.axes[0].get_xlabel() == "P A / c" and fig.axes[0].get_ylabel() == "actual extent"
    head, body = rp.part_table(man["parts"][0], rows, labels)
    assert head[:2] == ["index", "P A / c"] and len(body) == 3
