"""CalculiX (Abaqus-style input) driver: a case as a ``ccx`` deck, run, read and verified.

``python -m compare.external.calculix CASE OUT [--level L] [--deck-only]`` writes
``OUT/ccx/<case>.inp``; without ``--deck-only`` it runs ``ccx`` (Debian: ``apt-get install
calculix-ccx``), reads ``<case>.frd``, writes the exchange format into ``OUT`` and verifies it.

Model (the case's problem, ``docs/cases.md``): two plane-strain bodies of linear CPE4 quads
on one tensor-product grid (element size ``h`` over the analytic contact span widened by
:data:`MARGIN` on each side, graded by :data:`GROWTH` out to the half-width and depth
:data:`SIZE_FACTOR` x the fine zone's half-width), body 1's nodes lifted by
``h0(x) (1 - y/H)`` so that its bottom is the profile; bottom of body 2 clamped; the top of
body 1 rigid (every top node tied to a reference node by ``*EQUATION``), its rotation locked;
load control on the reference node (``*CLOAD``): stage 1 P with the top's x fixed, stage 2 Q
from 0 to Q0, stage 3 Q from Q0 to -Q0.  Contact: node-to-surface ``*CONTACT PAIR`` (body 1
slave, body 2 master), linear penalty ``*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR``,
Coulomb ``*FRICTION``.  Friction is ~0 in stage 1 (:data:`MU_STAGE1`) and set to mu by
``*CHANGE FRICTION`` at stage 2: with mu active from the first increment ccx 2.20 did not get
through stage 1; for elastically similar bodies (the library's) P alone causes no slip, so
nothing is lost.  Automatic incrementation, every increment written (``*NODE FILE,
OUTPUT=3D``: RF, of which the clamped bottom is read; ``*CONTACT FILE``: CSTR, CDIS).

Reading (``.frd``): ccx expands CPE4 into one layer of C3D8 bricks and writes node-to-surface
contact results on the expanded nodes; each slave node is mapped to its two copies through
the element connectivity and the two values averaged.  CPRESS (> 0 compressive; open nodes
carry -sigma_inf) gives p; q = CSHEAR1 (:data:`CCX_SHEAR_SIGN`, measured: it integrates to
+Q); status: open where CPRESS <= 0, slip where |q| >= mu p (1 - :data:`SLIP_RTOL`) and the
node moved in the increment (CSLIP1 by more than :data:`SLIP_MOVE_ATOL` h), stick otherwise.
P, Q and M come from the reactions of body 2's bottom.  Values are written in our convention.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from compare.analytic_side import solve_normal_case
from compare.cases import Case, load_case
from compare.errors import CaseError
from compare.external.driver import (
    BODY_SIZE_FACTOR,
    DriverError,
    check_landed,
    parser,
    print_verdicts,
    run_cli,
)
from compare.external.driver import (
    write_steps as driver_steps,
)
from compare.fileio import owned_output, plan_output

#: Elements across the (widened) contact span at level 0; level L has 2**L times as many.
N_SPAN = 40
#: The fine zone is the analytic contact span widened by this fraction of its width each side.
MARGIN = 0.15
#: Geometric growth of the element size away from the fine zone (x and depth).
GROWTH = 1.25
#: Half-width and depth of each body, in multiples of the fine zone's half-width.
SIZE_FACTOR = BODY_SIZE_FACTOR
#: Linear penalty slope K = PENALTY_FACTOR * E / h (pressure per overclosure): penetration
#: ~ p h / (100 E), like our own FE's default penalty.
PENALTY_FACTOR = 100.0
#: Stick slope (tangential penalty) as a fraction of the normal slope K.
STICK_SLOPE = 1.0
#: Tension at large clearance of the linear pressure-overclosure law (ccx's sigma_inf), as a
#: fraction of the mean contact pressure P / (2a): small, it only keeps near-open nodes stable.
SIGMA_INF = 1e-4
#: Friction coefficient of stage 1 (ccx needs mu > 0 in a frictional pair; ~0 = frictionless).
MU_STAGE1 = 1e-4
#: A contact node slips when |q| >= mu p (1 - SLIP_RTOL) (ccx writes no stick/slip flag) ...
SLIP_RTOL = 1e-3
#: ... and its relative tangential displacement CSLIP1 moved by more than this fraction of h
#: in the increment (measured, Cattaneo levels 0-1: sticking nodes <= 5e-6 h, nodes on the cone
#: right after the reversal <= 1.4e-8 h, slipping nodes >= 6e-6 h per increment).
SLIP_MOVE_ATOL = 1e-6
#: Largest increment of each step (fraction of the step): at least 10 outputs per stage.
MAX_INCREMENT = 0.1
#: q on body 1 = CCX_SHEAR_SIGN * CSHEAR1 (measured, Cattaneo level 0: sum CSHEAR1 w = 13.978
#: at Q = 13.950, -17.926 at Q = -17.888 in the expanded-brick output of ccx 2.20).
CCX_SHEAR_SIGN = 1
CODE = "CalculiX ccx"


def available() -> bool:
    """True when the ``ccx`` executable is on PATH."""
    return shutil.which("ccx") is not None


@dataclass(frozen=True)
class Grid:
    """Both bodies' nodes (1-based ids = row + 1), CPE4 elements, named node and face sets."""

    xy: np.ndarray            # (n, 2) reference coordinates, body 1 lifted onto the profile
    elements: np.ndarray      # (m, 4) 0-based node rows, counter-clockwise
    n_elem1: int              # elements 0 .. n_elem1-1 belong to body 1
    slave_faces: np.ndarray   # body 1 elements whose face S1 (bottom) is a contact candidate
    master_faces: np.ndarray  # body 2 elements whose face S3 (top) is a contact candidate
    slave_nodes: np.ndarray   # body 1 interface nodes of the candidate faces, sorted by x
    top: np.ndarray           # body 1 top nodes
    bottom: np.ndarray        # body 2 bottom nodes
    h: float                  # fine element size
    span: tuple[float, float]  # the analytic contact span


