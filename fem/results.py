"""Result containers (frozen dataclasses) and zone / edge extraction from nodal data.

Units follow the inputs (forces per unit width, lengths, stresses). Sign conventions
(docs/conventions.md): p >= 0 compressive; q is the shear on body 1 in the direction of Q with
``sum q w = Q``; ``M = sum x p w`` about x = 0; slip is the irreversible relative
tangential displacement of body 1 over body 2 (+x); status 0 open, 1 stick, 2 slip.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .contact import OPEN, SLIP, STICK


@dataclass(frozen=True)
class FemInterface:
    """Nodal interface data at one increment, sorted by x.

    x: node x; w: tributary length; p: pressure; q: shear (direction of Q);
    status: 0 open / 1 stick / 2 slip; slip: irreversible relative slip;
    penetration: max(0, -gap); gap: deformed gap (inf where h0 is inf).
    """

    x: np.ndarray
    w: np.ndarray
    p: np.ndarray
    q: np.ndarray
    status: np.ndarray
    slip: np.ndarray
    penetration: np.ndarray
    gap: np.ndarray


@dataclass(frozen=True)
class FemStep:
    """One converged load increment.

    stage: 1, 2 or 3; t: load-step parameter (stage 1: P/P0, stage 2: 1 + Q/Q0,
    stage 3: 2 + (Q0 - Q)/(2 Q0)); P, Q, M: applied loads (M computed in
    vertical-indentation mode); contact_zones: ((a, b), ...); stick_zones: one
    (c, d) or None per contact zone; plate: (u, v, theta) of the plate, theta about (0, 0)
    in the analytic convention (the gap seen in contact is h0(x) - theta x, i.e. clockwise);
    reactions: (P, Q, M) recovered from the full-field plate reactions;
    residuals: relative equilibrium residuals (P, Q, M) of those reactions;
    iterations: Newton iterations of the increment (summed over cut-backs / Uzawa).
    """

    index: int
    stage: int
    t: float
    P: float
    Q: float
    M: float
    interface: FemInterface
    contact_zones: tuple
    stick_zones: tuple
    plate: tuple
    reactions: tuple
    residuals: tuple
    iterations: int


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Index ranges [i0, i1] (inclusive) of consecutive True entries."""
    m = np.r_[False, mask, False].astype(np.int8)
    starts = np.flatnonzero(np.diff(m) == 1)
    ends = np.flatnonzero(np.diff(m) == -1) - 1
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


def edge(x: np.ndarray, f: np.ndarray, inner: int, step: int) -> float:
    """Zero of f between node ``inner`` (f > 0) and its outer neighbour ``inner+step``.

    Near a nonsingular edge f behaves like sqrt(distance), so f**2 is extrapolated
    linearly from the two innermost nodes and clipped to the node interval.
    """
    outer, second = inner + step, inner - step
    lo, hi = sorted((x[inner], x[outer]))
    f1 = f[inner]
    f2 = f[second] if 0 <= second < x.size else f1
    slope = (f2**2 - f1**2) / (x[second] - x[inner]) if f2 > f1 and 0 <= second < x.size else 0.0
    if slope == 0.0:
        return 0.5 * (lo + hi)
    return float(np.clip(x[inner] - f1**2 / slope, lo, hi))


def zone_edges(x, f, mask, hard) -> list[tuple[float, float]]:
    """Edges of each run of ``mask``; a run bounded by a ``hard`` node ends at the node itself."""
    out = []
    for i0, i1 in runs(mask):
        a = x[i0] if i0 == 0 or hard[i0 - 1] else edge(x, f, i0, -1)
        b = x[i1] if i1 == x.size - 1 or hard[i1 + 1] else edge(x, f, i1, +1)
        out.append((float(a), float(b)))
    return out


def contact_and_stick(x, p, q, status, candidate, mu) -> tuple[tuple, tuple]:
    """Contact zones (p -> 0) and their stick zones (mu p - |q| -> 0), aligned."""
    contact = zone_edges(x, p, status > OPEN, ~candidate)
    stick_f = np.where(status == STICK, mu * p - np.abs(q), 0.0)
    hard = status == OPEN
    sticks = zone_edges(x, np.maximum(stick_f, 0.0), status == STICK, np.zeros_like(hard))
    aligned = []
    for (a, b), (i0, i1) in zip(contact, runs(status > OPEN), strict=True):
        inside = [
            s
            for s, (j0, j1) in zip(sticks, runs(status == STICK), strict=True)
            if i0 <= j0 and j1 <= i1
        ]
        if not inside:
            aligned.append(None)
            continue
        c, d = min(s[0] for s in inside), max(s[1] for s in inside)
        j0 = min(r[0] for r in runs(status == STICK) if i0 <= r[0] <= i1)
        j1 = max(r[1] for r in runs(status == STICK) if i0 <= r[1] <= i1)
        aligned.append((a if j0 == i0 else c, b if j1 == i1 else d))
    return tuple(contact), tuple(aligned)


__all__ = ["FemInterface", "FemStep", "contact_and_stick", "runs", "OPEN", "STICK", "SLIP"]
