"""Sweep tasks: what is computed for one case, and the flat JSON record it becomes.

A task maps a validated :class:`compare.cases.Case` to a flat dict of JSON-able metrics
(``TASKS``: analytic normal solution, the paper's Section 6 overlap extent / ``Pe`` (Fig. 5),
FE stage 1 against the analytic solution, or the full ``compare.run_case`` comparison).
:func:`execute` runs one plain-data task dict on a worker (local process pool or dask) and
returns its record (schema in ``docs/sweeps.md``); it never raises: a failing case becomes a
record with ``status = "failed"`` and the error.
"""

from __future__ import annotations

import math
import os
import socket
import time
import traceback
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

import compare
from compare import cases as case_schema
from compare.sweep.store import SCHEMA_VERSION


# =============================================================================================
# tasks: what is computed for one case (each returns a flat dict of JSON-able metrics)
# =============================================================================================
def _normal_metrics(sol, case) -> dict:
    """Zones, loads and self-checks of an analytic normal solution."""
    m: dict[str, Any] = {"n_zones": sol.n_zones, "P": sol.P, "M": sol.M, "theta": sol.theta,
                         "extent_total": sol.extent}
    for i, ((a, b), load) in enumerate(zip(sol.zones, sol.zone_loads, strict=True)):
        m.update({f"zone{i}_a": a, f"zone{i}_b": b, f"zone{i}_width": b - a,
                  f"zone{i}_load": load})
    m["extent"] = sol.zones[-1][1] - sol.zones[-1][0]
    m["kappa"] = m["extent"] / case.profile_spec["c"] if "c" in case.profile_spec else None
    m.update({f"check_{k}": v for k, v in sol.residuals.items()})
    return m


def _solve_normal(case):
    import analytic

    return analytic.solve_normal(case.profile, case.P, case.A, case.M)


def task_analytic(case) -> dict:
    """Analytic normal solution (stage 1): zones, zone loads, extent of the right zone."""
    return _normal_metrics(_solve_normal(case), case)


def _overlapped_extent(case, theta: float) -> float:
    import analytic

    zones = analytic.overlapped(case.profile, case.P, case.A, theta).zones
    return zones[-1][1] - zones[-1][0]


def task_overlap(case) -> dict:
    """Paper Section 6 / Fig. 5: actual vs overlapped extent of the right zone, ``Pe``."""
    sol = _solve_normal(case)
    m = _normal_metrics(sol, case)
    m["extent_overlapped"] = _overlapped_extent(case, sol.theta)
    m["Pe"] = (m["extent"] - m["extent_overlapped"]) / m["extent"] * 100.0
    return m


def _fem_metrics(case, sol) -> dict:
    from compare import fem_side, metrics

    hist = fem_side.run_fem(case, sol)
    end = [s for s in hist.steps if s.stage == 1][-1]
    fe = list(end.contact_zones)
    m: dict[str, Any] = {"fe_n_zones": len(fe), "fe_P": end.reactions[0],
                         "n_dofs": hist.n_dofs, "h_min": hist.h_min}
    for i, (a, b) in enumerate(fe):
        m.update({f"fe_zone{i}_a": a, f"fe_zone{i}_b": b, f"fe_zone{i}_width": b - a})
    errs = metrics.edge_errors(sol.zones, fe)
    rel = [max(e) / (b - a) for e, (a, b) in zip(errs, sol.zones, strict=True)]
    m["edge_error_max"] = max(rel)
    match = metrics.match_zones(sol.zones, fe)[-1]
    m["extent_analytic"] = sol.zones[-1][1] - sol.zones[-1][0]
    m["extent"] = fe[match][1] - fe[match][0] if match is not None else None
    if m["extent"] is not None:
        m["extent_error"] = abs(m["extent"] - m["extent_analytic"]) / m["extent_analytic"]
    m["kappa"] = (m["extent"] / case.profile_spec["c"]
                  if "c" in case.profile_spec and m["extent"] is not None else None)
    m.update({f"fe_time_{k}": v for k, v in dict(hist.timings).items()
              if isinstance(v, (int, float))})
    return m


