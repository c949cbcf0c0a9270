"""Report of a sweep directory: metric-vs-parameter figures, heat maps, tables.

``write_sweep_report(DIR)`` reads ``DIR/sweep.json`` and ``DIR/results.jsonl`` (see
``docs/sweeps.md``) and writes ``DIR/report/index.html`` (self-contained: figures embedded as
base64 PNG), ``DIR/report/report.md`` (figures as PNG files next to it) and
``DIR/report/summary.json``.  The report directory is built aside and swapped in, so a failed
run leaves the previous report untouched.

Figures come from the sweep file's ``[report]`` table (``[[report.plots]]``,
``[[report.heatmaps]]``, ``[report.labels]``), else from defaults: every default metric of a
part's task against every varying parameter (one line per value of the other parameters), and
a heat map over every pair of varying parameters.  Parts with an analytic task are drawn as
curves, FE parts as markers, so FE points sit on the analytic curves they check.
"""

from __future__ import annotations

import base64
import html
import io
import itertools
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from compare.errors import SweepError
from compare.fileio import owned_output, plan_output
from compare.sweep.store import read_manifest, read_records
from compare.sweep.tasks import ANALYTIC_TASKS, DEFAULT_METRICS

#: Parameters with more distinct values than this are not used to split lines / panels.
MAX_GROUPS = 12
#: Values spanning more than this ratio (all > 0) are drawn on a log axis by default.
LOG_SPAN = 30.0
PLOT_KEYS = {"title", "x", "y", "parts", "panels", "series", "logx", "logy"}
HEATMAP_KEYS = {"title", "x", "y", "z", "part", "log"}


@dataclass(frozen=True)
class Figure:
    """One rendered figure: file stem, title, caption and PNG bytes."""

    stem: str
    title: str
    caption: str
    png: bytes


# ---------------------------------------------------------------------------------------------
# data
# ---------------------------------------------------------------------------------------------
def sweep_rows(directory: str | Path) -> tuple[dict, list[dict]]:
    """Manifest and one row per case of the manifest (params + metrics + status)."""
    man = read_manifest(directory)
    recs = read_records(directory)
    rows = []
    for c in man["cases"]:
        rec = recs.get(c["key"])
        row = {"part": c["part"], "task": c["task"], "key": c["key"], "index": c["index"],
               **c["params"], "status": rec["status"] if rec else "pending",
               "error": (rec.get("error") or {}).get("message", "") if rec else "",
               "wall_s": rec["timings"]["wall_s"] if rec else None}
        if rec and rec["status"] == "ok":
            row.update({k: v for k, v in rec["metrics"].items() if k not in row})
        rows.append(row)
    return man, rows


def _num(v: Any) -> float:
    ok = isinstance(v, (int, float)) and not isinstance(v, bool)
    return float(v) if ok else float("nan")


def _distinct(rows: list[dict], col: str) -> list:
    seen: dict = {}
    for r in rows:
        if col in r:
            seen.setdefault(_hashable(r[col]), None)
    return list(seen)


def _hashable(v: Any) -> Any:
    return tuple(v) if isinstance(v, list) else v


def _present(rows: list[dict], cols: Sequence[str]) -> list[tuple]:
    """Distinct value tuples of ``cols`` that occur in ``rows`` (order of first occurrence)."""
    seen: dict = {}
    for r in rows:
        seen.setdefault(tuple(_hashable(r.get(c)) for c in cols), None)
    return list(seen) or [()]


def _varying(part: dict, rows: list[dict]) -> list[str]:
    """One parameter per axis that takes more than one value (a zip group by its first)."""
    return [axis[0] for axis in part["axes"] if len(_distinct(rows, axis[0])) > 1]


def _auto_log(values: Sequence[float]) -> bool:
    v = np.asarray([x for x in values if math.isfinite(x)])
    return v.size > 1 and bool(np.all(v > 0)) and v.max() / v.min() > LOG_SPAN


