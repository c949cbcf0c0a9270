"""Randomised audit of the analytic solver against independent quadratures and the BEM.

Run: ``python benchmarks/audit.py --n 500 --seed 0 --jobs 1 --out audit-out``. Audits the cases
of seeds ``seed .. seed + n - 1`` (see ``compare/audit/cases.py``) and writes ``audit.json`` and
``audit.md`` (cases, disagreements by class, solve-time median / p95 / max) to ``--out``.
Prints "i of N" per case; interrupted (Ctrl-C), it writes the table of the cases finished so
far and exits with 130.  Exit status 1 when any case disagrees.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # threaded BLAS on 2 cores is 30-100x slower

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from compare.audit import checks, run  # noqa: E402


class Progress:
    """Collects the results as they arrive and prints one line each: i of N, verdict, time."""

    def __init__(self, total: int):
        self.total, self.results, self.t0 = total, [], time.perf_counter()

    def __call__(self, result: run.CaseResult) -> None:
        self.results.append(result)
        verdict = ", ".join(result.classes) or "ok"
        print(f"[{len(self.results)} of {self.total}, {time.perf_counter() - self.t0:.0f} s] "
              f"seed {result.seed}: {verdict} (solve {result.solve_cpu:.2f} s CPU)",
              file=sys.stderr, flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=500, help="number of cases (default 500)")
    parser.add_argument("--seed", type=int, default=0, help="first seed (default 0)")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    parser.add_argument("--bem-n", type=int, default=checks.BEM_N,
                        help=f"coarse BEM panels (fine: twice; default {checks.BEM_N})")
    parser.add_argument("--out", type=Path, default=Path("audit-out"),
                        help="output directory for audit.json and audit.md")
    args = parser.parse_args(argv)
    if args.n < 1 or args.jobs < 1 or args.seed < 0:
        parser.error(f"need --n >= 1, --jobs >= 1, --seed >= 0 (got {args.n}, {args.jobs}, "
                     f"{args.seed})")
    progress = Progress(args.n)
    try:
        run.run_audit(list(range(args.seed, args.seed + args.n)), args.jobs, args.bem_n,
                      report=progress)
    except KeyboardInterrupt:
        results = progress.results
        if not results:
            print("interrupted before the first case finished: nothing written", file=sys.stderr)
            return 130
        run.write_table(results, args.out)
        print(f"interrupted after {len(results)} of {args.n} cases: their table is written to "
              f"{args.out / 'audit.json'} and {args.out / 'audit.md'}", file=sys.stderr)
        return 130
    results = progress.results
    head = run.write_table(results, args.out)
    print(run.markdown(results, head).split("\n## Cases")[0])
    print(f"written {args.out / 'audit.json'} and {args.out / 'audit.md'}")
    return 1 if head["disagreements"] else 0


if __name__ == "__main__":
    sys.exit(main())