def graded(lo: float, hi: float, h: float, outer: float, growth: float) -> np.ndarray:
    """Nodes: uniform (size ~h) on [lo, hi], growing by ``growth`` outwards to +-outer."""
    n = max(1, int(np.ceil((hi - lo) / h)))
    mid = np.linspace(lo, hi, n + 1)
    step = (hi - lo) / n

    def side(start: float, end: float) -> list[float]:
        out, x, d = [], start, step
        sgn = np.sign(end - start)
        while abs(end - x) > 1e-12 * abs(end):
            d *= growth
            x = end if abs(end - x) < 1.5 * d else x + sgn * d
            out.append(x)
        return out

    return np.r_[side(lo, -outer)[::-1], mid, side(hi, outer)]


def grid(case: Case, level: int, n_span: int = N_SPAN, growth: float = GROWTH,
         size_factor: float = SIZE_FACTOR) -> Grid:
    """The two-body CPE4 grid of ``case`` at ``level`` (see the module docstring); the
    defaults of ``n_span``, ``growth``, ``size_factor`` are the driver's (smaller grids make
    small example files)."""
    if level < 0:
        raise CaseError(f"level = {level}; allowed: an integer >= 0")
    zones = solve_normal_case(case).zones
    a, b = zones[0][0], zones[-1][1]
    lo, hi = a - MARGIN * (b - a), b + MARGIN * (b - a)
    h = (hi - lo) / (n_span * 2**level)
    half = 0.5 * (hi - lo)
    centre = 0.5 * (lo + hi)
    W = size_factor * half
    xs = centre + graded(lo - centre, hi - centre, h, W, growth)
    depth = -graded(-h, 0.0, h, W, growth)[::-1]
    ys = np.unique(np.r_[0.0, depth[depth > 0]])  # 0 .. H, fine at 0
    H = float(ys[-1])
    h0 = case.profile.h0(xs)
    lift = np.where(np.isfinite(h0), h0, np.nan)
    if np.isnan(lift).any():  # beyond a sharp corner: the corner's height (no contact there)
        idx = np.arange(len(xs))
        ok = ~np.isnan(lift)
        lift = np.interp(idx, idx[ok], lift[ok])
    nx, ny = len(xs), len(ys)
    X, Y = np.meshgrid(xs, ys)          # (ny, nx), row j = y index
    body1 = np.c_[X.ravel(), (Y + lift[None, :] * (1 - Y / H)).ravel()]
    body2 = np.c_[X.ravel(), -Y[::-1].ravel()]  # row 0 = bottom (y = -H), last = interface
    xy = np.r_[body1, body2]
    n1 = nx * ny

    def quads(offset: int) -> np.ndarray:
        j, i = np.meshgrid(np.arange(ny - 1), np.arange(nx - 1), indexing="ij")
        k = (j * nx + i).ravel() + offset
        return np.c_[k, k + 1, k + 1 + nx, k + nx]  # counter-clockwise from bottom-left

    e1, e2 = quads(0), quads(n1)
    reach = (lo - 0.5 * (hi - lo), hi + 0.5 * (hi - lo))
    cand = np.isfinite(h0[:-1]) & np.isfinite(h0[1:]) & (xs[:-1] >= reach[0]) & (
        xs[1:] <= reach[1])
    faces = np.flatnonzero(cand)                      # bottom row of body 1 = elements 0..nx-2
    master = len(e1) + (ny - 2) * (nx - 1) + faces    # top row of body 2
    slave_nodes = np.unique(np.r_[faces, faces + 1])
    return Grid(xy=xy, elements=np.r_[e1, e2], n_elem1=len(e1), slave_faces=faces,
                master_faces=master, slave_nodes=slave_nodes,
                top=np.arange((ny - 1) * nx, n1), bottom=n1 + np.arange(nx), h=h,
                span=(float(a), float(b)))


