"""Sweep throughput (cases / minute) with 1 and 2 local workers, and the scaling efficiency.

Studies: the analytic part of the library study ``fig5_sweep`` (3 angle pairs x 40 loads,
actual + overlapped extent per case) and a small FE study (double wedge, FE stage 1 at level
1, 8 loads).  Every run starts in an empty directory and includes the pool start-up.
Efficiency = throughput(2 workers) / (2 * throughput(1 worker)).

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_sweep.py [--dask] [--repeat N]

``--dask`` adds rows for a dask LocalCluster with the same worker counts.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import tomllib
from pathlib import Path

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

from compare import sweep as sw  # noqa: E402

FE_STUDY = """
name = "fe_small"
task = "fem"
set = { "fem.level" = 1 }
axes = { "load.P" = [0.04, 0.05, 0.06, 0.07, 0.08, 0.09, 0.1, 0.11] }
[base]
profile = { type = "double_wedge", c = 1.0, phi_inner = 0.11, phi_outer = 0.07 }
material = { A = 1.0 }
load = { P = 0.05, mu = 0.3 }
"""


def studies() -> dict[str, tuple[sw.Sweep, list[str] | None]]:
    return {"fig5 analytic (120 cases)": (sw.load_sweep("fig5_sweep"), ["analytic"]),
            "FE stage 1, level 1 (8 cases)": (sw.sweep_from_dict(tomllib.loads(FE_STUDY),
                                                                 "fe_small"), None)}


def measure(sweep: sw.Sweep, parts, workers: int, scheduler: str | None, repeat: int
            ) -> tuple[float, int]:
    """Best throughput (cases / min) over ``repeat`` runs, and the number of failed cases."""
    best, failed = 0.0, 0
    for _ in range(repeat):
        with tempfile.TemporaryDirectory() as tmp:
            res = sw.run_sweep(sweep, Path(tmp) / "out", workers=workers, scheduler=scheduler,
                               parts=parts, progress=False)
        best, failed = max(best, res.throughput_per_min), max(failed, res.failed)
    return best, failed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dask", action="store_true", help="also run on a dask LocalCluster")
    ap.add_argument("--repeat", type=int, default=1, help="runs per row (best is kept)")
    args = ap.parse_args()
    runners = [("process pool", None)] + ([("dask LocalCluster", "local")] if args.dask else [])
    print(f"{'study':32} {'runner':18} {'workers':>7} {'cases/min':>10} {'efficiency':>10} "
          f"{'failed':>6}")
    for label, (sweep, parts) in studies().items():
        for rname, sched in runners:
            one = None
            for w in (1, 2):
                thr, failed = measure(sweep, parts, w, sched, args.repeat)
                one = thr if w == 1 else one
                eff = "" if w == 1 else f"{thr / (2 * one):10.2f}"
                print(f"{label:32} {rname:18} {w:7d} {thr:10.1f} {eff:>10} {failed:6d}",
                      flush=True)


if __name__ == "__main__":
    main()
