"""The exchange format's data model: conventions, raw step tables, conversion to our convention.

A result is a sequence of load steps.  Each step carries its stage (1, 2, 3), the loads P, Q
(and M or theta) and the interface nodal table ``x, p, q`` (optional ``status, w, slip, gap,
ux``).  The file readers (:mod:`compare.external.csvio`, :mod:`compare.external.vtkio`) build
:class:`RawStep` tables in the file's own units and signs; :func:`to_history` converts them with
the :class:`Conventions` into an FE-like :class:`fem.FemHistory` in our convention (p >= 0
compressive, q on body 1 in the direction of Q, x in the case's frame, theta with the gap in
contact h0(x) - theta x).  Every problem raises :class:`compare.errors.CaseError` naming the
file, the line or step and what is allowed.  The full description is ``docs/external.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

import fem
from compare.errors import CaseError
from fem.results import zones_with_uncertainty

#: Columns every step table must have, and the optional ones (see docs/external.md).
REQUIRED_COLUMNS = ("x", "p", "q")
OPTIONAL_COLUMNS = ("status", "w", "slip", "gap", "ux")
#: Without a status column a node is open where p <= 0, slip where its shear reaches the cone
#: (:func:`derived_status`) and stick otherwise.  The cone's slack: STATUS_EPS of mu p at the
#: node (Kratos 10.3, ALM mortar, cattaneo: |q| / mu p >= 1 - 2e-5 on its slip nodes and <= 0.985
#: on its stick nodes) ...
STATUS_EPS = 1e-3
#: ... or, in stages 2 and 3, SLIP_SLACK of mu max p, whichever is larger: a regularised
#: friction law or a file of 3 significant digits leaves a slip node's shear up to a few 1e-3
#: of mu p below the cone, which STATUS_EPS alone took for stick (the whole contact zone then
#: a stick zone: 16-19 elements off on cattaneo level 1).  A true stick node that close to the
#: cone lies within (SLIP_SLACK a / c)^2 / 2 of c of its stick edge (Cattaneo: mu p - |q| =
#: mu p0 (c/a) sqrt(1 - x^2/c^2)): 5e-3 c for c = a/10.
SLIP_SLACK = 1e-2
#: Per step, sum p w must give P within this fraction of P, sum q w must give Q within this
#: fraction of mu P (q is bounded by mu p) and, where M is given, sum x p w must give M within
#: this fraction of P times the largest |x| in contact: measured on Kratos 10.3 (cattaneo level
#: 0, default tributary widths) 0.12 % of P, 0.13 % of mu P and 0.015 % of P max|x|, < 1e-9 on
#: our own FE export; a sign, unit or width mistake is off by O(1) or a power of ten.
CONSISTENCY_RTOL = 0.01
#: Within a stage the load moves one way (P up in stage 1, Q up in stage 2, down in stage 3); a
#: step whose load goes back by more than this fraction of P0 is out of order (a code's reaction
#: noise on a monotone path is far smaller: Kratos 10.3 lands within 1e-5 of P0).
ORDER_RTOL = 1e-3
#: Negative pressure down to this fraction of the step's largest p (a penalty code's open or
#: barely touching nodes) is clipped to 0 with a note; a lower one is an input error.  Kratos
#: 10.3 writes none; a chosen bound (no penalty code measured yet), 1 % of p_max moves sum p w by
#: far less than CONSISTENCY_RTOL.
NEGATIVE_P_RTOL = 0.01
#: Status words accepted besides the codes 0 / 1 / 2.
STATUS_WORDS = {"open": 0, "stick": 1, "slip": 2}
#: Two steps list the same interface nodes when their x differ by less than this fraction of
#: the interface length (rounding of a text format).
SAME_X_RTOL = 1e-9


@dataclass(frozen=True)
class Conventions:
    """How the files differ from our convention (all explicit, defaults = our convention).

    pressure_sign: +1 if the file's p > 0 is compressive, -1 if compressive p is negative.
    shear_sign: +1 if the file's q and Q act on body 1 (upper, profiled) in +x, -1 if they act
    in -x (e.g. the shear on body 2).  theta_sign: +1 if theta > 0 lowers the gap on the right
    (our h0(x) - theta x), -1 for the opposite (counter-clockwise) sense.
    x: "reference" (undeformed coordinates) or "deformed" (x minus the column ``ux`` is used).
    x_origin: the file's x of the case's origin x = 0 (file units).
    length_scale, stress_scale: case units per file unit for lengths and for stresses; forces
    per unit width scale with their product, moments with stress_scale * length_scale**2.
    values: "traction" (p, q are tractions) or "force" (p, q are nodal forces per unit width,
    divided by the tributary length w).
    """

    pressure_sign: int = 1
    shear_sign: int = 1
    theta_sign: int = 1
    x: str = "reference"
    x_origin: float = 0.0
    length_scale: float = 1.0
    stress_scale: float = 1.0
    values: str = "traction"

    CHOICES = {"pressure_sign": (1, -1), "shear_sign": (1, -1), "theta_sign": (1, -1),
               "x": ("reference", "deformed"), "values": ("traction", "force")}


@dataclass(frozen=True)
class Meta:
    """Information about the run: code name, dofs, element order, wall time (0 / '' unknown)."""

    code: str = "external code"
    case: str = ""
    dofs: int = 0
    order: int = 0
    seconds: float = 0.0


#: Header keys of the meta data and their types.
META_KEYS = {"code": str, "case": str, "dofs": int, "order": int, "seconds": float}


@dataclass(frozen=True)
class RawStep:
    """One load step as read (file units and signs); ``where`` names it in error messages;
    ``columns``: name -> array (``status`` may be absent: derived, :func:`derived_status`)."""

    where: str
    stage: int
    P: float
    Q: float
    M: float
    theta: float
    columns: dict


def parse_header(items: dict[str, str], where: str, lines: dict | None = None
                 ) -> tuple[Conventions, Meta]:
    """Conventions and meta data from ``key = value`` header items (unknown keys: error);
    ``lines``: key -> where the item was given (file and line), else ``where``."""
    conv_types = {f.name: type(f.default) for f in fields(Conventions)}
    allowed = sorted(set(conv_types) | set(META_KEYS))
    conv, meta = {}, {}
    for key, text in items.items():
        at = (lines or {}).get(key, where)
        if key in conv_types:
            conv[key] = _typed(text, conv_types[key], key, at)
        elif key in META_KEYS:
            meta[key] = _typed(text, META_KEYS[key], key, at)
        else:
            raise CaseError(f"{at}: unknown header key '{key}'; allowed: {', '.join(allowed)}")
    return check_conventions(Conventions(**conv), where, lines), Meta(**meta)


def _typed(text: str, typ: type, key: str, where: str):
    try:
        value = typ(text)
    except ValueError:
        raise CaseError(f"{where}: header '{key} = {text}' must be {typ.__name__}") from None
    if typ is float and not math.isfinite(value):
        raise CaseError(f"{where}: header '{key} = {text}' must be a finite number")
    return value


def check_conventions(conv: Conventions, where: str, lines: dict | None = None) -> Conventions:
    """Reject values outside :attr:`Conventions.CHOICES` and non-positive scales (``lines``:
    key -> where it was given, as :func:`parse_header`)."""
    for key, allowed in Conventions.CHOICES.items():
        if getattr(conv, key) not in allowed:
            raise CaseError(f"{(lines or {}).get(key, where)}: {key} = {getattr(conv, key)!r} "
                            f"is not allowed; allowed: {', '.join(map(str, allowed))}")
    for key in ("length_scale", "stress_scale"):
        if not getattr(conv, key) > 0:
            raise CaseError(f"{(lines or {}).get(key, where)}: {key} = "
                            f"{getattr(conv, key)!r} must be > 0")
    return conv


# ---------------------------------------------------------------------------------------------
# one step table: strict checks, conversion
# ---------------------------------------------------------------------------------------------
def status_codes(values: list[str], where: str, first_line: int) -> np.ndarray:
    """Status column as codes 0 open / 1 stick / 2 slip (also the words open, stick, slip)."""
    out = np.empty(len(values), np.int8)
    for i, v in enumerate(values):
        word = v.strip().lower()
        code = STATUS_WORDS.get(word)
        if code is None and word in ("0", "1", "2", "0.0", "1.0", "2.0"):
            code = int(float(word))
        if code is None:
            raise CaseError(f"{where}, line {first_line + i}: status '{v}' is not allowed; "
                            "allowed: 0 open, 1 stick, 2 slip (or the words)")
        out[i] = code
    return out


def check_columns(names: list[str], where: str, conv: Conventions) -> None:
    """All required columns present (``w`` with values = force, ``ux`` with x = deformed)."""
    need = list(REQUIRED_COLUMNS) + (["w"] if conv.values == "force" else [])
    need += ["ux"] if conv.x == "deformed" else []
    known = set(REQUIRED_COLUMNS) | set(OPTIONAL_COLUMNS)
    for col in need:
        if col not in names:
            raise CaseError(f"{where}: missing column '{col}'; required: {', '.join(need)} "
                            f"(optional: {', '.join(OPTIONAL_COLUMNS)}); found: {', '.join(names)}")
    extra = [n for n in names if n not in known]
    if extra:
        raise CaseError(f"{where}: unknown column '{extra[0]}'; allowed: "
                        f"{', '.join(REQUIRED_COLUMNS + OPTIONAL_COLUMNS)}")


def tributary(x: np.ndarray) -> np.ndarray:
    """Tributary lengths of nodes on a line: half of each adjacent segment."""
    seg = np.diff(x)
    return 0.5 * (np.r_[seg, 0.0] + np.r_[0.0, seg])


def convert(raw: RawStep, conv: Conventions) -> dict:
    """Nodal arrays of one step in our convention and the case's units."""
    c, L, S = raw.columns, conv.length_scale, conv.stress_scale
    x_file = c["x"] - c["ux"] if conv.x == "deformed" else c["x"]
    if np.any(np.diff(x_file) <= 0):
        i = int(np.flatnonzero(np.diff(x_file) <= 0)[0])
        raise CaseError(f"{raw.where}: x must increase strictly (one row per interface node, "
                        f"sorted by {'x - ux' if conv.x == 'deformed' else 'x'}); node {i + 2} "
                        f"has x = {float(x_file[i + 1])!r} after {float(x_file[i])!r}")
    w_file = c["w"] if "w" in c else tributary(x_file)
    if np.any(w_file <= 0):
        raise CaseError(f"{raw.where}: tributary length w must be > 0 at every node")
    scale = 1.0 / w_file if conv.values == "force" else 1.0
    return {"x": L * (x_file - conv.x_origin), "w": L * w_file,
            "p": conv.pressure_sign * S * c["p"] * scale,
            "q": conv.shear_sign * S * c["q"] * scale, "status": c.get("status"),
            "slip": conv.shear_sign * L * c["slip"] if "slip" in c else np.full(x_file.size,
                                                                                 np.nan),
            "gap": L * c["gap"] if "gap" in c else np.full(x_file.size, np.nan)}