# ---------------------------------------------------------------------------------------------
# the deck
# ---------------------------------------------------------------------------------------------
def _num(v: float) -> str:
    """A number in at most 20 characters (ccx's field width)."""
    return f"{float(v):.14g}"


def _lines(ids, per_line: int = 8) -> str:
    ids = [str(int(i) + 1) for i in ids]
    return "\n".join(", ".join(ids[k:k + per_line]) for k in range(0, len(ids), per_line))


def deck(case: Case, g: Grid, max_increment: float = MAX_INCREMENT) -> str:
    """The CalculiX input deck (Abaqus keywords where ccx accepts them; docs/external.md lists
    the lines an Abaqus user changes)."""
    if case.M is not None:
        raise CaseError(f"case '{case.name}': the CalculiX driver runs vertical indentation "
                        "only (M = None)")
    K = PENALTY_FACTOR * case.E / g.h
    sig_inf = SIGMA_INF * case.P / (g.span[1] - g.span[0])
    ref = int(g.top[np.argmin(np.abs(g.xy[g.top, 0]))])
    others = [int(n) for n in g.top if n != ref]
    nodes = "\n".join(f"{k + 1}, {_num(x)}, {_num(y)}" for k, (x, y) in enumerate(g.xy.tolist()))
    elems = [f"{k + 1}, " + ", ".join(str(int(v) + 1) for v in e)
             for k, e in enumerate(g.elements)]
    eqs = "\n".join(f"2\n{n + 1}, {d}, 1.0, {ref + 1}, {d}, -1.0" for n in others for d in (1, 2))
    out = [
        f"** multicontact case '{case.name}': P = {_num(case.P)}, Q0 = {_num(case.Q0)}, "
        f"mu = {_num(case.mu)}",
        f"** fine element size h = {_num(g.h)}; body 1 = elements 1-{g.n_elem1}",
        "*HEADING", f"multicontact {case.name}",
        "*NODE", nodes,
        "*ELEMENT, TYPE=CPE4, ELSET=BODY1", "\n".join(elems[:g.n_elem1]),
        "*ELEMENT, TYPE=CPE4, ELSET=BODY2", "\n".join(elems[g.n_elem1:]),
        "*NSET, NSET=TOP", _lines(g.top),
        "*NSET, NSET=BOTTOM", _lines(g.bottom),
        "*NSET, NSET=REF", str(ref + 1),
        "*NSET, NSET=SLAVENODES", _lines(g.slave_nodes),
        "*SURFACE, NAME=SLAVE, TYPE=ELEMENT", "\n".join(f"{e + 1}, S1" for e in g.slave_faces),
        "*SURFACE, NAME=MASTER, TYPE=ELEMENT", "\n".join(f"{e + 1}, S3" for e in g.master_faces),
        "*MATERIAL, NAME=ELASTIC", "*ELASTIC", f"{_num(case.E)}, {_num(case.nu)}",
        "*SOLID SECTION, ELSET=BODY1, MATERIAL=ELASTIC", "1.0",
        "*SOLID SECTION, ELSET=BODY2, MATERIAL=ELASTIC", "1.0",
        "*EQUATION", eqs,
        "*SURFACE INTERACTION, NAME=SI",
        "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR", f"{_num(K)}, {_num(sig_inf)}",
        "*FRICTION", f"{_num(MU_STAGE1)}, {_num(STICK_SLOPE * K)}",
        "*CONTACT PAIR, INTERACTION=SI, TYPE=NODE TO SURFACE", "SLAVE, MASTER",
        "*BOUNDARY", "BOTTOM, 1, 2, 0.0",
    ]
    inc = f"{_num(max_increment / 2)}, 1.0, 1e-6, {_num(max_increment)}"
    output = ["*NODE FILE, OUTPUT=3D", "RF", "*CONTACT FILE", "CSTR, CDIS"]
    out += ["** stage 1: P from 0 to P0, Q = 0 (x of the top fixed), friction ~0",
            "*STEP, INC=1000", "*STATIC", inc,
            "*BOUNDARY", "REF, 1, 1, 0.0",
            "*CLOAD", f"REF, 2, {_num(-case.P)}", *output, "*END STEP"]
    if case.Q0 > 0:
        out += ["** stage 2: friction mu; Q from 0 to Q0 at constant P",
                "*STEP, INC=1000", "*STATIC", inc,
                "*CHANGE FRICTION, INTERACTION=SI", "*FRICTION",
                f"{_num(case.mu)}, {_num(STICK_SLOPE * K)}",
                "*BOUNDARY, OP=NEW", "BOTTOM, 1, 2, 0.0",
                "*CLOAD", f"REF, 1, {_num(case.Q0)}", f"REF, 2, {_num(-case.P)}",
                *output, "*END STEP",
                "** stage 3: Q from Q0 to -Q0 at constant P",
                "*STEP, INC=1000", "*STATIC", inc,
                "*CLOAD", f"REF, 1, {_num(-case.Q0)}", f"REF, 2, {_num(-case.P)}",
                *output, "*END STEP"]
    return "\n".join(out) + "\n"


