"""Independent discretised half-plane contact solver (influence coefficients, log kernel).

This module is the project's *independent* check of the analytic singular-integral
solver: it takes plain callables and imports neither ``analytic`` nor ``fem``.

Model (conventions of docs/conventions.md): two elastically similar plane-strain half-planes with
composite compliance ``A = 4 (1 - nu**2) / E``, pressure ``p >= 0`` compressive, forces
per unit width.

Normal problem::

    u(x) = -(A/pi) ∫ p(s) ln(|x - s| / L) ds          relative normal displacement
    g(x) = h0(x) - theta x - delta + u(x)             deformed gap
    g = 0 where p > 0;  g >= 0 and p = 0 elsewhere;  ∫ p dx = P;  ∫ x p dx = M

``L = x1 - x0`` (the window length) is the reference length of the logarithm. It only
changes the constant that is absorbed in ``delta``; ``delta`` is therefore the approach
referred to ``L``. With this choice the kernel ``-ln(|x - s| / L)`` is positive definite
on the window (the logarithmic capacity of an interval of length ``L`` is ``L/4 < L``), so
every active-set matrix is symmetric positive definite and Cholesky applies.

Discretisation: ``N`` uniform panels on ``[x0, x1]``, piecewise-constant tractions,
collocation at the panel centres, exact panel integrals of the logarithm::

    ∫_{panel j} ln(|x_i - s| / L) ds = F(t + dx/2) - F(t - dx/2),   t = x_i - x_j,
    F(t) = t ln(|t| / L) - t,   F(0) = 0.

Solvers: the normal problem is the equality-constrained QP
``min 1/2 p^T K p + p^T h  s.t.  p >= 0, dx sum p = P (, dx sum x p = M)`` solved by a
primal-dual active-set (block pivoting) iteration whose subproblems are solved exactly
(Cholesky of ``K`` on the active set, Lagrange multipliers ``delta`` and ``theta`` from
a 1x1 or 2x2 Schur complement), warm-started from the solution on a grid with half as
many panels. The tangential problem (stages 2 and 3, on a normal solution) is solved in
:mod:`compare.bem_tangential`.

Sub-panel edge estimators (see :func:`sqrt_edge`): at a nonsingular contact edge
``p ~ sqrt(distance)``, at a stick edge ``mu p - |q| ~ sqrt(distance)``; the square of the
quantity is fitted by a straight line through the panels next to the edge and
extrapolated to zero. The observed order of the contact-edge error is measured in
``tests/verification/test_bem.py``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

Profile = Callable[[np.ndarray], np.ndarray]

GAP_TOL = 1e-11
"""Gap tolerance relative to ``A P``: deformed gaps above ``-GAP_TOL A P`` count as open
(roundoff of the dense solve is ~1e-13 A P; a real penetration is far larger)."""
MAX_ITER = 100
"""Active-set iterations before giving up (warm-started solves need fewer than ~15)."""
EDGE_SKIP_PANELS = 4
"""Panels next to an edge left out of the sqrt-edge fit: their values carry the O(dx)
error of the partly-contacting edge panel (Hertz: edge error 0.17 dx -> 0.03 dx)."""
EDGE_FIT_PANELS = 6
"""Panels in the quadratic sqrt-edge fit: enough to average panel noise, close enough
to the edge that p^2 = c1 d + c2 d^2 + O(d^3) holds."""
COARSEST_WARM_START = 64
"""Grids with more panels are warm-started from a solve on a grid with half as many."""


@dataclass(frozen=True)
class Grid:
    """Uniform panels on the window ``[x0, x1]``.

    Panel ``i`` is ``[x0 + i dx, x0 + (i+1) dx]``, ``dx = (x1 - x0) / n``, collocation
    point its centre ``x[i]``. Tractions are constant per panel.
    """

    x0: float
    x1: float
    n: int

    def __post_init__(self) -> None:
        if not (np.isfinite(self.x0) and np.isfinite(self.x1) and self.x1 > self.x0):
            raise ValueError(
                f"window=({self.x0}, {self.x1}) is not allowed: need finite x0 < x1"
            )
        if int(self.n) != self.n or self.n < 8:
            raise ValueError(f"N={self.n} is not allowed: need an integer N >= 8")

    @property
    def dx(self) -> float:
        """Panel width."""
        return (self.x1 - self.x0) / self.n

    @property
    def x(self) -> np.ndarray:
        """Panel centres (collocation points)."""
        return self.x0 + (np.arange(self.n) + 0.5) * self.dx

    def influence(self, A: float) -> np.ndarray:
        """Influence matrix ``K[i, j] = -(A/pi) ∫_{panel j} ln(|x_i - s| / L) ds``.

        ``u = K @ p`` is the relative surface displacement at the centres caused by the
        piecewise-constant traction ``p`` (up to the constant absorbed in ``delta``).
        Symmetric Toeplitz; positive definite (reference length ``L = x1 - x0``).
        """
        return sla.toeplitz(_kernel_column(self.n, self.dx, self.x1 - self.x0, A))


def _kernel_column(n: int, dx: float, length: float, A: float) -> np.ndarray:
    """First column of the Toeplitz influence matrix: offsets ``t = k dx``, k = 0..n-1."""
    t = np.arange(n) * dx
    return -(A / np.pi) * (_log_antiderivative(t + dx / 2, length)
                           - _log_antiderivative(t - dx / 2, length))


def _log_antiderivative(t: np.ndarray, length: float) -> np.ndarray:
    """``F(t) = t ln(|t| / L) - t`` with ``F(0) = 0`` (antiderivative of ``ln(|t|/L)``)."""
    a = np.abs(t)
    safe = np.where(a > 0, a, 1.0)
    return np.where(a > 0, t * np.log(safe / length) - t, 0.0)


@dataclass(frozen=True)
class BemNormal:
    """Discrete normal contact solution (stage 1).

    Attributes:
        grid: the panel grid; ``x``/``dx`` repeat its centres and width.
        A: composite compliance ``4 (1 - nu^2) / E`` [1/stress].
        p: panel pressures [force/length^2 per unit width], ``p >= 0`` compressive.
        g: deformed gap at the centres, ``h0 - theta x - delta + K p`` (0 in contact,
            ``inf`` where ``h0`` is ``inf``).
        h0: the initial gap at the centres (``inf`` where contact is impossible).
        delta: rigid approach (log reference length ``L = x1 - x0``).
        theta: rigid rotation of body 1 (0 when the rotation is locked).
        P, M: normal force and moment ``dx sum x p`` about ``x = 0``.
        active: panels in contact (``p > 0``).
        zones: contact zones ``(a, b)`` ordered by x, edges estimated sub-panel.
        singular: per zone ``(left, right)``: True where the edge is a sharp corner
            (``h0 = inf`` beyond it; the edge is then the panel boundary at the corner).
        zone_panels: per zone the inclusive panel index range ``(i0, i1)``.
        zone_loads: per zone ``dx sum p``.
        iterations: active-set iterations on the finest grid.
    """

    grid: Grid
    x: np.ndarray
    dx: float
    A: float
    p: np.ndarray
    g: np.ndarray
    h0: np.ndarray
    delta: float
    theta: float
    P: float
    M: float
    active: np.ndarray
    zones: tuple[tuple[float, float], ...]
    singular: tuple[tuple[bool, bool], ...]
    zone_panels: tuple[tuple[int, int], ...]
    zone_loads: tuple[float, ...]
    iterations: int


# ----------------------------------------------------------------------------- normal


def solve_normal_bem(
    h0: Profile,
    window: tuple[float, float],
    N: int,
    P: float,
    A: float,
    *,
    M: float | None = None,
) -> BemNormal:
    """Solve the discrete normal contact problem on ``N`` panels over ``window``.

    Args:
        h0: vectorised initial gap ``h0(x)``; ``np.inf`` where contact is impossible
            (those panels are excluded; a sharp corner is where h0 jumps to inf).
        window: ``(x0, x1)``; must contain every contact zone with a free panel to spare
            (or ``h0 = inf`` just beyond it).
        N: number of panels (>= 8).
        P: normal force > 0.
        A: composite compliance ``4 (1 - nu^2) / E`` > 0.
        M: None locks the rotation (``theta = 0``, M is an output); a value imposes
            ``dx sum x p = M`` and ``theta`` is an output.

    Returns:
        :class:`BemNormal`. Raises ValueError for bad inputs and RuntimeError when the
        active set does not converge or the contact reaches the window boundary.
    """
    grid = Grid(float(window[0]), float(window[1]), N)
    check_positive("P", P)
    check_positive("A", A)
    if M is not None and not np.isfinite(M):
        raise ValueError(f"M={M} is not allowed: need a finite moment or None")
    h = _sample_profile(h0, grid)
    _check_moment_carried(grid, h, P, M)
    active, p, delta, theta, iterations = _normal_multilevel(h0, grid, P, A, M)
    K = grid.influence(A)
    g = _normal_gap(K, grid.x, h, p, active, delta, theta)
    _check_normal_kkt(p, g, active, A * P)
    return _assemble_normal(h0, grid, A, h, p, g, delta, theta, P, active, iterations)


def check_positive(name: str, value: float) -> None:
    """Raise ValueError unless ``value`` is finite and > 0 (the message names it)."""
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name}={value} is not allowed: need a finite {name} > 0")


def _sample_profile(h0: Profile, grid: Grid) -> np.ndarray:
    """``h0`` at the centres; +inf allowed (excluded panels), NaN / -inf are not."""
    h = np.asarray(h0(grid.x), dtype=float)
    if h.shape != (grid.n,):
        raise ValueError(f"h0 returned shape {h.shape}: need a vectorised callable, ({grid.n},)")
    if np.any(np.isnan(h)) or np.any(h == -np.inf):
        raise ValueError("h0 returned NaN or -inf: allowed values are finite or +inf")
    if not np.any(np.isfinite(h)):
        raise ValueError("h0 is +inf on every panel of the window: no contact is possible")
    return h


def _check_moment_carried(grid: Grid, h: np.ndarray, P: float, M: float | None) -> None:
    if M is None:
        return
    xs = grid.x[np.isfinite(h)]
    if not xs.min() < M / P < xs.max():
        raise ValueError(
            f"M={M} tips the body off: the centre of pressure M/P={M / P:.6g} must lie "
            f"inside the contactable range ({xs.min():.6g}, {xs.max():.6g})"
        )


def _normal_multilevel(
    h0: Profile, grid: Grid, P: float, A: float, M: float | None
) -> tuple[np.ndarray, np.ndarray, float, float, int]:
    """Active-set solve, warm-started from the solve on a grid of ``n/2`` panels (cold, from
    every contactable panel, when that coarser solve fails: a contact narrower than a couple
    of coarse panels can make the coarse active set cycle)."""
    h = _sample_profile(h0, grid)
    start = np.isfinite(h)
    if grid.n > COARSEST_WARM_START and grid.n % 2 == 0:
        coarse = Grid(grid.x0, grid.x1, grid.n // 2)
        try:
            coarse_active = _normal_multilevel(h0, coarse, P, A, M)[0]
            start = np.repeat(coarse_active, 2) & np.isfinite(h)
        except RuntimeError:
            pass
    return _normal_active_set(grid.influence(A), grid, h, P, A, M, start)


def _normal_active_set(
    K: np.ndarray, grid: Grid, h: np.ndarray, P: float, A: float, M: float | None,
    start: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, float, float, int]:
    """Primal-dual active set (block pivoting) for the normal contact LCP.

    Each iteration solves the equality problem on the active set exactly, then drops
    panels with ``p <= 0`` and adds inactive panels with ``g < -GAP_TOL A P``. A repeated
    active set (cycling) or MAX_ITER iterations raise RuntimeError.
    """
    allowed = np.isfinite(h)
    active = start & allowed
    if active.sum() < 2:
        active = allowed.copy()
    seen: set[bytes] = set()
    tol = GAP_TOL * A * P
    for iteration in range(1, MAX_ITER + 1):
        p, delta, theta = _normal_equality_solve(K, grid, h, active, P, M)
        g = _normal_gap(K, grid.x, h, p, active, delta, theta)
        new = (active & (p > 0)) | (~active & allowed & (g < -tol))
        if np.array_equal(new, active):
            return active, p, delta, theta, iteration
        key = new.tobytes()
        if key in seen:
            raise RuntimeError(
                f"normal active set cycles at iteration {iteration} (N={grid.n}, "
                f"{int(new.sum())} active panels, min gap {g[allowed & ~active].min():.3e})"
            )
        seen.add(key)
        if new.sum() < 2:
            new = active & (p >= np.sort(p[active])[-2])
        active = new
    raise RuntimeError(
        f"normal active set did not converge in MAX_ITER={MAX_ITER} iterations (N={grid.n})"
    )


def _normal_equality_solve(
    K: np.ndarray, grid: Grid, h: np.ndarray, active: np.ndarray, P: float, M: float | None
) -> tuple[np.ndarray, float, float]:
    """Exact solve with the active set fixed: ``K_SS p_S = delta + theta x_S - h_S`` with
    ``dx sum p = P`` (and ``dx sum x p = M``). Rotation written about the active
    centroid ``xc`` for conditioning: ``delta = d' - theta xc``.
    """
    idx = np.flatnonzero(active)
    x = grid.x[idx]
    xc = float(x.mean())
    factor = sla.cho_factor(K[np.ix_(idx, idx)], lower=True)
    cols = [np.ones_like(x)] if M is None else [np.ones_like(x), x - xc]
    B = np.column_stack(cols)
    Z = sla.cho_solve(factor, np.column_stack([B, h[idx]]))
    rhs = np.array([P] if M is None else [P, M - P * xc]) / grid.dx + B.T @ Z[:, -1]
    lam = np.linalg.solve(B.T @ Z[:, :-1], rhs)
    p = np.zeros(grid.n)
    p[idx] = Z[:, :-1] @ lam - Z[:, -1]
    theta = 0.0 if M is None else float(lam[1])
    return p, float(lam[0] - theta * xc), theta


def _normal_gap(
    K: np.ndarray, x: np.ndarray, h: np.ndarray, p: np.ndarray, active: np.ndarray,
    delta: float, theta: float,
) -> np.ndarray:
    """Deformed gap ``g = h0 - theta x - delta + K p`` at the centres (inf where h0 is); p is
    zero off the active set, so ``K p`` needs no copy of K's active columns (at N = 16384 one
    took 0.6 GB beside K's 2.1 GB and exhausted an audit worker, seed 112231)."""
    with np.errstate(invalid="ignore"):
        g = h - theta * x - delta + K @ p
    g[active] = 0.0
    return g


