"""Convergence studies: h-refinement, penalty growth and domain size for one case.

The analytic solution is computed once; the FE side is re-run per level.  Observed orders are
least-squares slopes of ``log(error)`` against ``log(parameter)``:

- ``kind="h"``: parameter = finest interface element length ``h``.  The graded far field is
  refined too, otherwise its fixed relative coarseness leaves a level-independent error
  (measured on the tensor mesh: ~0.1 % of the Hertz width, pressure order dropping to ~0.4):
  the ring mesh does it by itself (its rate ``1 + (growth - 1) 2^(-(level+1)/2)``
  falls with the level, fem.mesh.near_growth), the tensor mesh by :func:`refined_growth`
  (growth -> 1).  Expected orders for linear
  (Q4) elements: pressure L2 error ~ h^1 (the penalty error ``p/k_n`` with ``k_n ~ E/h`` is
  O(h), and the sqrt edge behaviour limits the nodal interpolation near the edges to about
  h^1.5), the edge error ~ h^1 or better (edges located inside one element, then extrapolated).
- ``kind="penalty"``: parameter = ``1 / penalty_factor`` (0 for the augmented Lagrangian,
  value ``inf``): the penalty error falls until the discretisation error dominates; the default
  factor 100 is already past that point (Cattaneo, level 1, pressure error 0.0089 / 0.0033 /
  0.0046 / 0.0048 for factors 1 / 10 / 100 / 1000).  The study converges when the FE edges move
  by at most PENALTY_EDGE_SHIFT of the zone width from factor 100 to 1e4 and the augmented
  Lagrangian (the default values).
- ``kind="domain"``: parameter = ``1 / size_factor`` (the finite-body error).  With the default
  half-plane far field (``fem.MeshSpec.boundary``) the results hardly depend on the body size
  (Cattaneo, size factors 6 / 12 / 25: the edges move by 1.2e-6 of the zone width, the errors
  are the mesh's), so the study converges, like a penalty study, when the FE edges move by at
  most DOMAIN_EDGE_SHIFT of the zone width over the size range: the body size is then not what
  limits the edges.  (Judged by the orders of the errors, as it was, it could never converge:
  the errors do not depend on the size.)

Phase: the FE contact edge falls at a different place inside its element at every level, and
the edge error (and the pressure error next to it) swings with that phase, so an h-study on a
smooth-edge case is non-monotone.  ``phase_locked=True`` (``converge --phase-locked``) puts a
mesh node on every analytic contact edge of the full normal load at every level
(``fem.edge_nodes``, as the slow Hertz order test does), which measures the order itself; the
study says which one ran (``phase_locked``, in its verdict line and summary).  Even locked, the
edge error is the sum of terms of opposite sign: on the ring mesh of plain Q1 (growth 1.2,
Hertz) the discretisation widens the zone (order ~2: -1.6e-4, -3.4e-5, -7e-6 of the width at
levels 1-3) and the rings' grading narrows it (order 1, as (rate - 1)**2 with
fem.mesh.near_growth: 1.5e-4, 6.9e-5, 3.5e-5; a quarter with growth 1.1: from the difference of
the runs at growth 1.2 and 1.1, 1.1e-4, 5.2e-5, 2.6e-5, scaled by (rate - 1)**2; it predicted
level 4 within 10 %), so the error falls, crosses zero and rises before it falls at order 1
(3.3e-4, 1.3e-5, 3.5e-5, 2.8e-5, 1.45e-5, 7.4e-6 at levels 0-5; local orders 0.93, 0.97 from
level 3): a crossing, not a floor.  The grading's part is plain Q1's stiffness: with the
incompatible modes of the default elements it is 0.39x as large and the crossing moves to
levels 3-4, below 2e-6 of the width (edge offsets, + where the FE zone is wider, as the study
prints them: +2.77e-3, +7.13e-4, +2.02e-4, +5.56e-5, +1.99e-6, +1.49e-6 at levels -1 to 4;
fem.settings.DEFAULT_LAYOUT).  The study prints the signed edge
offset per run and names a sign change (:meth:`ConvergenceStudy.offset_crossings`).

Honesty: besides the least-squares orders the study reports the local order and the ratio of
successive errors; an error whose local order over the last refinement is below STALL_ORDER
*stalls* and the study does not converge (``verdict()``: ``does not converge: stalls at ...``).
The orders theory expects for the element order are in EXPECTED_ORDERS, with the reason.

Richardson extrapolation of every FE contact edge over the three finest levels (refinement
ratio 2) estimates the mesh-converged edge; its distance to the analytic edge says whether the
FE converges to the analytic answer and not just to something.  It is refused (nan, with the
reason in ``richardson_reason``) for non-monotone sequences and implausible orders
(metrics.RICHARDSON_ORDERS), never replaced by the finest value.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from compare import metrics as mt
from compare.analytic_side import solve_case
from compare.cases import Case, load_case
from compare.errors import CaseError
from compare.run import CaseResult, run_case
from compare.tolerances import EDGE_RTOL

TRACKED = ("edge_error_max", "pressure_l2_error", "stick_edge_error_max", "shear_l2_error")
#: A study "converges" when every tracked error is smaller at the finest run than at the coarsest,
#: the pressure error falls with an observed order above this, and nothing stalls.
MIN_ORDER = 0.5
#: A tracked error *stalls* when its local order over the last refinement is below this (its
#: error fell by less than 2**0.3 = 1.23x when h halved), unless it is below STALL_FLOOR.
STALL_ORDER = 0.3
#: Errors below this (relative) are at the level of rounding and the analytic solver's accuracy;
#: they cannot stall.
STALL_FLOOR = 1e-7
#: A penalty study converges when the FE edges move by at most this fraction of the zone width
#: over the penalty range (factor 100 .. 1e4 .. augmented Lagrangian): the penalty is then not
#: what limits the edges (issue 14: <= 0.03 %).
PENALTY_EDGE_SHIFT = 3e-4
#: A domain study converges when the FE edges move by at most this fraction of the zone width
#: over the size range: the body size is then not what limits the edges (the same resolution
#: as the penalty study's).
DOMAIN_EDGE_SHIFT = PENALTY_EDGE_SHIFT
#: The studies judged by how far the FE edges move over their range: (bound, range's name).
SHIFT_RULES = {"penalty": (PENALTY_EDGE_SHIFT, "penalty"), "domain": (DOMAIN_EDGE_SHIFT,
                                                                      "body-size")}
KINDS = ("h", "penalty", "domain")
#: What theory expects per element order (1: Q4, 2: Q9) for the observed h-orders, and why.
EXPECTED_ORDERS = {
    "pressure_l2_error": {
        1: (1.0, "sqrt edges: p is only in H^(1-eps), the element holding an edge alone gives an "
                 "O(h) L2 error, and the node-wise penalty traction error p/k_n is O(h)"),
        2: (1.5, "at most 1.5: the sqrt edge caps the L2 error of any element degree")},
    "edge_error_max": {
        1: (1.0, "the discrete contact zone ends within one element: O(h), the estimator "
                 "(sqrt fit) adds O(h^2)"),
        2: (1.0, "as Q4: the edge lies inside one element")},
}
EXPECTED_ORDERS["stick_edge_error_max"] = EXPECTED_ORDERS["edge_error_max"]
EXPECTED_ORDERS["shear_l2_error"] = EXPECTED_ORDERS["pressure_l2_error"]


@dataclass(frozen=True)
class ConvergenceStudy:
    """Errors of one case over a sequence of FE discretisations.

    kind: 'h', 'penalty' or 'domain'; values: level / penalty factor (inf: augmented
    Lagrangian) / size factor per run; parameter: the x of the log-log fit (h, 1/penalty,
    1/size); errors: metric -> values; orders: metric -> least-squares order over all runs;
    local_orders: metric -> order between successive runs; ratios: metric -> e_i / e_(i+1);
    expected: metric -> (order, reason) that theory expects for the element order (h only);
    stall: '' or which errors stopped falling (h and domain); fem_edges: per run the FE edges
    paired with the analytic edges (flattened a1, b1, a2, ...); analytic_edges;
    richardson_edges (nan where refused); richardson_reason ('' or why it was refused);
    richardson_error: max |edge_R - edge_an| / zone width; edge_shift: max |edge - edge of the
    last run| / zone width over the runs (penalty: how far the edges move); converges: see
    MIN_ORDER and STALL_ORDER (penalty: edge_shift <= PENALTY_EDGE_SHIFT); phase_locked: True
    when every run had a mesh node on each analytic edge (FemSettings.edge_nodes).
    """

    case_name: str
    kind: str
    values: tuple
    parameter: tuple
    errors: dict
    orders: dict
    local_orders: dict
    ratios: dict
    expected: dict
    stall: str
    fem_edges: tuple
    analytic_edges: tuple
    richardson_edges: tuple
    richardson_reason: str
    richardson_error: float
    edge_shift: float
    converges: bool
    timings: tuple
    phase_locked: bool = False

    def verdict(self) -> str:
        """One line in words: 'converges' (penalty and domain: with how far the edges move) or
        'does not converge: stalls at ...' / why not."""
        if self.converges and self.kind in SHIFT_RULES:
            bound, what = SHIFT_RULES[self.kind]
            return (f"converges: the FE edges move by {self.edge_shift:.2e} of the zone width "
                    f"over the {what} range (<= {bound:g})")
        if self.converges:
            return "converges"
        return "does not converge: " + self.failure()

    def failure(self) -> str:
        """Why the study does not converge ('' when it does): the stall, the order, or errors
        not smaller at the finest run (one rule, ``_failure``, decides ``converges`` too)."""
        return _failure(self.orders, self.errors, self.stall, self.kind, self.edge_shift)

    def richardson_line(self) -> str:
        """The Richardson estimate in words (h-studies; '' otherwise): the extrapolated edges'
        error relative to the zone width, or why the extrapolation was refused."""
        if self.kind != "h":
            return ""
        if math.isfinite(self.richardson_error):
            within = "within" if self.richardson_error <= EDGE_RTOL else "outside"
            return (f"Richardson-extrapolated edges: error / zone width {self.richardson_error:.3e}"
                    f" ({within} the edge tolerance {EDGE_RTOL:g})")
        return (f"Richardson extrapolation of the edges refused ({self.richardson_reason}), so "
                "the edges are judged by their observed orders only")

    def edge_offsets(self) -> list[float]:
        """Per run the signed edge error of largest size, outward positive (the FE zone wider
        than the analytic one), relative to its zone width."""
        an = np.asarray(self.analytic_edges, float)
        fe = np.asarray(self.fem_edges, float)
        widths = np.repeat(an[1::2] - an[0::2], 2)
        out = np.where(np.arange(an.size) % 2 == 0, an - fe, fe - an) / widths
        return [float(r[np.argmax(np.abs(r))]) for r in out]

    def offset_crossings(self) -> list[tuple]:
        """(value_i, value_i+1) between which the edge offset changes sign: two edge-error
        terms of opposite sign cross there, so the edge error is not monotone (not a floor)."""
        off = self.edge_offsets()
        return [(self.values[i], self.values[i + 1]) for i in range(len(off) - 1)
                if off[i] * off[i + 1] < 0]

    def applies(self, metric: str) -> bool:
        """False for a metric the case does not have (stick and shear of a normal-only case)."""
        return bool(np.any(np.isfinite(self.errors[metric])))

    def summary(self) -> dict:
        return {"case": self.case_name, "kind": self.kind, "values": _clean(self.values),
                "parameter": _clean(self.parameter),
                "errors": {k: _clean(vs) for k, vs in self.errors.items()},
                "orders": {k: _clean(v) for k, v in self.orders.items()},
                "local_orders": {k: _clean(v) for k, v in self.local_orders.items()},
                "ratios": {k: _clean(v) for k, v in self.ratios.items()},
                "expected": {k: {"order": o, "reason": r} for k, (o, r) in self.expected.items()},
                "stall": self.stall, "verdict": self.verdict(),
                "analytic_edges": list(self.analytic_edges),
                "richardson_edges": _clean(self.richardson_edges),
                "richardson_reason": self.richardson_reason,
                "richardson_error": _clean(self.richardson_error),
                "edge_shift": _clean(self.edge_shift),
                "converges": self.converges, "timings": list(self.timings),
                "edge_offsets": _clean(self.edge_offsets()),
                "offset_crossings": [list(c) for c in self.offset_crossings()],
                "phase_locked": self.phase_locked, "phase": phase_text(self.phase_locked)}


def phase_text(locked: bool) -> str:
    """Which refinement ran, in words."""
    if locked:
        return "phase-locked (a mesh node on every analytic contact edge at every level)"
    return "free phase (the edges fall anywhere inside their elements: edge errors oscillate)"


def _clean(v):
    """JSON-ready: non-finite floats become None (lists element-wise)."""
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    return None if isinstance(v, float) and not math.isfinite(v) else v


def _finite_pair(errs: Sequence[float]) -> bool:
    return bool(np.isfinite(errs[0]) and np.isfinite(errs[-1]))


def refined_growth(case: Case, level: int) -> float:
    """Far-field growth ratio at ``level``: the case's own for the ring layout (its rate falls
    with the level by itself), ``1 + (g - 1) 2^(level_case - level)`` (<= 2) for the tensor
    layout."""
    if case.fem.layout == "rings":
        return case.fem.growth
    return min(1.0 + (case.fem.growth - 1.0) * 2.0 ** (case.fem.level - level), 2.0)


def _variants(case: Case, kind: str, values: Sequence) -> list[Case]:
    if kind == "h":
        return [case.with_fem(level=int(v), growth=refined_growth(case, int(v))) for v in values]
    if kind == "penalty":
        return [case.with_fem(augmented=True) if math.isinf(v) else
                case.with_fem(penalty_factor=float(v), augmented=False) for v in values]
    return [case.with_fem(size_factor=v) for v in values]


def _parameter(kind: str, res: CaseResult) -> float:
    if kind == "h":
        return float(res.fem.h_min)
    if kind == "penalty":
        return 0.0 if res.case.fem.augmented else 1.0 / res.case.fem.penalty_factor
    return 1.0 / res.case.fem.size_factor


def paired_edges(res: CaseResult) -> list[float]:
    """The FE contact edges at the end of stage 1, each the one nearest an analytic edge
    (a1, b1, a2, ... in the order of the analytic zones)."""
    fe = list(res.fem.stage(1)[-1].contact_zones)
    lefts, rights = [z[0] for z in fe], [z[1] for z in fe]
    return [e for a, b in res.analytic.normal.zones
            for e in (mt.nearest(lefts, a), mt.nearest(rights, b))]


def _richardson(edges: np.ndarray, kind: str, ratio: float = 2.0) -> tuple[np.ndarray, str]:
    """Per edge the extrapolated value (nan where refused) and the reasons of the refusals
    (``ratio`` nan: the last three runs are not refined by one ratio)."""
    if kind != "h":
        return np.full(edges.shape[1], np.nan), "only for h-refinement"
    if not math.isfinite(ratio):
        return np.full(edges.shape[1], np.nan), ("the last three levels are not evenly spaced "
                                                 "(no one refinement ratio)")
    out = [mt.richardson_check(edges[:, j], ratio) for j in range(edges.shape[1])]
    reasons = sorted({f"edge {j}: {r}" for j, (_, _, r) in enumerate(out) if r})
    return np.array([v for v, _, _ in out]), "; ".join(reasons)


def stall_of(kind: str, values: Sequence, local: dict, errors: dict, label: str = "") -> str:
    """'' or 'stalls at <level>: metric e1 -> e2 (order p), ...' for the last refinement
    (``label``: what the values are, default 'level' / 'size factor' by kind)."""
    if kind != "h" or len(values) < 2:  # penalty and domain studies go by the edges' shift
        return ""
    bad = [f"{m} {errors[m][-2]:.3g} -> {errors[m][-1]:.3g} (order {local[m][-1]:.2f})"
           for m in TRACKED if np.isfinite(local[m][-1]) and local[m][-1] < STALL_ORDER
           and errors[m][-1] > STALL_FLOOR]
    name = label or {"h": "level", "domain": "size factor"}[kind]
    return f"stalls at {name} {values[-1]:g}: " + ", ".join(bad) if bad else ""


def _failure(orders: dict, errors: dict, stall: str, kind: str, shift: float) -> str:
    """'' when the study converges, else why not: penalty and domain studies by how far the FE
    edges move over their range (PENALTY_EDGE_SHIFT, DOMAIN_EDGE_SHIFT); h-studies by the stall
    (STALL_ORDER), the pressure order (MIN_ORDER) and errors that must be smaller at the finest
    run than at the first."""
    if kind in SHIFT_RULES:
        bound, what = SHIFT_RULES[kind]
        return "" if shift <= bound else (
            f"the FE edges move by {shift:.2e} of the zone width over the {what} range "
            f"(> {bound:g})")
    if stall:
        return stall
    order = orders["pressure_l2_error"]
    if not order >= MIN_ORDER:
        return f"pressure L2 order {order:.2f} < {MIN_ORDER}"
    grew = [m for m in TRACKED if _finite_pair(errors[m]) and errors[m][-1] >= errors[m][0]
            and errors[m][-1] > STALL_FLOOR]  # an error exact to STALL_FLOOR is not growing
    return "error not smaller at the finest run: " + ", ".join(grew) if grew else ""


#: What each kind of study refines, for study_values' errors.
_REFINED = {"h": "levels, each finer than the last (increasing integers, e.g. 0 1 2)",
            "penalty": "penalty factors > 0, each stiffer than the last (increasing; inf: "
                       "the augmented Lagrangian, last), e.g. 100 1e4 inf",
            "domain": "size factors >= 2, each larger than the last (increasing), e.g. 6 12 25"}


#: Mesh levels of an h-study when none are given.
DEFAULT_LEVELS = (0, 1, 2)


def study_values(kind: str, levels: Sequence[int] = DEFAULT_LEVELS,
                 values: Sequence[float] | None = None, label: str | None = None) -> list:
    """The runs of a study of ``kind``: ``levels`` for 'h', ``values`` (or their defaults) for
    'penalty' and 'domain'; CaseError unless there are at least two, in refining order (orders,
    the stall and the verdict read the last run as the finest), levels whole numbers.  ``label``:
    how the error names them (e.g. a CLI option; default ``levels=`` / ``values=``)."""
    if kind not in KINDS:
        raise CaseError(f"kind={kind!r} is not allowed: need one of {', '.join(KINDS)}")
    default = (100.0, 1e4, math.inf) if kind == "penalty" else (6.0, 12.0, 25.0)
    vals = list(levels) if kind == "h" else list(default if values is None else values)
    num = np.array(vals, float)
    with np.errstate(invalid="ignore"):  # inf - inf: nan, refused as not increasing
        steps = np.diff(num)
    bad = (num.size < 2 or not np.all(steps > 0)
           or (kind != "penalty" and not np.all(np.isfinite(num)))
           or (kind == "h" and not np.all(num == np.round(num)))
           or (kind == "penalty" and not num[0] > 0))
    if bad:
        given = " ".join(f"{v:g}" for v in num)
        what = f"{label} {given}" if label else \
            f"{'levels' if kind == 'h' else 'values'}={given}"
        raise CaseError(f"{what} is not allowed for "
                        f"{'an' if kind == 'h' else 'a'} {kind}-study: need at least two "
                        f"{_REFINED[kind]}")
    return [int(v) for v in vals] if kind == "h" else [float(v) for v in vals]


def convergence(case: Case | str, levels: Sequence[int] = DEFAULT_LEVELS, kind: str = "h",
                values: Sequence[float] | None = None,
                progress: Callable[[int, int], None] | None = None,
                phase_locked: bool = False) -> ConvergenceStudy:
    """Run a convergence study of ``case``.

    ``kind="h"`` uses ``levels`` (>= 3 for Richardson); ``kind="penalty"`` / ``"domain"`` use
    ``values`` (penalty factors, ``inf`` = augmented Lagrangian / size factors) at the case's
    level.  ``progress(i, n)`` is called after each run.  ``phase_locked``: a mesh node on every
    analytic contact edge in every run (see the module docstring).
    """
    case = load_case(case)
    if phase_locked:
        case = case.with_fem(edge_nodes=True)
    vals = study_values(kind, levels, values)
    variants = _variants(case, kind, vals)
    an = solve_case(case)
    runs = []
    for i, c in enumerate(variants):
        runs.append(run_case(c, analytic=an))
        if progress:
            progress(i + 1, len(vals))
    par = [_parameter(kind, r) for r in runs]
    errors = {m: [float(r.metrics.get(m, np.nan)) for r in runs] for m in TRACKED}
    return assemble(case.name, kind, vals, par, errors, [paired_edges(r) for r in runs],
                    an.normal.zones, case.fem.order,
                    [sum(r.timings.values()) for r in runs], case.fem.edge_nodes,
                    ratio=level_ratio(kind, vals))


def level_ratio(kind: str, values: Sequence) -> float:
    """The refinement ratio of the last three runs of an h-study, 2**step for levels evenly
    spaced by ``step`` (h halves per level), nan otherwise (Richardson needs one ratio); 2 for
    other kinds (unused)."""
    if kind != "h":
        return 2.0
    steps = np.diff(np.asarray(values[-3:], float))
    return float(2.0 ** steps[0]) if steps.size and np.all(steps == steps[0]) else math.nan


def assemble(name: str, kind: str, values: Sequence, parameter: Sequence[float], errors: dict,
             fem_edges: Sequence[Sequence[float]], zones: Sequence[tuple[float, float]],
             order: int = 1, timings: Sequence[float] = (),
             phase_locked: bool = False, label: str = "",
             ratio: float = 2.0) -> ConvergenceStudy:
    """The study from its runs' errors (metric -> list) and FE edges (per run, paired with the
    analytic ``zones`` as a1, b1, a2, ...): orders, ratios, stall, Richardson, verdict.
    ``label`` names the values in the stall message (:func:`stall_of`); ``ratio`` is the
    refinement ratio of Richardson's extrapolation."""
    orders = {m: mt.observed_order(parameter, e) for m, e in errors.items()}
    local = {m: mt.local_orders(parameter, e) for m, e in errors.items()}
    edges = np.asarray(fem_edges, float)
    an_edges = np.array([e for z in zones for e in z])
    widths = np.repeat([b - a for a, b in zones], 2)
    rich, reason = _richardson(edges, kind, ratio)
    rich_err = float(np.max(np.abs(rich - an_edges) / widths)) if np.all(np.isfinite(rich)) \
        else float("nan")
    stall = stall_of(kind, values, local, errors, label)
    shift = float(np.max(np.abs(edges - edges[-1]) / widths))
    expected = {m: EXPECTED_ORDERS[m][order] for m in TRACKED} if kind == "h" else {}
    return ConvergenceStudy(
        name, kind, tuple(values), tuple(parameter), errors, orders, local,
        {m: mt.error_ratios(e) for m, e in errors.items()}, expected, stall,
        tuple(map(tuple, edges)), tuple(an_edges), tuple(rich), reason, rich_err,
        shift, not _failure(orders, errors, stall, kind, shift), tuple(timings), phase_locked)