# ---------------------------------------------------------------------------------------------
# reading the .frd
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FrdSet:
    """One result block of a .frd: its ccx step and increment, total time, name (DISP, FORC,
    CONTACT, ...), component names and values per (expanded) node id."""

    step: int
    increment: int
    time: float
    name: str
    components: tuple[str, ...]
    values: dict


@dataclass(frozen=True)
class Frd:
    """A ccx ASCII result file: element connectivity (expanded ids) and the result blocks."""

    elements: dict
    sets: tuple[FrdSet, ...]


def _fields(line: str, n: int) -> list[float]:
    return [float(line[13 + 12 * k: 25 + 12 * k]) for k in range(n)]


def read_frd(path: str | Path) -> Frd:
    """Parse the parts of a ccx .frd this driver needs (fixed-width records, format
    E12.5).  Raises :class:`DriverError` naming the file and line on anything unexpected."""
    path = Path(path)
    try:
        lines = path.read_text().splitlines()
    except OSError as exc:
        raise DriverError(f"{path}: cannot read the ccx result file ({exc.strerror})") from None
    elements, sets = {}, []
    k, pstep = 0, (0, 0)
    try:
        while k < len(lines):
            ln = lines[k]
            if ln.startswith("    3C"):
                k += 1
                while not lines[k].startswith(" -3"):
                    eid = int(lines[k][3:13])
                    conn = []
                    k += 1
                    while lines[k].startswith(" -2"):
                        body = lines[k][3:]
                        conn += [int(body[j:j + 10]) for j in range(0, len(body.rstrip()), 10)]
                        k += 1
                    elements[eid] = tuple(conn)
            elif ln.startswith("    1PSTEP"):
                parts = ln.split()
                pstep = (int(parts[3]), int(parts[2]))  # (step, increment)
            elif ln.startswith("  100CL"):
                time_ = float(ln[12:24])
                name = lines[k + 1].split()[1]
                k += 2
                comps = []
                while lines[k].startswith(" -5"):
                    comps.append(lines[k].split()[1])
                    k += 1
                comps = [c for c in comps if c != "ALL"]
                vals = {}
                while lines[k].startswith(" -1"):
                    vals[int(lines[k][3:13])] = _fields(lines[k], len(comps))
                    k += 1
                sets.append(FrdSet(pstep[0], pstep[1], time_, name, tuple(comps), vals))
                continue
            k += 1
    except (ValueError, IndexError):
        raise DriverError(f"{path}, line {k + 1}: not a ccx .frd record this driver can read: "
                          f"{lines[k] if k < len(lines) else '<end of file>'!r}") from None
    return Frd(elements=elements, sets=tuple(sets))


