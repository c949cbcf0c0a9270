"""``multicontact sweep`` and ``report --sweep``: a folder is a sweep's store only when its
sweep.json is a sweep manifest, and only that sweep's; bad input (scheduler, workers, part,
sweep size) is refused before anything is written; the sweep report's exit code."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest

from compare import sweep as sw
from compare.sweep.store import MANIFEST_FILE, RESULTS_FILE, ResultStore
from compare.sweep.tasks import execute, jsonable

#: A sweep of three analytic Hertz cases (about 0.1 s each, no FE run).
HERTZ = 'base = "hertz"\ntask = "analytic"\n[axes]\n"load.P" = [50, 100, 200]\n'
#: The same with a case whose analytic solution fails (an applied moment it cannot carry).
FAILING = 'base = "hertz"\ntask = "analytic"\n[axes]\n"load.M" = [0.0, 1e6]\n'


def sweep_file(folder: Path, name: str, text: str = HERTZ) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.toml"
    path.write_text(text)
    return path


def files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in folder.iterdir()}


def run_in_process(study: Path, out: Path) -> None:
    """What ``run_sweep`` writes, without its process pool: manifest and one record a case."""
    s = sw.load_sweep(study)
    out.mkdir(parents=True)
    (out / MANIFEST_FILE).write_text(json.dumps(jsonable(s.manifest()), indent=1))
    with ResultStore(out) as store:
        for c in s.cases:
            store.append(execute(c.as_task(s)) | {"run": "test"})


def sweep_cli(study: Path, out: Path, *extra: str) -> int:
    return sw.main(["sweep", str(study), "-o", str(out), "--workers", "1", "--no-progress",
                    *extra])


@pytest.mark.parametrize("force", [[], ["--force"]])
def test_foreign_sweep_json_refused_and_untouched(tmp_path, capsys, force):
    """The probe: a user's sweep.json and results.jsonl (last line without a newline) were
    replaced and cut; now exit 2 with one line, byte for byte as they were."""
    out = tmp_path / "D"
    out.mkdir()
    (out / RESULTS_FILE).write_text("line one\nline two no newline")
    (out / MANIFEST_FILE).write_text('{"mine": 1}\n')
    before = files(out)
    assert sweep_cli(sweep_file(tmp_path, "s1"), out, *force) == 2
    err = capsys.readouterr().err.strip()
    assert "sweep.json is not a multicontact sweep manifest" in err
    assert len(err.splitlines()) == 1
    assert files(out) == before


def test_results_without_manifest_refused_even_with_force(tmp_path, capsys):
    out = tmp_path / "D"
    out.mkdir()
    (out / RESULTS_FILE).write_text("mine\npartial")
    before = files(out)
    assert sweep_cli(sweep_file(tmp_path, "s1"), out, "--force") == 2
    assert "results.jsonl has no sweep.json beside it" in capsys.readouterr().err
    assert files(out) == before


def test_another_sweep_refused_the_same_resumes_and_grows(tmp_path, capsys):
    out = tmp_path / "runs"
    s1 = sweep_file(tmp_path, "s1")
    run_in_process(s1, out)
    stored = files(out)
    # another sweep (another name), or a version of s1 without a finished case: refused
    other = sweep_file(tmp_path, "s2")
    changed = sweep_file(tmp_path / "changed", "s1", HERTZ.replace("200]", "300]"))
    for study, words in ((other, "holds sweep 's1' (sweep.json), not 's2'"),
                         (changed, "holds 1 finished case(s) of sweep 's1' that this version")):
        assert sweep_cli(study, out) == 2
        err = capsys.readouterr().err.strip()
        assert words in err and len(err.splitlines()) == 1, err
        assert sweep_cli(study, out, "--dry-run") == 2
        capsys.readouterr()
        assert files(out) == stored
    # the same sweep resumes (nothing to do), and values added to an axis run alone
    assert sweep_cli(s1, out) == 0
    assert "0 ok, 0 failed, 3 already done" in capsys.readouterr().out
    grown = sweep_file(tmp_path / "grown", "s1", HERTZ.replace("200]", "200, 400]"))
    assert sweep_cli(grown, out, "--dry-run") == 0
    assert "1 cases to run, 3 finished" in capsys.readouterr().out


def test_store_of_an_earlier_version_without_format_resumes(tmp_path):
    """A manifest written before the ``format`` field still marks the sweep's own folder."""
    out = tmp_path / "runs"
    s1 = sweep_file(tmp_path, "s1")
    run_in_process(s1, out)
    man = json.loads((out / MANIFEST_FILE).read_text())
    del man["format"]
    (out / MANIFEST_FILE).write_text(json.dumps(man))
    assert sw.main(["sweep", str(s1), "-o", str(out), "--dry-run"]) == 0
    assert sw.store.is_manifest(man) and not sw.store.is_manifest({"mine": 1})
    assert not sw.store.is_manifest(man | {"format": "other tool"})


@pytest.mark.parametrize("address", ["bogus", "tcp://host", "tcp://host:0", "tcp://h:70000",
                                     "http://h:8786", "tcp://h:8786/x"])