def check_consistency(raw: RawStep, a: dict, load: tuple, mu: float) -> tuple[dict, str]:
    """A step's nodal table against its own loads ``(stage, P, Q, M, theta)`` (case units, our
    signs), before anything is measured.

    Finite positive widths; sum p w = P within CONSISTENCY_RTOL * P, sum q w = Q within
    CONSISTENCY_RTOL * mu P, sum x p w = M (where M is given) within CONSISTENCY_RTOL * P max|x|
    over the nodes in contact; p >= -NEGATIVE_P_RTOL * max p.  Returns the arrays (small
    negative p clipped to 0) and a note ('' if nothing was clipped); raises
    :class:`CaseError` naming the step, the two numbers and the likely cause."""
    w, p = a["w"], a["p"]
    if not np.all(np.isfinite(w)) or np.any(w <= 0):
        i = int(np.flatnonzero(~(np.isfinite(w) & (w > 0)))[0])
        raise CaseError(f"{raw.where}: tributary length w = {float(w[i])!r} at node {i + 1}; "
                        "allowed: finite numbers > 0")
    check_sums(raw, a, load, mu)
    check_contact_gaps(raw, a)
    low = float(np.min(p))
    top = float(np.max(p))
    if low >= 0:
        return a, ""
    if low < -NEGATIVE_P_RTOL * top:
        i = int(np.argmin(p))
        raise CaseError(f"{raw.where}: pressure p = {low:.6g} at node {i + 1} (x = "
                        f"{float(a['x'][i]):.6g}) is tensile beyond {NEGATIVE_P_RTOL:.0%} of the "
                        f"largest p = {top:.6g}; contact cannot pull (check pressure_sign, or "
                        "the code's contact settings)")
    n = int(np.sum(p < 0))
    note = (f"{raw.where}: {n} node(s) with small negative p (down to {low:.3g}, "
            f"{-low / top:.2%} of the largest p) clipped to 0")
    return a | {"p": np.maximum(p, 0.0)}, note


