"""Shared test set-up: single-threaded BLAS, a hypothesis profile and solution checkers.

Checkers are fixtures (not importable helpers) so that every test directory can use them
without packages: ``zone_integral`` integrates ``f(x) p(x)`` over each contact zone by
Gauss-Jacobi quadrature with the zone's own edge exponents, independently of the solver's
contour-integral zone loads.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # threaded BLAS on 2 cores is 30-100x slower

# fem.linsolve loads CHOLMOD with the CPU's BLAS kernels: before scipy.optimize and
# scipy.integrate (below, and tabulated profiles) do, as in the command line.
import fem.linsolve  # noqa: E402, F401

# isort: split
from collections.abc import Callable  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from hypothesis import HealthCheck, settings  # noqa: E402
from scipy.integrate import quad  # noqa: E402
from scipy.special import roots_jacobi  # noqa: E402

settings.register_profile(
    "multicontact", deadline=None, derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile("multicontact")

@pytest.fixture(scope="session")
def gen():
    """meshes/generate.py as a module (meshes/ is not a package)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "meshes" / "generate.py"
    spec = importlib.util.spec_from_file_location("meshes_generate", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


ZONE_QUAD_NODES = 400
"""Gauss-Jacobi nodes per zone: the smooth factor p / (edge weights) is analytic in the zone,
with its nearest singularity at the neighbouring zone's edge; 400 nodes reach roundoff for
gaps down to ~1e-3 of a zone width."""


QUAD_OPTS = {"epsabs": 0.0, "epsrel": 1e-13, "limit": 400}
"""scipy quad settings for zones with profile kinks (log-singular pressure at a wedge apex)."""


def _edge_exponents(flags: tuple[bool, bool]) -> tuple[float, float]:
    return (-0.5 if flags[0] else 0.5), (-0.5 if flags[1] else 0.5)


def _gauss_jacobi_zone(sol, f, a: float, b: float, al: float, ah: float) -> float:
    t, w = roots_jacobi(ZONE_QUAD_NODES, ah, al)
    half = 0.5 * (b - a)
    x = 0.5 * (a + b) + half * t
    smooth = sol.pressure(x) / ((x - a) ** al * (b - x) ** ah)
    return float(np.sum(w * half ** (1 + al + ah) * smooth * f(x)))


def _quad_zone(sol, f, a: float, b: float, kinks: list[float]) -> float:
    """Split at kinks; next to a true edge ``x = edge + (mid - edge) u^2`` turns the
    ``d^(+-1/2)`` edge behaviour into a smooth integrand in u."""
    def g(x: float) -> float:
        return float(sol.pressure(x) * f(np.array([x]))[0])

    def near_edge(edge: float, mid: float) -> float:
        span = mid - edge
        return quad(lambda u: g(edge + span * u * u) * 2 * span * u, 0.0, 1.0,
                    **QUAD_OPTS)[0]

    cuts = [a, *kinks, b]
    total = 0.0
    for lo, hi in zip(cuts[:-1], cuts[1:], strict=True):
        mid = 0.5 * (lo + hi)
        if lo == a:
            total += near_edge(lo, mid)
            lo = mid
        if hi == b:
            total -= near_edge(hi, mid)
            hi = mid
        if hi > lo:
            total += quad(g, lo, hi, **QUAD_OPTS)[0]
    return total


def _zone_integrals(sol, f: Callable[[np.ndarray], np.ndarray]) -> list[float]:
    """``int_{a_k}^{b_k} f(x) p(x) dx`` per zone; ``p ~ d^(+-1/2)`` at each edge (d: distance).

    Smooth profiles: Gauss-Jacobi with the edge exponents. Zones holding kinks of ``h0``
    (where p has a log singularity): adaptive quad split at the kinks.
    """
    out = []
    for (a, b), flags in zip(sol.zones, sol.singular, strict=True):
        al, ah = _edge_exponents(flags)
        kinks = [k for k in sol.profile.kinks if a < k < b]
        if kinks:
            out.append(_quad_zone(sol, f, a, b, kinks))
        else:
            out.append(_gauss_jacobi_zone(sol, f, a, b, al, ah))
    return out


@pytest.fixture
def zone_integral() -> Callable:
    """``zone_integral(sol, f=1)`` -> list of ``int f p dx`` over each zone of ``sol``."""
    def integrate(sol, f: Callable[[np.ndarray], np.ndarray] | None = None) -> list[float]:
        return _zone_integrals(sol, f if f is not None else np.ones_like)

    return integrate


def _points_outside(sol, n_per_gap: int = 40) -> np.ndarray:
    """Points strictly outside the zones: in every gap and beyond both ends (finite h0)."""
    z = np.asarray(sol.zones)
    span = z[-1, 1] - z[0, 0]
    t = 0.5 * (1 - np.cos(np.pi * (np.arange(n_per_gap) + 0.5) / n_per_gap))
    pts = [b + (a - b) * t for b, a in zip(z[:-1, 1], z[1:, 0], strict=True)]
    d = span * np.geomspace(1e-4, 2.0, n_per_gap)
    pts += [z[0, 0] - d, z[-1, 1] + d]
    x = np.concatenate(pts)
    return x[np.isfinite(sol.profile.h0(x))]


def _points_inside(sol, n_per_zone: int = 60) -> np.ndarray:
    """Chebyshev points strictly inside every zone (dense near the edges)."""
    z = np.asarray(sol.zones)
    t = 0.5 * (1 - np.cos(np.pi * (np.arange(n_per_zone) + 0.5) / n_per_zone))
    return (z[:, :1] + (z[:, 1:] - z[:, :1]) * t[None, :]).ravel()


@pytest.fixture
def points_outside() -> Callable:
    return _points_outside


@pytest.fixture
def points_inside() -> Callable:
    return _points_inside


@pytest.fixture(scope="session")
def refined_run(contact_case) -> Callable:
    """``refined_run(name, level)``: the library case refined as ``multicontact converge`` refines
    it (level and far field: compare.convergence.refined_growth), run once per session by the
    plugin's ``contact_case`` (at the library level: the library run itself).  Shared by the
    tests of several files: read it, never change it."""
    from compare.cases import load_case
    from compare.convergence import refined_growth

    def run(name: str, level: int):
        case = load_case(name)
        changes = {"level": level, "growth": refined_growth(case, level)}
        return contact_case(name, **({} if case.with_fem(**changes) == case else changes))

    return run