def _check_normal_kkt(p: np.ndarray, g: np.ndarray, active: np.ndarray, AP: float) -> None:
    if np.any(p < 0) or np.any(g[~active] < -GAP_TOL * AP):
        raise RuntimeError(
            f"normal solution not admissible: min p = {p.min():.3e}, "
            f"min gap = {g[~active].min():.3e} (tolerance {-GAP_TOL * AP:.3e})"
        )


def _assemble_normal(
    h0: Profile, grid: Grid, A: float, h: np.ndarray, p: np.ndarray, g: np.ndarray,
    delta: float, theta: float, P: float, active: np.ndarray, iterations: int,
) -> BemNormal:
    runs = _runs(active)
    zones, singular = [], []
    for i0, i1 in runs:
        left, left_corner = _contact_edge(h0, grid, h, p, i0, i1, -1)
        right, right_corner = _contact_edge(h0, grid, h, p, i0, i1, +1)
        zones.append((left, right))
        singular.append((left_corner, right_corner))
    return BemNormal(
        grid=grid, x=grid.x, dx=grid.dx, A=A, p=p, g=g, h0=h, delta=delta, theta=theta,
        P=float(grid.dx * p.sum()), M=float(grid.dx * (grid.x * p).sum()), active=active,
        zones=tuple(zones), singular=tuple(singular), zone_panels=tuple(runs),
        zone_loads=tuple(float(grid.dx * p[i0:i1 + 1].sum()) for i0, i1 in runs),
        iterations=iterations,
    )


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Inclusive index ranges ``(i0, i1)`` of the runs of True in ``mask``."""
    padded = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(padded)
    return [(int(a), int(b) - 1) for a, b in zip(np.flatnonzero(d == 1),
                                                  np.flatnonzero(d == -1), strict=True)]


def _contact_edge(
    h0: Profile, grid: Grid, h: np.ndarray, p: np.ndarray, i0: int, i1: int, side: int
) -> tuple[float, bool]:
    """Edge of the zone of panels ``i0..i1`` on ``side`` (-1 left, +1 right).

    Corner (``h0 = inf`` on the next panel or just beyond the window, or a finite step
    of ``h0`` recognised by a pressure that rises towards the edge, zone >= 3 panels):
    the panel boundary; align corners with panel boundaries. Otherwise
    :func:`sqrt_edge` on the pressure. Contact reaching the window boundary with a
    finite ``h0`` beyond raises RuntimeError.
    """
    end = i0 if side < 0 else i1
    boundary = grid.x[end] + side * grid.dx / 2
    beyond = end + side
    if 0 <= beyond < grid.n:
        if not np.isfinite(h[beyond]):
            return float(boundary), True
    elif np.isfinite(h0(np.array([boundary + side * grid.dx / 2]))[0]):
        raise RuntimeError(
            f"contact reaches the window boundary x={boundary:.6g} where h0 is finite: "
            "enlarge the window"
        )
    else:
        return float(boundary), True
    inward = np.arange(end, i1 + 1) if side < 0 else np.arange(end, i0 - 1, -1)
    if inward.size >= 3 and p[inward[0]] > p[inward[1]]:
        return float(boundary), True
    return sqrt_edge(grid.x[inward], p[inward], grid.dx), False


def sqrt_edge(x: np.ndarray, f: np.ndarray, dx: float) -> float:
    """Sub-panel position where a quantity with a square-root edge vanishes.

    ``x, f``: panel centres and values ordered from the edge panel inward. Near a
    nonsingular edge ``f = c sqrt(d) (1 + O(d))`` (``d`` distance to the edge), so
    ``f^2 = c1 d + c2 d^2 + O(d^3)`` is smooth. The panels right at the edge carry the
    largest discretisation error (the edge panel is only partly in contact), so the
    estimator skips the ``EDGE_SKIP_PANELS`` panels nearest the edge, fits a quadratic
    to ``f^2`` through the next ``EDGE_FIT_PANELS`` and returns its root next to the edge
    panel (model bias ``O(dx^3)``). Shorter runs fit the quadratic through their first
    ``EDGE_FIT_PANELS`` panels without skipping (exact for a Hertz-like p^2), runs of two
    or three panels a straight line, a single panel returns its outer boundary.
    Observed (Hertz, tests/verification/test_bem.py): first order, ``|error| <= 0.05 dx``
    depending on where the exact edge falls inside its panel (0.17 dx for the line fit).
    """
    side = np.sign(x[0] - x[-1]) if x.size > 1 else 1.0
    outer = float(x[0] + side * dx / 2)
    t = x - x[0]
    lo, hi = sorted((-1.5 * side * dx, 1.5 * side * dx))
    if x.size >= 4:
        skip = EDGE_SKIP_PANELS if x.size >= EDGE_SKIP_PANELS + EDGE_FIT_PANELS else 0
        fit = slice(skip, skip + EDGE_FIT_PANELS)
        roots = np.roots(np.polyfit(t[fit], f[fit] ** 2, 2))
        roots = roots[np.isreal(roots)].real
        roots = roots[(roots >= lo) & (roots <= hi)]
        if roots.size:
            return float(x[0] + roots[np.argmin(np.abs(roots))])
    m = min(3, x.size)
    if m < 2:
        return outer
    slope, intercept = np.polyfit(t[:m], f[:m] ** 2, 1)
    if slope * side >= 0:
        return outer
    return float(x[0] + np.clip(-intercept / slope, lo, hi))