def check_sums(raw: RawStep, a: dict, load: tuple, mu: float) -> None:
    """sum p w = P, sum q w = Q and sum x p w = M (where given) within their tolerances
    (:data:`CONSISTENCY_RTOL`)."""
    _, P, Q, M, _ = load
    w, p = a["w"], a["p"]
    sums = [("p", float(np.sum(p * w)), P, P, "P"), ("q", float(np.sum(a["q"] * w)), Q, mu * P,
                                                     "mu P")]
    if math.isfinite(M):
        arm = float(np.max(np.abs(a["x"][p > 0]), initial=0.0))
        sums.append(("x p", float(np.sum(a["x"] * p * w)), M, P * arm, "P max|x| in contact"))
    for name, total, value, scale, what in sums:
        tol = CONSISTENCY_RTOL * scale
        if abs(total - value) > tol:
            sym = {"p": "P", "q": "Q", "x p": "M"}[name]
            raise CaseError(f"{raw.where}: sum {name} w = {total:.6g} but the step's {sym} = "
                            f"{value:.6g} (allowed difference {CONSISTENCY_RTOL:.0%} of {what} "
                            f"= {tol:.4g}); likely cause: {likely_cause(name, total, value, tol)}")


def check_contact_gaps(raw: RawStep, a: dict) -> None:
    """No node in contact (p > 0) with gap = inf ("contact impossible there")."""
    bad = np.isinf(a["gap"]) & (a["p"] > 0)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise CaseError(f"{raw.where}: gap = inf (contact impossible) at node {i + 1} (x = "
                        f"{float(a['x'][i]):.6g}) which carries p = {float(a['p'][i]):.6g} > 0; "
                        "allowed: inf only where the bodies cannot touch (beyond a sharp corner "
                        "of the profile), a number elsewhere")