def _label(labels: dict, col: str) -> str:
    return labels.get(col, col)


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return "" if v is None else str(v)


# ---------------------------------------------------------------------------------------------
# figures
# ---------------------------------------------------------------------------------------------
def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    _plt().close(fig)
    return buf.getvalue()


def _ys(spec: dict, part: str) -> list[str]:
    y = spec["y"]
    if isinstance(y, dict):
        return list(y.get(part, []))
    return [y] if isinstance(y, str) else list(y)


def _group_label(cols: Sequence[str], values: tuple, labels: dict) -> str:
    return ", ".join(f"{_label(labels, c)}={_fmt(v)}" for c, v in zip(cols, values, strict=True))


def _draw_series(ax, rows: list[dict], x: str, y: str, style: dict, label: str) -> bool:
    pts = sorted((_num(r.get(x)), _num(r.get(y))) for r in rows if r["status"] == "ok")
    pts = [(a, b) for a, b in pts if math.isfinite(a) and math.isfinite(b)]
    if not pts:
        return False
    xs, ys = zip(*pts, strict=True)
    ax.plot(xs, ys, label=label, **style)
    return True


def _panel(ax, rows: list[dict], spec: dict, parts: dict, labels: dict) -> None:
    series = list(spec.get("series", []))
    groups = _present(rows, series)
    colors = _plt().rcParams["axes.prop_cycle"].by_key()["color"]
    lines = ("-", "--", ":", "-.")
    marks = ("o", "s", "^", "D")
    for gi, gval in enumerate(groups):
        grows = [r for r in rows if all(_hashable(r.get(s)) == v
                                        for s, v in zip(series, gval, strict=True))]
        for pname, task in parts.items():
            prow = [r for r in grows if r["part"] == pname]
            for yi, y in enumerate(_ys(spec, pname)):
                curve = task in ANALYTIC_TASKS
                style = ({"ls": lines[yi % 4], "lw": 1.5} if curve else
                         {"ls": "none", "marker": marks[yi % 4], "ms": 6, "mfc": "none"})
                style["color"] = colors[gi % len(colors)]
                name = _group_label(series, gval, labels)
                lab = f"{pname}: {_label(labels, y)}" + (f" ({name})" if name else "")
                _draw_series(ax, prow, spec["x"], y, style, lab)
    ax.set_xlabel(_label(labels, spec["x"]))
    ax.grid(True, alpha=0.3)


def _scale(ax, spec: dict, rows: list[dict], axis: str, cols: list[str]) -> None:
    key = f"log{axis}"
    vals = [_num(r.get(c)) for r in rows for c in cols]
    if spec.get(key, _auto_log(vals)):
        (ax.set_xscale if axis == "x" else ax.set_yscale)("log")


def plot_figure(spec: dict, rows: list[dict], man: dict, labels: dict, stem: str) -> Figure:
    """Lines / points of ``spec['y']`` against ``spec['x']``, one panel per ``panels`` value."""
    parts = {p["name"]: p["task"] for p in man["parts"]
             if not spec.get("parts") or p["name"] in spec["parts"]}
    rows = [r for r in rows if r["part"] in parts]
    pcols = list(spec.get("panels", []))
    pvals = _present(rows, pcols)
    plt = _plt()
    ncol = min(3, len(pvals))
    nrow = math.ceil(len(pvals) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.6 * ncol, 3.6 * nrow), squeeze=False,
                             layout="constrained")
    ys = sorted({y for p in parts for y in _ys(spec, p)})
    for ax, v in zip(axes.flat, pvals, strict=False):
        prow = [r for r in rows if all(_hashable(r.get(c)) == x
                                       for c, x in zip(pcols, v, strict=True))]
        _panel(ax, prow, spec, parts, labels)
        ax.set_ylabel(", ".join(_label(labels, y) for y in ys), fontsize=9)
        _scale(ax, spec, prow, "x", [spec["x"]])
        _scale(ax, spec, prow, "y", ys)
        ax.set_title(_group_label(pcols, v, labels), fontsize=9)
    for ax in list(axes.flat)[len(pvals):]:
        ax.set_visible(False)
    title = spec.get("title", f"{', '.join(ys)} vs {spec['x']}")
    fig.suptitle(title, fontsize=11)
    _legend_below(fig, axes)
    return Figure(stem, title, _caption(spec, parts), _png(fig))


