"""Bit-for-bit fingerprint of the analytic check cases and the FE library.

A refactor that must not change a single number runs this before and after and compares:

    python benchmarks/fingerprint.py --out before.json          # on the old tree
    python benchmarks/fingerprint.py --check before.json        # on the new tree: exit 1 on change

Each entry is the sha256 of the exact bytes (``float.hex``) of a result:

- ``analytic/<case>``: every library case's normal solution (zones, edge flags, zone loads,
  P, M, theta, residuals and self-check figures, pressure on 129 points per zone) and its
  stick states (stick zones, shear on the same points);
- ``audit/<seed>``: the normal (and, in stick modes, stick) solution of the randomised audit
  cases (``compare.audit.cases``) of seeds ``0 .. --seeds - 1`` and of every regression seed;
  a refused case fingerprints its error message;
- ``fem/<case>``: the FE history of every library case (each increment's interface arrays,
  zones, plate, reactions, residuals, iterations) and the comparison's metrics, zones and
  samples (timings excluded).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import hashlib  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
from collections.abc import Callable, Iterator  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

# fem.linsolve loads CHOLMOD with the CPU's BLAS kernels: before scipy.optimize (tabulated
# profiles) does, as in the command line (compare imports it first), so that the FE fingerprints
# are its numbers.
import fem.linsolve  # noqa: E402, F401

# isort: split
import analytic  # noqa: E402
from compare.analytic_side import solve_case  # noqa: E402
from compare.audit.cases import make_case  # noqa: E402
from compare.cases import list_cases, load_case  # noqa: E402
from compare.run import run_case  # noqa: E402

REGRESSIONS = Path(__file__).resolve().parents[1] / "tests/verification/audit_regressions.json"
POINTS = 129  # pressure / shear samples per contact zone (ends included)
SKIP_KEYS = {"timings", "profile", "_system", "fields", "shear", "backend", "vtk", "case",
             "diagnostics"}  # diagnostics: counts of solver events, not numbers of a result


def _leaves(obj) -> Iterator[str]:
    """Exact text of every numeric / string leaf of a result, in a fixed order."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        for f in dataclasses.fields(obj):
            if f.name not in SKIP_KEYS:
                yield f.name
                yield from _leaves(getattr(obj, f.name))
    elif isinstance(obj, dict):
        for k in sorted(obj, key=str):
            if k not in SKIP_KEYS:
                yield str(k)
                yield from _leaves(obj[k])
    elif isinstance(obj, list | tuple):
        yield f"[{len(obj)}"
        for v in obj:
            yield from _leaves(v)
    elif isinstance(obj, np.ndarray):
        yield f"{obj.dtype}{obj.shape}"
        yield from (_leaf(v) for v in np.asarray(obj, dtype=float).ravel())
    else:
        yield _leaf(obj)


def _leaf(v) -> str:
    if isinstance(v, bool | np.bool_) or v is None or isinstance(v, str):
        return repr(v)
    if isinstance(v, int | np.integer):
        return str(int(v))
    return float(v).hex()


def _digest(*parts) -> str:
    h = hashlib.sha256()
    for part in parts:
        for s in _leaves(part):
            h.update(s.encode())
            h.update(b"\0")
    return h.hexdigest()


def _zone_points(zones) -> np.ndarray:
    return np.concatenate([np.linspace(a, b, POINTS) for a, b in zones])


def _normal_digest(sol) -> list:
    x = _zone_points(sol.zones)
    return [sol, sol.pressure(x)]


def _shear(fn: Callable, x: np.ndarray) -> np.ndarray:
    return np.asarray(fn(x), dtype=float)


def analytic_case(name: str) -> str:
    res = solve_case(load_case(name))
    x = _zone_points(res.normal.zones)
    sticks = [(s, _shear(s.shear, x)) for s in res.samples]
    return _digest(_normal_digest(res.normal), sticks)


def audit_case(seed: int) -> str:
    case = make_case(seed)
    try:
        sol = analytic.solve_normal(case.profile, case.P, case.A, case.M)
        parts = _normal_digest(sol)
        if case.mode.startswith("stick"):
            st = analytic.solve_stick(sol, case.mu, case.Q, case.Q0, allow_full_slip=True)
            parts.append([st, _shear(st.shear, _zone_points(sol.zones))])
    except Exception as err:  # a refusal is a result too: its message must not change
        parts = [f"{type(err).__name__}: {err}"]
    return _digest(parts)


def fem_case(name: str) -> str:
    res = run_case(name)
    return _digest(res.fem, res.metrics, res.zones, res.samples)


def regression_seeds() -> list[int]:
    return [int(e["seed"]) for e in json.loads(REGRESSIONS.read_text())["seeds"]]


def fingerprint(seeds: int, with_fem: bool, report=print) -> dict[str, str]:
    out: dict[str, str] = {}
    jobs = [(f"analytic/{n}", analytic_case, n) for n in list_cases()]
    audit_seeds = sorted(set(range(seeds)) | set(regression_seeds()))
    jobs += [(f"audit/{s}", audit_case, s) for s in audit_seeds]
    if with_fem:
        jobs += [(f"fem/{n}", fem_case, n) for n in list_cases()]
    for key, fn, arg in jobs:
        out[key] = fn(arg)
        report(f"{key} {out[key][:16]}")
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100, help="audit seeds 0..N-1 (default 100)")
    parser.add_argument("--no-fem", action="store_true", help="skip the FE library")
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--out", type=Path, help="write the fingerprint (JSON) here")
    group.add_argument("--check", type=Path, help="compare with a fingerprint written by --out")
    args = parser.parse_args(argv)
    quiet = lambda *_: None  # noqa: E731
    got = fingerprint(args.seeds, not args.no_fem, report=quiet if args.check else print)
    if args.out:
        args.out.write_text(json.dumps(got, indent=1) + "\n")
        print(f"{len(got)} fingerprints written to {args.out}")
        return 0
    want = json.loads(args.check.read_text())
    changed = sorted(k for k in got if k in want and want[k] != got[k])
    missing = sorted(set(want) - set(got))
    for k in changed:
        print(f"CHANGED {k}")
    for k in missing:
        print(f"MISSING {k}")
    same = len(got) - len(changed)
    print(f"{same} of {len(got)} fingerprints identical, {len(changed)} changed, "
          f"{len(missing)} missing")
    return 1 if changed or missing else 0


if __name__ == "__main__":
    sys.exit(main())