def likely_cause(name: str, total: float, load: float, tol: float) -> str:
    """What most likely makes sum f w differ from its load: a sign, a power of ten, widths."""
    if name == "x p":
        return ("M taken about another point than x = 0 (x_origin), another sign of the moment, "
                "or M from reactions that include the shear's lever arm")
    if name == "q" and abs(load) <= tol:
        return ("a net tangential traction at zero tangential load: check which body's shear is "
                "written (q must be the traction of body 2 on body 1) and the columns' order")
    if load != 0 and abs(total + load) <= tol:
        if name == "q":
            return ("q and Q have opposite signs in the file itself (shear_sign flips both, so "
                    "it cannot fix this): write q and Q for the same body and direction (q acts "
                    "on body 1, Q is the tangential load on body 1)")
        return ("the sign of p (pressure_sign = -1 if the file's p is tensile-positive, "
                "compressive p negative)")
    if total != 0 and load != 0:
        k = math.log10(abs(total / load))
        if round(k) != 0 and abs(k - round(k)) < 0.05:
            return (f"the nodal table and the loads in different units (sum {name} w / load = "
                    f"{total / load:.3g}): stress_scale and length_scale convert both alike, so "
                    "convert one of them in the file (or values = force vs traction)")
    return ("the tributary lengths w (a given w column, or values = force vs traction), nodes "
            "missing from the table, or the x unit")


def interface(a: dict) -> fem.FemInterface:
    pen = np.maximum(-np.where(np.isfinite(a["gap"]), a["gap"], 0.0), 0.0)
    return fem.FemInterface(x=a["x"], w=a["w"], p=a["p"], q=a["q"], status=a["status"],
                            slip=a["slip"], penetration=pen, gap=a["gap"])