def _legend_below(fig, axes) -> None:
    """One legend under all panels (each label once), where it covers no data."""
    seen: dict = {}
    for ax in axes.flat:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            seen.setdefault(lab, h)
    if seen:
        fig.legend(list(seen.values()), list(seen), loc="outside lower center", fontsize=8,
                   ncol=min(3, len(seen)), frameon=False)


def _caption(spec: dict, parts: dict) -> str:
    kinds = ", ".join(f"{p} ({'curve' if t in ANALYTIC_TASKS else 'points'}, task {t})"
                      for p, t in parts.items())
    return f"x = {spec['x']}; parts: {kinds}."


def heatmap_figure(spec: dict, rows: list[dict], labels: dict, stem: str) -> Figure:
    """Mean of ``z`` over the other parameters on the grid of ``x`` and ``y`` values."""
    rows = [r for r in rows if r["part"] == spec["part"] and r["status"] == "ok"]
    xv = sorted(_distinct(rows, spec["x"]), key=_num)
    yv = sorted(_distinct(rows, spec["y"]), key=_num)
    grid = np.full((len(yv), len(xv)), np.nan)
    for i, y in enumerate(yv):
        for j, x in enumerate(xv):
            z = [_num(r.get(spec["z"])) for r in rows
                 if _hashable(r.get(spec["x"])) == x and _hashable(r.get(spec["y"])) == y]
            z = [v for v in z if math.isfinite(v)]
            grid[i, j] = np.mean(z) if z else np.nan
    plt = _plt()
    fig, ax = plt.subplots(figsize=(1.0 + 0.7 * max(4, len(xv)), 1.0 + 0.5 * max(4, len(yv))))
    show = np.log10(grid) if spec.get("log") and np.nanmin(grid) > 0 else grid
    im = ax.imshow(show, origin="lower", aspect="auto", cmap="viridis")
    ax.set_xticks(range(len(xv)), [_fmt(v) for v in xv], rotation=45, fontsize=7)
    ax.set_yticks(range(len(yv)), [_fmt(v) for v in yv], fontsize=7)
    if grid.size <= 200:
        for (i, j), v in np.ndenumerate(grid):
            ax.text(j, i, _fmt(float(v)), ha="center", va="center", fontsize=6, color="w")
    ax.set_xlabel(_label(labels, spec["x"]))
    ax.set_ylabel(_label(labels, spec["y"]))
    fig.colorbar(im, ax=ax, label=("log10 " if spec.get("log") else "") + spec["z"])
    title = spec.get("title", f"{spec['part']}: {spec['z']} over {spec['x']} x {spec['y']}")
    ax.set_title(title, fontsize=10)
    return Figure(stem, title, "mean over the other parameters of the part", _png(fig))


def auto_specs(man: dict, rows: list[dict]) -> tuple[list[dict], list[dict]]:
    """Default plots and heat maps when the sweep file has no [report] figures."""
    plots, maps = [], []
    for part in man["parts"]:
        prow = [r for r in rows if r["part"] == part["name"]]
        metrics = [m for m in DEFAULT_METRICS.get(part["task"], []) if any(m in r for r in prow)]
        vary = [p for p in _varying(part, prow) if len(_distinct(prow, p)) <= 200]
        if not metrics:
            continue
        for x in vary:
            others = [p for p in vary if p != x]
            n_groups = math.prod(len(_distinct(prow, p)) for p in others)
            plots += [{"title": f"{part['name']}: {m} vs {x}", "x": x, "y": [m],
                       "parts": [part["name"]],
                       "series": others if n_groups <= MAX_GROUPS else []} for m in metrics]
        for x, y in itertools.combinations(vary, 2):
            maps += [{"x": x, "y": y, "z": m, "part": part["name"]} for m in metrics]
    return plots, maps