def expanded_copies(frd: Frd, elements2d: np.ndarray) -> dict:
    """expanded node id -> 2D node row: ccx's C3D8 element e has the copies of the CPE4 node k
    of element e at positions k and k + 4 (both faces of the layer)."""
    copies = {}
    for e, conn2d in enumerate(elements2d):
        conn3d = frd.elements.get(e + 1)
        if conn3d is None or len(conn3d) != 8:
            raise DriverError(f"the .frd has no expanded C3D8 element {e + 1}: was the deck "
                              "written by this driver, with *NODE FILE, OUTPUT=3D?")
        for k, n in enumerate(conn2d):
            copies[conn3d[k]] = int(n)
            copies[conn3d[k + 4]] = int(n)
    return copies


@dataclass(frozen=True)
class CcxStep:
    """One converged increment in our convention: stage, total time, loads (M = int x p dx
    about x = 0), interface rows."""

    stage: int
    time: float
    P: float
    Q: float
    M: float
    p: np.ndarray
    q: np.ndarray
    status: np.ndarray


def _per_node(values: dict, copies: dict, rows: np.ndarray, comp: int) -> np.ndarray:
    """Average of the two expanded copies of each 2D node in ``rows`` (0 where none)."""
    where = {int(r): i for i, r in enumerate(rows)}
    total, count = np.zeros(len(rows)), np.zeros(len(rows))
    for nid, v in values.items():
        i = where.get(copies.get(nid, -1))
        if i is not None:
            total[i] += v[comp]
            count[i] += 1
    return np.divide(total, count, out=np.zeros(len(rows)), where=count > 0)


def increments(frd: Frd, g: Grid, mu: float) -> list[CcxStep]:
    """Every increment with its FORC and CONTACT blocks, as interface rows of the slave nodes.

    P, Q, M: from the reactions F of body 2's bottom (P = sum F_y, Q = -sum F_x: the bottom
    holds body 2 against the load on body 1; M = sum (x F_y - y F_x), the moment balancing
    the pressure's -int x p dx on body 2 about (0, 0), the shear at y = 0 having no arm).
    p = CPRESS where > 0; q = CCX_SHEAR_SIGN * CSHEAR1 on contact nodes; status open / stick /
    slip: slip where q is on the friction cone (|q| >= mu p (1 - SLIP_RTOL)) *and* the node
    moved relative to the master in the increment (CSLIP1 changed by more than
    SLIP_MOVE_ATOL h): right after the stage-3 reversal the nodes are still on the cone but
    stick.
    """
    copies = expanded_copies(frd, g.elements)
    by_inc: dict = {}
    for s in frd.sets:
        by_inc.setdefault((s.step, s.increment), {})[s.name] = s
    bottom = {int(n) for n in g.bottom}
    out = []
    moved = np.zeros(len(g.slave_nodes))  # CSLIP1 of the increment before
    for (step, _), blocks in sorted(by_inc.items()):
        if "FORC" not in blocks:
            continue
        f = blocks["FORC"]
        at = [(copies[nid], v[:2]) for nid, v in f.values.items() if copies.get(nid) in bottom]
        xy = g.xy[[n for n, _ in at]]
        F = np.array([v for _, v in at])
        P, Q = float(F[:, 1].sum()), -float(F[:, 0].sum())
        # moment of body 2 about (0, 0): -M from the pressure, plus the bottom reactions
        M = float(xy[:, 0] @ F[:, 1] - xy[:, 1] @ F[:, 0])
        rows = g.slave_nodes
        p = q = np.zeros(len(rows))
        tangential = moved
        if "CONTACT" in blocks:
            c = blocks["CONTACT"]
            ip, iq = c.components.index("CPRESS"), c.components.index("CSHEAR1")
            p = _per_node(c.values, copies, rows, ip)
            q = CCX_SHEAR_SIGN * _per_node(c.values, copies, rows, iq)
            tangential = _per_node(c.values, copies, rows, c.components.index("CSLIP1"))
        closed = p > 0
        on_cone = np.abs(q) >= mu * p * (1 - SLIP_RTOL)
        moving = np.abs(tangential - moved) > SLIP_MOVE_ATOL * g.h
        moved = tangential
        status = np.where(closed, np.where(on_cone & moving, 2, 1), 0)
        out.append(CcxStep(step, f.time, P, Q, M, np.where(closed, p, 0.0),
                           np.where(closed, q, 0.0), status))
    return out