def _t(stage: int, P: float, Q: float, P0: float, Q0: float) -> float:
    if stage == 1:
        return P / P0
    if Q0 == 0:
        return float(stage)
    return 1.0 + Q / Q0 if stage == 2 else 2.0 + (Q0 - Q) / (2.0 * Q0)


# ---------------------------------------------------------------------------------------------
# the whole result
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ExternalResult:
    """A result read from the exchange format (raw tables, conventions, meta, source path)."""

    source: str
    steps: tuple
    conventions: Conventions = Conventions()
    meta: Meta = Meta()
    notes: dict = field(default_factory=dict)

    def loads(self) -> list[tuple[int, float, float, float, float]]:
        """(stage, P, Q, M, theta) per step in the case's units and our signs."""
        c = self.conventions
        F, L = c.stress_scale * c.length_scale, c.length_scale
        return [(s.stage, F * s.P, c.shear_sign * F * s.Q, F * L * s.M,
                 c.theta_sign * s.theta) for s in self.steps]

    def history(self, mu: float, E: float = math.nan, nu: float = math.nan) -> fem.FemHistory:
        """FE-like history in our convention; zones from ``fem.results.zones_with_uncertainty``."""
        return self.checked_history(mu, E, nu)[0]

    def checked_history(self, mu: float, E: float = math.nan, nu: float = math.nan
                        ) -> tuple[fem.FemHistory, tuple[str, ...]]:
        """(:meth:`history`, notes): every step passes :func:`check_consistency` first (an
        input error otherwise); the notes say what was clipped."""
        check_stages(self)
        loads = self.loads()
        arrays = [convert(s, self.conventions) for s in self.steps]
        check_same_nodes(self.steps, arrays)
        checked = [check_consistency(s, a, ld, mu)
                   for s, a, ld in zip(self.steps, arrays, loads, strict=True)]
        arrays = [a for a, _ in checked]
        notes = tuple(n for _, n in checked if n)
        ends = {st: (P, Q) for st, P, Q, _, _ in loads}
        P0, Q0 = ends[1][0], ends.get(2, (0.0, 0.0))[1]
        steps = tuple(_step(i, ld, a, mu, P0, Q0)
                      for i, (ld, a) in enumerate(zip(loads, arrays, strict=True)))
        x = arrays[0]["x"]
        h = float(np.min(np.diff(x))) if x.size > 1 else math.nan
        return fem.FemHistory(steps=steps, n_dofs=self.meta.dofs, order=self.meta.order,
                              backend=self.meta.code, timings={"external": self.meta.seconds},
                              mu=mu, E=E, nu=nu, P0=P0, Q0=Q0, h_min=h,
                              n_candidates=int(x.size), fields=None), notes


def derived_status(p: np.ndarray, q: np.ndarray, mu: float, sense: float = 0.0
                   ) -> np.ndarray:
    """Status of nodes from their tractions (no status column): 0 open where p <= 0, 2 slip
    where the shear reaches the cone, else 1 stick.  ``sense``: 0 in stage 1 (no slip expected:
    |q| >= (1 - STATUS_EPS) mu p), else the direction slip can take in this stage, +-1 (stage 2
    the sign of Q0, stage 3 the opposite: by the Jaeger-Ciavarella principle a stage-3 node at
    the cone in the stage-2 direction is a frozen stage-2 slip node, i.e. stick): sense q >= mu p
    - max(STATUS_EPS mu p, SLIP_SLACK mu max p)."""
    if sense == 0.0:
        slip = np.abs(q) >= (1.0 - STATUS_EPS) * mu * p
    else:
        slack = np.maximum(STATUS_EPS * mu * p, SLIP_SLACK * mu * np.max(p, initial=0.0))
        slip = sense * q >= mu * p - slack
    return np.where(p > 0, np.where(slip, 2, 1), 0).astype(np.int8)


def slip_sense(stage: int, Q0: float) -> float:
    """The direction slip takes in ``stage`` (0 in stage 1 or without a tangential load)."""
    if stage == 1 or Q0 == 0:
        return 0.0
    return float(np.sign(Q0)) * (1.0 if stage == 2 else -1.0)