def task_fem(case) -> dict:
    """FE stage 1 against the analytic normal solution: FE zones, edge errors, extent."""
    return _fem_metrics(case, _solve_normal(case))


def task_fem_overlap(case) -> dict:
    """FE stage 1 plus the overlapped extent: FE points of the paper's Fig. 5 (``Pe`` of FE)."""
    sol = _solve_normal(case)
    m = _fem_metrics(case, sol)
    m["extent_overlapped"] = _overlapped_extent(case, sol.theta)
    an = m["extent_analytic"]
    m["Pe_analytic"] = (an - m["extent_overlapped"]) / an * 100.0
    fe = m["extent"]
    m["Pe"] = (fe - m["extent_overlapped"]) / fe * 100.0 if fe else None
    return m


def task_run(case) -> dict:
    """Both solvers and all comparison metrics: ``compare.run_case(case).metrics``."""
    return dict(compare.run_case(case).metrics)


TASKS: dict[str, Callable[[Any], dict]] = {
    "analytic": task_analytic,
    "overlap": task_overlap,
    "fem": task_fem,
    "fem_overlap": task_fem_overlap,
    "run": task_run,
}
#: Tasks drawn as curves in reports (the others are FE points, drawn as markers).
ANALYTIC_TASKS = {"analytic", "overlap"}
#: Metrics plotted by default per task (when the sweep file has no [report] table).
DEFAULT_METRICS = {
    "analytic": ["extent", "extent_total"],
    "overlap": ["extent", "extent_overlapped", "Pe"],
    "fem": ["edge_error_max", "extent_error"],
    "fem_overlap": ["edge_error_max", "extent_error", "Pe"],
    "run": ["edge_error_max", "stick_edge_error_max", "pressure_l2_error", "shear_l2_error"],
}


# =============================================================================================
# records: one flat JSON object per case (schema in docs/sweeps.md)
# =============================================================================================
def jsonable(value: Any) -> Any:
    """Plain JSON value: numpy scalars -> Python, nan/inf -> None, tuples -> lists."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, (list, tuple, np.ndarray)):
        return [jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if value is None or isinstance(value, str):
        return value
    return str(value)


def utc_now() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def _record(task: dict, status: str, metrics: dict, error: dict | None,
            t0: float, started: str) -> dict:
    return {"schema": SCHEMA_VERSION, "key": task["key"], "sweep": task["sweep"],
            "part": task["part"], "task": task["task"], "index": task["index"],
            "params": task["params"], "status": status, "metrics": jsonable(metrics),
            "error": error,
            "timings": {"wall_s": time.perf_counter() - t0, "started": started,
                        "finished": utc_now()},
            "worker": {"host": socket.gethostname(), "pid": os.getpid()}}


def _error(exc: BaseException) -> dict:
    tb = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__, limit=-6))
    return {"type": type(exc).__name__, "message": str(exc), "traceback": tb}


def execute(task: dict) -> dict:
    """Run one sweep case (plain-data ``task``) and return its record; never raises."""
    t0, started = time.perf_counter(), utc_now()
    try:
        base = Path(task["base_dir"]) if task.get("base_dir") else None
        case = case_schema.case_from_dict(task["case"], name=task["name"], src=task["name"],
                                          base=base)
        metrics = TASKS[task["task"]](case)
    except Exception as exc:  # noqa: BLE001 - a failing case is recorded, the sweep goes on
        return _record(task, "failed", {}, _error(exc), t0, started)
    return _record(task, "ok", metrics, None, t0, started)


def infrastructure_failure(task: dict, message: str) -> dict:
    """Record of a case whose worker died or whose result never came back."""
    rec = _record(task, "failed", {}, {"type": "WorkerLost", "message": message,
                                       "traceback": ""}, time.perf_counter(), utc_now())
    rec["worker"] = None
    return rec