def convergence_text(st: ConvergenceStudy) -> str:
    """Plain-text table of a study: errors, ratios of successive errors, local and least-squares
    orders, the expected order and why, the verdict and the Richardson estimate."""
    head = {"h": "level", "penalty": "penalty", "domain": "size"}[st.kind]
    lines = [f"{st.case_name}: {st.kind}-convergence, {st.verdict()}",
             f"  refinement: {phase_text(st.phase_locked)}",
             f"  {head:<22} " + " ".join(f"{v:>10g}" for v in st.values)]
    for m, vals in st.errors.items():
        if not st.applies(m):
            continue
        lines.append(f"  {m:<22} " + " ".join(f"{v:10.3e}" for v in vals)
                     + f"   order {st.orders[m]:.2f} (last {st.local_orders[m][-1]:.2f})")
        lines.append(f"  {'  ratio e_i/e_i+1':<22} " + " " * 11
                     + " ".join(f"{r:10.2f}" for r in st.ratios[m]))
    for m, (order, why) in st.expected.items():
        if st.applies(m):
            lines.append(f"  expected {m}: ~{order:g} ({why})")
    if st.kind == "h":
        lines.append(f"  {st.richardson_line()}")
    lines.append(f"  FE edges move by {st.edge_shift:.3e} of the zone width over the runs")
    lines.append(f"  {'edge offset (wider +)':<22} "
                 + " ".join(f"{v:+10.3e}" for v in st.edge_offsets()))
    for a, b in st.offset_crossings():
        lines.append(f"  the edge offset changes sign from {head} {a:g} to {b:g}: two edge-error "
                     "terms of opposite sign cross there (non-monotone, not a floor)")
    return "\n".join(lines)