def _step(i: int, load: tuple, a: dict, mu: float, P0: float, Q0: float) -> fem.FemStep:
    stage, P, Q, M, theta = load
    if a["status"] is None:
        a = a | {"status": derived_status(a["p"], a["q"], mu, slip_sense(stage, Q0))}
    candidate = ~np.isinf(a["gap"])
    # the gap side locates an edge as the FE model does (NaN gaps: from the pressure side)
    zones, sticks, u_zones, u_sticks = zones_with_uncertainty(
        a["x"], a["p"], a["q"], a["status"], candidate, mu, a["gap"])
    return fem.FemStep(index=i, stage=stage, t=_t(stage, P, Q, P0, Q0), P=P, Q=Q, M=M,
                       interface=interface(a), contact_zones=zones, stick_zones=sticks,
                       plate=(math.nan, math.nan, theta), reactions=(P, Q, M),
                       residuals=(math.nan,) * 3, iterations=0, edge_uncertainty=u_zones,
                       stick_uncertainty=u_sticks)


def check_stages(res: ExternalResult) -> None:
    """Stages in load order 1..., 2..., 3... with at least one stage-1 step."""
    if not res.steps:
        raise CaseError(f"{res.source}: no load steps found")
    stages = [s.stage for s in res.steps]
    for prev, s in zip(res.steps, res.steps[1:], strict=False):
        if s.stage < prev.stage:
            raise CaseError(f"{s.where}: stage {s.stage} after stage {prev.stage}; steps must be "
                            "in load order (stage 1, then 2, then 3)")
    if stages[0] != 1:
        raise CaseError(f"{res.steps[0].where}: the first step must be of stage 1 (normal "
                        f"load), got stage {stages[0]}")
    if 3 in stages and 2 not in stages:
        raise CaseError(f"{res.source}: stage-3 steps need the stage-2 steps before them (Q0)")
    check_load_order(res.steps, res.loads())


#: The load that moves in each stage (index into a loads tuple), its direction and its name.
STAGE_LOADS = {1: (1, 1.0, "P rises"), 2: (2, 1.0, "Q rises"), 3: (2, -1.0, "Q falls")}


def check_load_order(steps: tuple, loads: list) -> None:
    """Within a stage the steps follow the load path (P up in stage 1, Q up in stage 2, Q down
    in stage 3, in our signs) to :data:`ORDER_RTOL` of P0: each step is compared with the
    analytic state of a monotone path, so data listed out of order would be judged against
    the wrong states."""
    P0 = max(ld[1] for ld in loads)
    for k in range(1, len(steps)):
        stage = loads[k][0]
        if stage != loads[k - 1][0]:
            continue
        i, sense, what = STAGE_LOADS[stage]
        now, then, name = loads[k][i], loads[k - 1][i], " PQ"[i]
        if sense * (now - then) < -ORDER_RTOL * P0:
            sign = ("; or Q of the opposite sign to ours (shear_sign = -1: q and Q on body 1, "
                    "+ in +x)") if stage == 2 and now < 0 else ""
            raise CaseError(f"{steps[k].where}: step out of load order: {name} = {now:.6g} "
                            f"after {name} = {then:.6g} in stage {stage} (in stage {stage} "
                            f"{what}; allowed going back: {ORDER_RTOL:g} of P0 = "
                            f"{ORDER_RTOL * P0:.3g}); list the steps in load order{sign}")


def check_same_nodes(steps: tuple, arrays: list[dict]) -> None:
    """Every step lists the same interface nodes as the first one."""
    x0 = arrays[0]["x"]
    span = float(x0[-1] - x0[0]) if x0.size > 1 else 1.0
    for s, a in zip(steps[1:], arrays[1:], strict=True):
        if a["x"].size != x0.size or np.max(np.abs(a["x"] - x0)) > SAME_X_RTOL * span:
            raise CaseError(f"{s.where}: the interface nodes differ from those of "
                            f"{steps[0].where} ({a['x'].size} vs {x0.size} nodes); every step "
                            "must list the same nodes (reference x)")
