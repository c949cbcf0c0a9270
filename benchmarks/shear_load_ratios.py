"""The shear metric of our own FE across load ratios and levels (issue 25, item 6).

The library case ``cattaneo`` (Hertz cylinder, Cattaneo-Mindlin stages 2-3) with its amplitude
Q0 set to r mu P for r in RATIOS, run at every level of LEVELS as ``multicontact run --level``
runs it (the case's far-field growth), the analytic side solved once per ratio.  Per (ratio,
level) the table gives the elements across the contact zone and the shear error at every
sampled Q (stage 2: Q/Q0 = 0.5, 0.75, 1; stage 3: 0, -0.5, -1) in two normalisations:

- ``rel``: the library metric ``shear_l2_error``, ||q_fe - q_an|| / max(||q_an||,
  SHEAR_FLOOR mu ||p||) (compare.metrics.SHEAR_FLOOR);
- ``abs``: ||q_fe - q_an|| / (mu ||p||), the error in units of the friction bound.

and ``||q_an|| / (mu ||p||)``, which says where the relative form divides by a small number.
The worst sample per run is the ``shear_l2_error`` the tolerance (compare.tolerances.SHEAR_RTOL)
bounds.  Re-run it when the FE mesh changes; the measured table is in docs/conventions.md.

With ``--library`` it runs every library case with Q0 > 0 at its default level instead (the
smallest zone's elements in the third column).

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/shear_load_ratios.py [--ratios ...]
     [--levels 0 1 2 3] [--json out.json]
     OPENBLAS_NUM_THREADS=1 python benchmarks/shear_load_ratios.py --library
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from compare import metrics as mt
from compare.analytic_side import solve_case
from compare.cases import Case, case_from_dict, list_cases, load_case
from compare.fem_side import kinks
from compare.run import CaseResult, run_case

RATIOS = (0.2, 0.4, 0.5, 0.6, 0.8, 0.95)
LEVELS = (0, 1, 2, 3)


def at_ratio(base: Case, ratio: float) -> Case:
    """``base`` with Q0 = ratio * mu * P (the same sample fractions of Q0)."""
    doc = base.to_dict()
    doc["load"]["Q0"] = ratio * base.mu * base.P
    return case_from_dict(doc, name=base.name, src=f"{base.name} at Q0/(mu P) = {ratio:g}")


def sample_rows(res: CaseResult) -> list[dict]:
    """Per sampled Q: stage, Q/Q0, relative (library) and absolute shear error, ||q|| / mu||p||."""
    ns, case = res.analytic.normal, res.case
    x0 = res.fem.stage(1)[-1].interface.x
    keep = mt.regular_mask(x0, ns.zones, mt.singular_points(ns.zones, ns.singular, kinks(case)))
    rows = []
    for st in res.analytic.samples:
        it = res.fem.at(st.stage, Q=st.Q).interface
        x, w = it.x[keep], it.w[keep]
        q_an = np.asarray(st.shear(x), float)
        bound = case.mu * mt.l2(ns.pressure(x), w)
        err = mt.l2(it.q[keep] - q_an, w)
        rows.append({"stage": st.stage, "Q_over_Q0": st.Q / case.Q0,
                     "rel": err / max(mt.l2(q_an, w), mt.SHEAR_FLOOR * bound),
                     "abs": err / bound, "q_norm": mt.l2(q_an, w) / bound})
    return rows


def measure(ratio: float, levels: tuple[int, ...], base: Case) -> list[dict]:
    case = at_ratio(base, ratio)
    an = solve_case(case)
    width = float(np.diff(an.normal.zones[0])[0])
    out = []
    for level in levels:
        t0 = time.perf_counter()
        res = run_case(case.with_fem(level=level), analytic=an)
        rows = sample_rows(res)
        worst = max(rows, key=lambda r: r["rel"])
        out.append({"ratio": ratio, "level": level, "elements": width / res.fem.h_min,
                    "shear_l2_error": res.metrics["shear_l2_error"],
                    "worst_sample": [worst["stage"], worst["Q_over_Q0"]],
                    "abs_max": max(r["abs"] for r in rows),
                    "failures": [c.name for c in res.failures()], "samples": rows,
                    "seconds": time.perf_counter() - t0})
        print_row(out[-1])
    return out


def library(levels: tuple[int, ...] | None) -> list[dict]:
    """Every library case with Q0 > 0 at its default level (or at ``levels``)."""
    out = []
    for name in list_cases():
        case = load_case(name)
        if case.Q0 == 0:
            continue
        an = solve_case(case)
        width = min(b - a for a, b in an.normal.zones)
        for level in levels or (case.fem.level,):
            t0 = time.perf_counter()
            res = run_case(case.with_fem(level=level), analytic=an)
            rows = sample_rows(res)
            out.append({"case": name, "ratio": case.Q0 / (case.mu * case.P), "level": level,
                        "elements": width / res.fem.h_min,
                        "shear_l2_error": res.metrics["shear_l2_error"],
                        "abs_max": max(r["abs"] for r in rows),
                        "failures": [c.name for c in res.failures()], "samples": rows,
                        "seconds": time.perf_counter() - t0})
            print(f"{name:<24}", end=" ")
            print_row(out[-1])
    return out


def print_row(r: dict) -> None:
    cells = " ".join(f"{s['rel'] * 100:6.2f}" for s in r["samples"])
    absc = " ".join(f"{s['abs'] * 100:6.2f}" for s in r["samples"])
    qn = " ".join(f"{s['q_norm']:5.2f}" for s in r["samples"])
    print(f"{r['ratio']:5.2f} {r['level']:3d} {r['elements']:7.0f} | "
          f"{r['shear_l2_error'] * 100:6.2f} | rel % {cells} | abs % {absc} | "
          f"||q||/mu||p|| {qn} | fails {','.join(r['failures']) or '-'} "
          f"({r['seconds']:.0f} s)", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", default="cattaneo")
    ap.add_argument("--ratios", type=float, nargs="+", default=list(RATIOS))
    ap.add_argument("--levels", type=int, nargs="+", default=list(LEVELS))
    ap.add_argument("--json", help="also write the rows to this JSON file")
    ap.add_argument("--library", action="store_true",
                    help="every library case with Q0 > 0 at its default level (--levels: "
                         "at these levels) instead of the load-ratio study")
    args = ap.parse_args()
    if args.library:
        levels = None if args.levels == list(LEVELS) else tuple(args.levels)
        rows = library(levels)
        if args.json:
            with open(args.json, "w") as f:
                json.dump(rows, f, indent=1)
        return
    base = load_case(args.case)
    print(f"{base.name}: shear error (%) per sample, stage 2 Q/Q0 = "
          f"{', '.join(f'{q / base.Q0:g}' for q in base.stage2)}, stage 3 Q/Q0 = "
          f"{', '.join(f'{q / base.Q0:g}' for q in base.stage3)}; default level {base.fem.level}")
    print("ratio lvl elems/zone | metric | ...")
    rows = [r for ratio in args.ratios for r in measure(ratio, tuple(args.levels), base)]
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
