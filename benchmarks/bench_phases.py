"""CPU seconds of every phase of ``compare.run_case`` on one case, per level and mesh layout.

Run: ``python benchmarks/bench_phases.py [--case cattaneo] [--levels 1 2 3]
[--layouts tensor rings]``.  One process per row (a fresh process: no warm caches, and the
peak memory is the row's own); process CPU seconds, not wall-clock (the 2-core machine is
shared: CPU time is the reproducible figure, single runs still scatter by ~10-20 %).

Columns: DOFs; the FE history's phases as ``fem.FemHistory.timings['cpu']`` records them
(assembly, factorisation + condensation, increments, recovery = full fields + result steps,
history = their sum with the mesh); ``stress FE`` = the L2 projection of body 2's stresses at
the states the stress metrics compare (one multi-RHS mass solve); ``metrics`` = everything else
of ``compare.run.evaluate`` (analytic stresses by Cauchy integrals below and on the surface,
the interface metrics); ``peak GB`` = the process's peak resident memory.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import resource  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

PHASES = ("assembly", "factorisation+condensation", "increments", "recovery", "history")
HEADER = ("level", "layout", "DOFs", "assembly", "fact.+cond.", "increments", "recovery",
          "history", "stress FE", "metrics", "peak GB")


def measure(case_name: str, level: int, layout: str) -> dict:
    """One row: run the case at ``level`` / ``layout`` in this process and time its phases."""
    from compare import stress as cs
    from compare.analytic_side import solve_case
    from compare.cases import load_case
    from compare.fem_side import run_fem
    from compare.run import evaluate

    case = load_case(case_name).with_fem(level=level, layout=layout)
    an = solve_case(case)
    hist = run_fem(case, an.normal)
    c0 = time.process_time()
    steps = [cs.fem_step(hist, stage, Q) for stage, Q, _ in cs.analytic_states(case, an)]
    c1 = time.process_time()  # the analytic states count as metrics, the projection not
    hist.body_stresses(steps, 1)
    c2 = time.process_time()
    evaluate(case, an, hist)
    c3 = time.process_time()
    cpu = hist.timings["cpu"]
    return {"level": level, "layout": layout, "dofs": hist.n_dofs,
            **{k: cpu[k] for k in PHASES}, "stress FE": c2 - c1,
            "metrics": (c1 - c0) + (c3 - c2),
            "peak GB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6}


def row_text(r: dict) -> str:
    cells = [str(r["level"]), r["layout"], f"{r['dofs']:,}"]
    cells += [f"{r[k]:.2f}" for k in (*PHASES, "stress FE", "metrics", "peak GB")]
    return "| " + " | ".join(cells) + " |"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", default="cattaneo")
    parser.add_argument("--levels", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--layouts", nargs="+", default=["tensor", "rings"])
    parser.add_argument("--row", nargs=2, metavar=("LEVEL", "LAYOUT"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.row:  # a child process: one row as JSON
        print(json.dumps(measure(args.case, int(args.row[0]), args.row[1])))
        return 0
    print("| " + " | ".join(HEADER) + " |")
    print("|" + "---|" * len(HEADER))
    for level in args.levels:
        for layout in args.layouts:
            out = subprocess.run([sys.executable, __file__, "--case", args.case, "--row",
                                  str(level), layout], capture_output=True, text=True,
                                 check=True)
            print(row_text(json.loads(out.stdout.strip().splitlines()[-1])), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