def _check_spec(spec: Any, allowed: set, kind: str, i: int, required: Sequence[str]) -> dict:
    if not isinstance(spec, dict):
        raise SweepError(f"[[report.{kind}]] #{i} must be a table")
    bad = sorted(set(spec) - allowed)
    missing = [k for k in required if k not in spec]
    if bad or missing:
        what = f"unknown key {bad[0]!r}" if bad else f"missing key {missing[0]!r}"
        raise SweepError(f"[[report.{kind}]] #{i}: {what}; keys: {', '.join(sorted(allowed))}")
    return spec


def figures(man: dict, rows: list[dict]) -> list[Figure]:
    """All figures of the report (spec'd in the sweep file, or the defaults)."""
    rep = man.get("report") or {}
    labels = rep.get("labels", {})
    plots = [_check_spec(s, PLOT_KEYS, "plots", i, ("x", "y"))
             for i, s in enumerate(rep.get("plots", []))]
    maps = [_check_spec(s, HEATMAP_KEYS, "heatmaps", i, ("x", "y", "z", "part"))
            for i, s in enumerate(rep.get("heatmaps", []))]
    if not plots and not maps:
        plots, maps = auto_specs(man, rows)
    out = [plot_figure(s, rows, man, labels, f"plot{i + 1}") for i, s in enumerate(plots)]
    out += [heatmap_figure(s, rows, labels, f"heatmap{i + 1}") for i, s in enumerate(maps)]
    return out


# ---------------------------------------------------------------------------------------------
# tables and documents
# ---------------------------------------------------------------------------------------------
def part_table(part: dict, rows: list[dict], labels: dict | None = None
               ) -> tuple[list[str], list[list[str]]]:
    """Header and rows of a part's case table: parameters, default metrics, status, time; a
    column's header is its label of the sweep file's [report.labels] (the figures' axes)."""
    prow = [r for r in rows if r["part"] == part["name"]]
    metrics = [m for m in DEFAULT_METRICS.get(part["task"], []) if any(m in r for r in prow)]
    cols = ["index", *part["parameters"], *metrics, "status", "wall_s"]
    head = [_label(labels or {}, c) for c in cols]
    return head, [[_fmt(r.get(c)) for c in cols] for r in prow]


def summary(man: dict, rows: list[dict]) -> dict:
    """Counts per part and overall, plus the failed cases with their error messages."""
    parts = {}
    for p in man["parts"]:
        st = [r["status"] for r in rows if r["part"] == p["name"]]
        parts[p["name"]] = {"task": p["task"], "cases": len(st), "ok": st.count("ok"),
                            "failed": st.count("failed"), "pending": st.count("pending")}
    failed = [{"part": r["part"], "index": r["index"], "key": r["key"], "error": r["error"],
               **{k: r[k] for p in man["parts"] if p["name"] == r["part"]
                  for k in p["parameters"]}}
              for r in rows if r["status"] == "failed"]
    return {"name": man["name"], "description": man.get("description", ""), "parts": parts,
            "total": len(rows), "ok": sum(v["ok"] for v in parts.values()),
            "failed": len(failed), "pending": sum(v["pending"] for v in parts.values()),
            "failures": failed}


def _labels(man: dict) -> dict:
    return (man.get("report") or {}).get("labels", {})


def _md_table(cols: list[str], body: list[list[str]]) -> str:
    head = "| " + " | ".join(cols) + " |\n|" + "---|" * len(cols) + "\n"
    return head + "".join("| " + " | ".join(r) + " |\n" for r in body)


