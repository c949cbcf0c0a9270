"""Convergence studies: h-refinement, penalty growth and domain size for one case.

The analytic solution is computed once; the FE side is re-run per level.  Observed orders are
least-squares slopes of ``log(error)`` against ``log(parameter)``:

- ``kind="h"``: parameter = finest interface element length ``h``.  The refinement is uniform:
  the graded far field is refined too (:func:`refined_growth`, growth -> 1), otherwise its fixed
  relative coarseness leaves a level-independent error (measured: ~0.1 % of the Hertz width,
  pressure order dropping to ~0.4).  Expected orders for linear
  (Q4) elements: pressure L2 error ~ h^1 (the penalty error ``p/k_n`` with ``k_n ~ E/h`` is
  O(h), and the sqrt edge behaviour limits the nodal interpolation near the edges to about
  h^1.5), the edge error ~ h^1 or better (edges located inside one element, then extrapolated).
- ``kind="penalty"``: parameter = ``1 / penalty_factor``: the penalty error falls until the
  discretisation error dominates; the default factor 100 is already past that point (Cattaneo,
  level 1, pressure error 0.0089 / 0.0033 / 0.0046 / 0.0048 for factors 1 / 10 / 100 / 1000).
- ``kind="domain"``: parameter = ``1 / size_factor`` (finite-body error of the half-plane
  idealisation; measured order ~1.1-1.3 for Cattaneo, size factors 4 / 8 / 25).

Richardson extrapolation of every FE contact edge over the three finest levels (refinement
ratio 2) estimates the mesh-converged edge; its distance to the analytic edge says whether the
FE converges to the analytic answer and not just to something.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from compare import metrics as mt
from compare.analytic_side import solve_case
from compare.cases import Case, load_case
from compare.run import CaseResult, run_case

TRACKED = ("edge_error_max", "pressure_l2_error", "stick_edge_error_max", "shear_l2_error")
#: A study "converges" when every tracked error is smaller at the finest run than at the coarsest
#: and the pressure error falls with an observed order above this.  (The edge error alone is no
#: criterion: at the default levels it is already ~1e-3 of the zone width and not monotone.)
MIN_ORDER = 0.5
KINDS = ("h", "penalty", "domain")


@dataclass(frozen=True)
class ConvergenceStudy:
    """Errors of one case over a sequence of FE discretisations.

    kind: 'h', 'penalty' or 'domain'; values: level / penalty factor / size factor per run;
    parameter: the x of the log-log fit (h, 1/penalty, 1/size); errors: metric -> values;
    orders: metric -> observed order; fem_edges: per run the FE edges paired with the analytic
    edges (flattened a1, b1, a2, ...); analytic_edges; richardson_edges (nan if < 3 runs);
    richardson_error: max |edge_R - edge_an| / zone width; converges: see MIN_ORDER.
    """

    case_name: str
    kind: str
    values: tuple
    parameter: tuple
    errors: dict
    orders: dict
    fem_edges: tuple
    analytic_edges: tuple
    richardson_edges: tuple
    richardson_error: float
    converges: bool
    timings: tuple

    def summary(self) -> dict:
        def clean(v):
            return None if isinstance(v, float) and not math.isfinite(v) else v

        return {"case": self.case_name, "kind": self.kind, "values": list(self.values),
                "parameter": list(self.parameter),
                "errors": {k: [clean(v) for v in vs] for k, vs in self.errors.items()},
                "orders": {k: clean(v) for k, v in self.orders.items()},
                "analytic_edges": list(self.analytic_edges),
                "richardson_edges": [clean(v) for v in self.richardson_edges],
                "richardson_error": clean(self.richardson_error),
                "converges": self.converges, "timings": list(self.timings)}


def refined_growth(case: Case, level: int) -> float:
    """Far-field growth ratio at ``level``: ``1 + (g - 1) 2^(level_case - level)`` (<= 2)."""
    return min(1.0 + (case.fem.growth - 1.0) * 2.0 ** (case.fem.level - level), 2.0)


def _variants(case: Case, kind: str, values: Sequence) -> list[Case]:
    if kind == "h":
        return [case.with_fem(level=int(v), growth=refined_growth(case, int(v))) for v in values]
    key = {"penalty": "penalty_factor", "domain": "size_factor"}[kind]
    return [case.with_fem(**{key: v}) for v in values]


def _parameter(kind: str, res: CaseResult) -> float:
    if kind == "h":
        return float(res.fem.h_min)
    if kind == "penalty":
        return 1.0 / res.case.fem.penalty_factor
    return 1.0 / res.case.fem.size_factor


def _paired_edges(res: CaseResult) -> list[float]:
    fe = list(res.fem.stage(1)[-1].contact_zones)
    lefts, rights = [z[0] for z in fe], [z[1] for z in fe]
    return [e for a, b in res.analytic.normal.zones
            for e in (mt.nearest(lefts, a), mt.nearest(rights, b))]


def _richardson(edges: np.ndarray, kind: str) -> np.ndarray:
    if kind != "h" or edges.shape[0] < 3:
        return np.full(edges.shape[1], np.nan)
    return np.array([mt.richardson(edges[:, j])[0] for j in range(edges.shape[1])])


def convergence(case: Case | str, levels: Sequence[int] = (0, 1, 2), kind: str = "h",
                values: Sequence[float] | None = None,
                progress: Callable[[int, int], None] | None = None) -> ConvergenceStudy:
    """Run a convergence study of ``case``.

    ``kind="h"`` uses ``levels`` (>= 3 for Richardson); ``kind="penalty"`` / ``"domain"`` use
    ``values`` (penalty factors / size factors) at the case's level.  ``progress(i, n)`` is
    called after each run.
    """
    case = load_case(case)
    if kind not in KINDS:
        from compare.errors import CaseError

        raise CaseError(f"kind={kind!r} is not allowed: need one of {', '.join(KINDS)}")
    vals = list(levels) if kind == "h" else list(values or
                                                  ((25.0, 100.0, 400.0) if kind == "penalty"
                                                   else (6.0, 12.0, 25.0)))
    an = solve_case(case)
    runs = []
    for i, c in enumerate(_variants(case, kind, vals)):
        runs.append(run_case(c, analytic=an))
        if progress:
            progress(i + 1, len(vals))
    par = [_parameter(kind, r) for r in runs]
    errors = {m: [float(r.metrics.get(m, np.nan)) for r in runs] for m in TRACKED}
    orders = {m: mt.observed_order(par, e) for m, e in errors.items()}
    edges = np.array([_paired_edges(r) for r in runs])
    an_edges = np.array([e for z in an.normal.zones for e in z])
    widths = np.repeat([b - a for a, b in an.normal.zones], 2)
    rich = _richardson(edges, kind)
    rich_err = float(np.max(np.abs(rich - an_edges) / widths)) if np.all(np.isfinite(rich)) \
        else float("nan")
    finite = [m for m in TRACKED if np.isfinite(errors[m][0]) and np.isfinite(errors[m][-1])]
    conv = bool(orders["pressure_l2_error"] >= MIN_ORDER) and all(
        errors[m][-1] < errors[m][0] for m in finite)
    return ConvergenceStudy(case.name, kind, tuple(vals), tuple(par), errors, orders,
                            tuple(map(tuple, edges)), tuple(an_edges), tuple(rich), rich_err,
                            conv, tuple(sum(r.timings.values()) for r in runs))
