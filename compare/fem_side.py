"""The FE side of a case: mesh window, kinks and load path from the case, then ``fem``.

``fem`` takes the gap as a plain callable (it never imports ``analytic``); this module passes
``profile.h0``, the profile's kinks and corners (mesh nodes are put there) and a refinement
window around the analytic contact span.  The stage-2/3 Q values of the FE load path are the
union of equal increments, the case's sampled Q and the Q values at which the reduced load
``P* = P0 - Q / mu`` (stage 2) or ``P** = P0 - (Q0 - Q) / (2 mu)`` (stage 3) equals a stage-1
FE load, so the Jaeger-Ciavarella identity can be checked on the FE side without interpolation.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import fem
from analytic import NormalSolution
from compare.cases import Case

#: Two Q values closer than this (relative to Q0) are the same load step.
Q_MERGE = 1e-9


def window(case: Case, normal: NormalSolution) -> tuple[tuple[float, float], ...]:
    """Refined windows, one per analytic contact zone, each widened by ``window_margin`` of
    its width on each side (the FE mesh refines every zone relative to its own width)."""
    return tuple((a - case.fem.window_margin * (b - a), b + case.fem.window_margin * (b - a))
                 for a, b in normal.zones)


def kinks(case: Case) -> tuple[float, ...]:
    """Profile kinks and corners (finite ones)."""
    pts = {float(v) for v in (*case.profile.kinks, *case.profile.corners) if np.isfinite(v)}
    return tuple(sorted(pts))


def mesh_kinks(case: Case, normal: NormalSolution) -> tuple[float, ...]:
    """x that get a mesh node: the kinks and corners, and with ``fem.edge_nodes`` the analytic
    contact edges at the full normal load (phase-locked refinement)."""
    if not case.fem.edge_nodes:
        return kinks(case)
    edges = {float(e) for z in normal.zones for e in z}
    return tuple(sorted(set(kinks(case)) | edges))


def _merge(values: np.ndarray, decreasing: bool, Q0: float) -> tuple[float, ...]:
    v = np.sort(values)[::-1] if decreasing else np.sort(values)
    keep = [v[0]]
    for q in v[1:]:
        if abs(q - keep[-1]) > Q_MERGE * Q0:
            keep.append(q)
    return tuple(float(q) for q in keep)


def jc_q_values(case: Case) -> tuple[np.ndarray, np.ndarray]:
    """Q values where the reduced load equals a stage-1 FE load (stage 2, stage 3)."""
    P_k = case.P * np.arange(1, case.fem.n_normal + 1) / case.fem.n_normal
    q2 = case.mu * (case.P - P_k)
    q3 = case.Q0 - 2 * case.mu * (case.P - P_k)
    tol = Q_MERGE * case.Q0
    return q2[(q2 > tol) & (q2 <= case.Q0 + tol)], q3[(q3 < case.Q0 - tol) & (q3 >= -case.Q0 - tol)]


def load_path(case: Case) -> fem.LoadPath:
    """The FE increments (see module docstring)."""
    n = case.fem.n_tangential
    j2, j3 = jc_q_values(case)
    s2 = np.r_[np.linspace(0.0, case.Q0, n + 1)[1:], case.stage2, j2, case.Q0]
    s3 = np.r_[np.linspace(case.Q0, -case.Q0, 2 * n + 1)[1:], case.stage3, j3, -case.Q0]
    s2 = np.clip(s2, 0.0, case.Q0)
    s3 = np.clip(s3, -case.Q0, case.Q0)
    s3 = s3[s3 < case.Q0 - Q_MERGE * case.Q0]
    return fem.LoadPath(n_normal=case.fem.n_normal, stage2=_merge(s2, False, case.Q0),
                        stage3=_merge(s3, True, case.Q0))


def mesh(case: Case, boundary: str | None = None):
    """MeshSpec or MeshFile of the case; ``boundary``: fem's outer boundary condition
    ('half-plane' or 'clamped'; None: fem's default)."""
    bc = {} if boundary is None else {"boundary": boundary}
    if case.fem.mesh_file:
        return fem.MeshFile(Path(case.fem.mesh_file), order=case.fem.order,
                            incompatible=case.fem.incompatible, **bc)
    return fem.MeshSpec(level=case.fem.level, order=case.fem.order,
                        size_factor=case.fem.size_factor, growth=case.fem.growth,
                        layout=case.fem.layout, incompatible=case.fem.incompatible, **bc)


def contact(case: Case) -> fem.ContactSettings:
    return fem.ContactSettings(penalty_factor=case.fem.penalty_factor,
                               augmented=case.fem.augmented)


def run_fem(case: Case, normal: NormalSolution, boundary: str | None = None
            ) -> fem.FemHistory:
    """Solve the case's three-stage history with the FE model (``boundary``: see
    :func:`mesh`; an external code's model with a clamped bottom and a rigid top is matched
    with 'clamped')."""
    path = load_path(case) if case.Q0 > 0 else fem.LoadPath(n_normal=case.fem.n_normal)
    return fem.solve_history(case.profile.h0, case.P, case.Q0, case.mu, case.E, case.nu,
                             M=case.M, mesh=mesh(case, boundary), contact=contact(case),
                             increments=path, kinks=mesh_kinks(case, normal),
                             window=window(case, normal))