# ---------------------------------------------------------------------------------------------
# running and writing
# ---------------------------------------------------------------------------------------------
#: The interface tractions of every increment must integrate to the reactions within this
#: fraction of P (p) and of mu P (q): a check that the contact output was read and mapped
#: right (measured, Cattaneo level 0: sum p w - P = 0.11 % of P, sum q w - Q = 0.2 % of mu P).
TRACTION_BALANCE_RTOL = 0.01


def version() -> str:
    """``ccx -v`` as 'CalculiX 2.20' (or 'CalculiX' when it does not say)."""
    try:
        text = subprocess.run(["ccx", "-v"], capture_output=True, text=True, timeout=60).stdout
    except (OSError, subprocess.SubprocessError):
        return "CalculiX"
    words = text.split()
    return f"CalculiX {words[words.index('Version') + 1]}" if "Version" in words else "CalculiX"


def write_deck(case: Case | str, out: str | Path, level: int = 0) -> tuple[Path, Grid]:
    """Write ``out/ccx/<case>.inp``; returns its path and the grid."""
    case = load_case(case)
    g = grid(case, level)
    text = deck(case, g)
    work = Path(out).resolve() / "ccx"
    work.mkdir(parents=True, exist_ok=True)
    path = work / f"{case.name}.inp"
    tmp = path.with_suffix(".inp.tmp")
    tmp.write_text(text)
    tmp.replace(path)
    return path, g


def run_ccx(inp: Path) -> float:
    """Run ccx on ``inp`` in its folder (one thread); wall seconds.  DriverError on failure."""
    if not available():
        raise DriverError("ccx is not installed: on Debian/Ubuntu `apt-get install "
                          "calculix-ccx`, elsewhere see calculix.de (or use --deck-only)")
    t0 = time.perf_counter()
    log = inp.with_suffix(".log")
    env = {**os.environ, "OMP_NUM_THREADS": "1", "CCX_NPROC_EQUATION_SOLVER": "1"}
    with log.open("w") as fh:
        rc = subprocess.run(["ccx", "-i", inp.stem], cwd=inp.parent, stdout=fh,
                            stderr=subprocess.STDOUT, env=env).returncode
    text = log.read_text()
    errors = [ln.strip() for ln in text.splitlines() if "*ERROR" in ln]
    if rc != 0 or errors:
        raise DriverError(f"ccx failed on {inp} (exit {rc}): "
                          f"{'; '.join(errors[:3]) or 'see ' + str(log)}")
    return time.perf_counter() - t0


def tributary(x: np.ndarray) -> np.ndarray:
    """Half of each adjacent segment (the exchange format's default w)."""
    d = np.diff(x)
    return np.r_[d, 0.0] / 2 + np.r_[0.0, d] / 2


