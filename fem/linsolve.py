"""Sparse direct solver backends: CHOLMOD, MKL pardiso or SciPy SuperLU.

The bulk stiffness is factorised once; every later solve (interface compliance,
full-field recovery) reuses the factor. ``factorize`` picks the fastest available
backend ('cholmod' from scikit-sparse, 'pypardiso', then 'scipy-splu') and reports
which one ran.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .errors import InputError

BACKENDS = ("cholmod", "pypardiso", "scipy-splu")


@dataclass(frozen=True)
class Factor:
    """A factorised symmetric positive definite matrix; ``solve(B)`` accepts 1-D or 2-D B.

    ``pair_solve(lam, out=None, rows=None)``, when set (``fem.condense``), gives ``solve`` of
    the pair loads of the pair forces ``lam`` (columns) by a cheaper route than a general
    solve; with ``out`` it writes the solution's dof i into ``out[rows[i]]`` (and returns out)
    instead of allocating it (the recovery fills the full-field array directly).
    """

    backend: str
    solve: Callable[[np.ndarray], np.ndarray]
    n: int
    pair_solve: Callable[..., np.ndarray] | None = None


def available_backends() -> tuple[str, ...]:
    """Backends importable in this environment, fastest first."""
    found = []
    try:
        import sksparse.cholmod  # noqa: F401

        found.append("cholmod")
    except ImportError:
        pass
    try:
        import pypardiso  # noqa: F401

        found.append("pypardiso")
    except ImportError:
        pass
    return (*found, "scipy-splu")


def factorize(K: sp.spmatrix, backend: str = "auto") -> Factor:
    """Factorise the SPD matrix K with the requested (or fastest available) backend."""
    avail = available_backends()
    if backend == "auto":
        backend = avail[0]
    if backend not in avail:
        raise InputError(
            f"backend={backend!r} is not available: choose one of {list(avail)} or 'auto'"
        )
    K = sp.csc_matrix(K)
    return Factor(backend=backend, solve=_FACTORIZERS[backend](K), n=K.shape[0])


def _cholmod(K: sp.csc_matrix) -> Callable:
    from sksparse.cholmod import cholesky

    f = cholesky(K)
    return lambda b: f(np.asarray(b, dtype=float))


def _pardiso(K: sp.csc_matrix) -> Callable:
    import pypardiso

    solver = pypardiso.PyPardisoSolver(mtype=2)
    A = sp.triu(K, format="csr")
    solver.factorize(A)
    return lambda b: solver.solve(A, np.asarray(b, dtype=float))


def _splu(K: sp.csc_matrix) -> Callable:
    from scipy.sparse.linalg import splu

    lu = splu(K, permc_spec="COLAMD")
    return lambda b: lu.solve(np.asarray(b, dtype=float))


_FACTORIZERS = {"cholmod": _cholmod, "pypardiso": _pardiso, "scipy-splu": _splu}