def markdown(man: dict, rows: list[dict], figs: list[Figure], summ: dict) -> str:
    out = [f"# Sweep report: {man['name']}\n", man.get("description", "") + "\n",
           f"{summ['total']} cases: {summ['ok']} ok, {summ['failed']} failed, "
           f"{summ['pending']} not run.\n"]
    for f in figs:
        out.append(f"## {f.title}\n\n![{f.title}](figures/{f.stem}.png)\n\n{f.caption}\n")
    for p in man["parts"]:
        out.append(f"## Part `{p['name']}` (task `{p['task']}`)\n")
        out.append(_md_table(*part_table(p, rows, _labels(man))))
    if summ["failures"]:
        out.append("## Failed cases\n")
        out.append(_md_table(["part", "index", "error"],
                             [[f["part"], str(f["index"]), f["error"].replace("|", "/")]
                              for f in summ["failures"]]))
    return "\n".join(out)


CSS = ("body{font-family:sans-serif;max-width:1200px;margin:2em auto;color:#222}"
       "table{border-collapse:collapse;font-size:12px}td,th{border:1px solid #ccc;"
       "padding:2px 6px;text-align:right}img{max-width:100%}.failed{color:#b00}")


def _html_table(cols: list[str], body: list[list[str]]) -> str:
    head = "".join(f"<th>{html.escape(c)}</th>" for c in cols)
    trs = "".join("<tr" + (' class="failed"' if "failed" in r else "") + ">"
                  + "".join(f"<td>{html.escape(v)}</td>" for v in r) + "</tr>" for r in body)
    return f"<table><tr>{head}</tr>{trs}</table>"


def html_page(man: dict, rows: list[dict], figs: list[Figure], summ: dict) -> str:
    esc = html.escape
    out = [f"<!doctype html><html><head><meta charset='utf-8'><title>Sweep {esc(man['name'])}"
           f"</title><style>{CSS}</style></head><body>",
           f"<h1>Sweep report: {esc(man['name'])}</h1><p>{esc(man.get('description', ''))}</p>",
           f"<p>{summ['total']} cases: {summ['ok']} ok, {summ['failed']} failed, "
           f"{summ['pending']} not run.</p>"]
    for f in figs:
        data = base64.b64encode(f.png).decode()
        out.append(f"<h2>{esc(f.title)}</h2><img alt='{esc(f.title)}' "
                   f"src='data:image/png;base64,{data}'><p>{esc(f.caption)}</p>")
    for p in man["parts"]:
        out.append(f"<h2>Part {esc(p['name'])} (task {esc(p['task'])})</h2><details open>"
                   f"<summary>cases</summary>{_html_table(*part_table(p, rows, _labels(man)))}"
                   "</details>")
    if summ["failures"]:
        out.append("<h2>Failed cases</h2>" + _html_table(
            ["part", "index", "error"],
            [[f["part"], str(f["index"]), f["error"]] for f in summ["failures"]]))
    out.append("</body></html>")
    return "\n".join(out)


def write_sweep_report(directory: str | Path, out: str | Path | None = None,
                       force: bool = False) -> Path:
    """Write the report of a sweep directory (default into ``DIR/report``); return its path.

    Written through :func:`compare.fileio.owned_output`: a folder holding files multicontact
    did not write is refused (CaseError) unless ``force``; the previous report is replaced
    atomically.
    """
    directory = Path(directory)
    man, rows = sweep_rows(directory)
    out = Path(out) if out else directory / "report"
    plan = plan_output(out, "sweep report", force, expected=("index.html", "report.md"))
    figs = figures(man, rows)
    summ = summary(man, rows)
    with owned_output(out, "sweep report", force, plan) as tmp:
        (tmp / "figures").mkdir()
        for f in figs:
            (tmp / "figures" / f"{f.stem}.png").write_bytes(f.png)
        (tmp / "report.md").write_text(markdown(man, rows, figs, summ), encoding="utf-8")
        (tmp / "index.html").write_text(html_page(man, rows, figs, summ), encoding="utf-8")
        (tmp / "summary.json").write_text(json.dumps(summ, indent=1), encoding="utf-8")
    out = plan.out
    return out