def check_balance(steps: list[CcxStep], x: np.ndarray, mu: float, P0: float) -> None:
    """sum p w = P and sum q w = Q at every increment, within TRACTION_BALANCE_RTOL."""
    w = tributary(x)
    for s in steps:
        ep = abs(float(s.p @ w) - s.P) / P0
        eq = abs(float(s.q @ w) - s.Q) / (mu * P0)
        if ep > TRACTION_BALANCE_RTOL or eq > TRACTION_BALANCE_RTOL:
            raise DriverError(
                f"ccx increment at t = {s.time:g}: the contact tractions integrate to "
                f"P = {float(s.p @ w):.6g}, Q = {float(s.q @ w):.6g} but the reactions are "
                f"P = {s.P:.6g}, Q = {s.Q:.6g} (allowed {TRACTION_BALANCE_RTOL:.0%} of P, mu P)")


def write_steps(out: Path, case: Case, x: np.ndarray, steps: list[CcxStep], n_dofs: int,
                seconds: float, code: str) -> Path:
    """Manifest + one step file per increment, in our convention (signs converted here)."""
    head = [f"# code = {code}", f"# case = {case.name}", f"# dofs = {n_dofs}", "# order = 1",
            f"# seconds = {seconds:.3f}"]
    return driver_steps(out, head, x, [(s.stage, s.P, s.Q, s.M, s.p, s.q, s.status)
                                       for s in steps])


def convert(case: Case, g: Grid, frd_path: Path, out: Path, seconds: float, code: str
            ) -> Path:
    """Read the .frd, check it, write the exchange format into ``out``; the manifest path."""
    steps = increments(read_frd(frd_path), g, case.mu)
    if not steps:
        raise DriverError(f"{frd_path}: no converged increment with reaction forces")
    check_landed("CalculiX", case, [(s.stage, s.P, s.Q) for s in steps])
    x = g.xy[g.slave_nodes, 0]
    check_balance(steps, x, case.mu, case.P)
    return write_steps(out, case, x, steps, 2 * len(g.xy), seconds, code)


def run(case: Case | str, out: str | Path, level: int = 0, force: bool = False) -> Path:
    """Write the deck of ``case``, run ccx, write the exchange format into ``out``; returns the
    manifest.  ccx's files stay in ``out/ccx``.  ``out`` is written through
    :func:`compare.fileio.owned_output` (a folder holding other files is refused unless
    ``force``, which keeps them).  Raises DriverError when ccx fails or its run misses the
    case's loads."""
    case = load_case(case)
    plan = plan_output(out, "calculix", force)
    with owned_output(out, "calculix", force, plan) as tmp:
        inp, g = write_deck(case, tmp, level)
        seconds = run_ccx(inp)
        code = f"{version()} (CPE4, node-to-surface penalty contact)"
        manifest = convert(case, g, inp.with_suffix(".frd"), tmp, seconds, code)
    return plan.out / manifest.relative_to(tmp)


def deck_only(case: Case | str, out: str | Path, level: int = 0, force: bool = False) -> Path:
    """Only the deck, ``out/ccx/<case>.inp`` (written like :func:`run`'s output); its path."""
    case = load_case(case)
    plan = plan_output(out, "calculix-deck", force)
    with owned_output(out, "calculix-deck", force, plan) as tmp:
        path, _ = write_deck(case, tmp, level)
    return plan.out / path.relative_to(tmp)


def main(argv: list[str] | None = None) -> int:
    """``python -m compare.external.calculix CASE OUT [--level L] [--deck-only]``.

    Exit 0 (ccx agrees), 1 (it does not), 2 (ccx missing or failed, or its run missed the
    case's loads: one message on stderr); with --deck-only 0 after writing the deck.
    """
    prog = "python -m compare.external.calculix"
    ap = parser(prog, "Write a CalculiX deck of a case, run ccx and verify its result.")
    ap.add_argument("--deck-only", action="store_true",
                    help="only write OUT/ccx/CASE.inp (to run ccx or Abaqus elsewhere)")
    args = ap.parse_args(argv)

    def body() -> bool:
        if args.deck_only:
            print(f"wrote {deck_only(args.case, args.out, args.level, args.force)}")
            return True
        return print_verdicts(args.case, [run(args.case, args.out, args.level, args.force)])

    return run_cli(prog, body)


if __name__ == "__main__":
    sys.exit(main())
