"""What the external-code drivers (Kratos, CalculiX) share: the landing check and the CLI.

A driver runs a library case in another FE code, writes the result in the exchange format
(``docs/external.md``) and verifies it.  The run must land on the case's loads: the last
stage-1 P within :data:`LANDING_RTOL` of the case's P and the last stage-2 Q within that
fraction of the case's Q0 (:func:`check_landed`); otherwise it is not a run of the case and
the driver stops with :class:`DriverError`.  :func:`main` is the common command line
``python -m compare.external.CODE CASE OUT [--level L]``: one clear message and exit 2 on any
error of the code or of the check, exit 0 / 1 with the verdict otherwise.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from compare.errors import CaseError
from compare.external.csvio import MANIFEST, step_name

#: A driver's run lands on the case's P and Q0 within this fraction.  Measured (Cattaneo,
#: level 0): Kratos with targets from the clamped FE model 0.02 % on P, 0.2 % on Q0; CalculiX
#: under load control is exact on the loads up to its force residual (< 1e-4).
LANDING_RTOL = 0.01
#: Half-width and depth of the clamped bodies of a driver's model, in multiples of the
#: half-width of the refined zone around the contact.  The case is two half-planes; a clamped
#: finite body moves the edges (measured with our FE, clamped, Cattaneo: edge error 0.23 % of
#: the width at 8 and 0.02 % at 32 at level 0; shear 12.9 % and 4.4 % at level 1).
BODY_SIZE_FACTOR = 32.0


class DriverError(CaseError):
    """The external code failed, or its run did not land on the case's loads."""


def landing_error(code: str, case, loads: Sequence[tuple[int, float, float]],
                  rtol: float = LANDING_RTOL) -> str | None:
    """``loads``: (stage, P, Q) of every step, in our convention.  None when the last stage-1 P
    and the last stage-2 Q are within ``rtol`` of the case's P and Q0, else why not."""
    s1 = [(P, Q) for st, P, Q in loads if st == 1]
    s2 = [(P, Q) for st, P, Q in loads if st == 2]
    if not s1:
        return f"{code}: the run has no stage-1 step"
    P0 = s1[-1][0]
    if abs(P0 - case.P) > rtol * case.P:
        return (f"{code}: P = {P0:.6g} at the end of stage 1 misses the case's P = "
                f"{case.P:.6g} by {abs(P0 / case.P - 1):.2%} (allowed {rtol:.1%})")
    Q0 = s2[-1][1] if s2 else 0.0
    if case.Q0 > 0 and abs(Q0 - case.Q0) > rtol * case.Q0:
        return (f"{code}: Q0 = {Q0:.6g} at the end of stage 2 misses the case's Q0 = "
                f"{case.Q0:.6g} by {abs(Q0 / case.Q0 - 1):.2%} (allowed {rtol:.1%})")
    return None


def check_landed(code: str, case, loads: Sequence[tuple[int, float, float]]) -> None:
    """Raise DriverError with :func:`landing_error`'s reason when the run missed the loads."""
    why = landing_error(code, case, loads)
    if why:
        raise DriverError(why)


def parser(prog: str, description: str) -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog=prog, description=description)
    ap.add_argument("case", help="library case name or case file (.toml)")
    ap.add_argument("out", help="output folder (the exchange-format result is written there)")
    ap.add_argument("--level", type=int, default=0, help="mesh level (0: coarsest)")
    ap.add_argument("--force", action="store_true",
                    help="write into a folder that holds other files (they are kept; only the "
                         "previous run's files are replaced)")
    return ap


def print_verdicts(case: str, manifests: Sequence[Path]) -> bool:
    """Verify each result and print its checks; True when the first one agrees."""
    from compare.testing import format_checks
    from compare.verify import verify

    results = [verify(case, m) for m in manifests]
    for res in results:
        print(format_checks(res.checks, f"{res.case.name}: {res.source}, {res.fem.n_dofs} dofs, "
                            f"{res.timings['external']:.1f} s, P = {res.case.P:.6g}, "
                            f"Q0 = {res.case.Q0:.6g}: "
                            f"{'agrees' if res.passed else 'FAILS'}"))
        for metric, why in res.unavailable.items():
            print(f"  not available: {metric}: {why}")
    return results[0].passed


def run_cli(prog: str, body: Callable[[], bool]) -> int:
    """Run ``body`` (returns whether the code agrees); errors -> one line on stderr, exit 2."""
    try:
        return 0 if body() else 1
    except (CaseError, RuntimeError, OSError, ValueError) as exc:
        msg = " ".join(str(exc).split()) or type(exc).__name__
        print(f"{prog}: error: {msg}", file=sys.stderr)
        return 2


def write_steps(out: Path, head: Sequence[str], x, steps: Sequence[tuple]) -> Path:
    """The exchange format of a driver's run: ``OUT/steps.csv`` (the ``# key = value`` lines
    ``head``, then one row per step) and one ``x,p,q,status`` file per step.  ``steps``:
    (stage, P, Q, M, p, q, status) in the signs ``head`` declares; returns the manifest."""
    out.mkdir(parents=True, exist_ok=True)
    lines = [*head, "step,stage,P,Q,M,file"]
    for k, (stage, P, Q, M, p, q, status) in enumerate(steps):
        name = step_name(k)
        lines.append(f"{k},{stage},{P:.12g},{Q:.12g},{M:.12g},{name}")
        table = ["x,p,q,status"] + [f"{a!r},{b:.10g},{c:.10g},{int(t)}" for a, b, c, t in zip(
            x.tolist(), p.tolist(), q.tolist(), status.tolist(), strict=True)]
        (out / name).write_text("\n".join(table) + "\n")
    (out / MANIFEST).write_text("\n".join(lines) + "\n")
    return out / MANIFEST