def test_bad_scheduler_refused_before_the_folder(tmp_path, capsys, address):
    out = tmp_path / "out"
    assert sweep_cli(sweep_file(tmp_path, "s1"), out, "--scheduler", address) == 2
    err = capsys.readouterr().err.strip()
    assert f"scheduler {address!r} is not allowed" in err and "tcp://HOST:PORT" in err
    assert len(err.splitlines()) == 1
    assert not out.exists()


def test_unreachable_scheduler_writes_nothing(tmp_path, capsys, monkeypatch):
    """The scheduler is connected to before the store is made (it used to be after)."""
    def unreachable(scheduler, workers):
        raise sw.SweepError(f"cannot connect to the dask scheduler {scheduler!r}: timed out")

    monkeypatch.setattr(sw.runner, "dask_client", unreachable)
    out = tmp_path / "out"
    study = sweep_file(tmp_path, "s1")
    assert sw.main(["sweep", str(study), "-o", str(out), "--scheduler", "tcp://127.0.0.1:1",
                    "--no-progress"]) == 2
    assert "cannot connect" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize("extra, words", [
    (["--workers", "0", "--dry-run"], "workers=0 is not allowed: need >= 1"),
    (["--part", "nope"], "unknown part 'nope': this sweep has main"),
])
def test_bad_options_refused_before_the_folder(tmp_path, capsys, extra, words):
    out = tmp_path / "out"
    study = sweep_file(tmp_path, "s1")
    assert sw.main(["sweep", str(study), "-o", str(out), "--no-progress", *extra]) == 2
    assert words in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize("axes, words", [
    ('"load.P" = { linspace = [1, 2, 100000000] }', "linspace n = 100000000 is not allowed"),
    ('"load.P" = { geomspace = [1, 2, 10001] }', "geomspace n = 10001 is not allowed"),
    ('"load.P" = { linspace = [1, 2, 101] }\n"load.mu" = { linspace = [0.1, 0.5, 100] }',
     "10100 cases (part 'main': 10100) are not allowed"),
])
def test_sweep_size_limit_refused_at_once(tmp_path, capsys, axes, words):
    """A sweep over the limit used to expand (and run) silently: 1e8 points ran 78 s CPU."""
    study = sweep_file(tmp_path, "big", 'base = "hertz"\ntask = "analytic"\n[axes]\n' + axes)
    out = tmp_path / "out"
    assert sw.main(["sweep", str(study), "-o", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert words in err and "a sweep has at most 10000 cases" in err
    assert not out.exists()
    with pytest.raises(sw.SweepError, match="at most 10000 cases"):
        sw.sweep_from_dict(tomllib.loads(study.read_text()))


def test_sweep_report_exit_1_on_failed_cases_and_honours_out(tmp_path, capsys):
    from compare.cli import main

    out = tmp_path / "runs"
    run_in_process(sweep_file(tmp_path, "fails", FAILING), out)
    assert main(["report", "--sweep", str(out)]) == 1
    assert "(1 ok, 1 failed, 0 not run)" in capsys.readouterr().out
    elsewhere = tmp_path / "elsewhere"
    assert main(["report", "--sweep", str(out), "-o", str(elsewhere), "--json"]) == 1
    summ = json.loads(capsys.readouterr().out)
    assert (summ["ok"], summ["failed"]) == (1, 1)
    assert summ["index"] == str(elsewhere / "index.html") and (elsewhere / "index.html").is_file()


def test_sweep_report_exit_0_when_every_case_ran(tmp_path, capsys):
    out = tmp_path / "runs"
    run_in_process(sweep_file(tmp_path, "s1"), out)
    assert sw.main(["report", "--sweep", str(out)]) == 0
    assert "(3 ok, 0 failed, 0 not run)" in capsys.readouterr().out


def test_manifest_is_plain_json_with_format(tmp_path):
    s = sw.load_sweep(sweep_file(tmp_path, "s1"))
    man = jsonable(s.manifest())
    assert man["format"] == sw.store.MANIFEST_FORMAT and sw.store.is_manifest(man)


def test_sweep_errors_with_json_give_the_json_error_object(tmp_path, capsys):
    """`sweep --json` and `report --sweep --json` print the JSON error object every command
    prints (README, Errors), on stdout, with exit 2."""
    import json

    from compare.cli import main

    assert main(["sweep", "nosuchstudy", "-o", str(tmp_path / "o"), "--json"]) == 2
    assert json.loads(capsys.readouterr().out)["error"]["exit_code"] == 2
    assert main(["report", "--sweep", str(tmp_path / "none"), "--json"]) == 2
    assert json.loads(capsys.readouterr().out)["error"]["kind"] == "input"


def test_run_sweep_refuses_workers_with_a_tcp_scheduler(tmp_path):
    """The API refuses what the CLI refuses: workers are the cluster's under tcp://."""
    from compare.errors import SweepError
    from compare.sweep.runner import run_sweep

    with pytest.raises(SweepError, match="workers=4 does not apply to scheduler tcp://h:8786"):
        run_sweep("fig5_sweep", tmp_path / "o", workers=4, scheduler="tcp://h:8786")
    assert not (tmp_path / "o").exists()
