"""Sparse direct solver backends: CHOLMOD, MKL pardiso or SciPy SuperLU.

The bulk stiffness is factorised once; every later solve (interface compliance,
full-field recovery) reuses the factor. ``factorize`` picks the fastest available
backend ('cholmod' from scikit-sparse, 'pypardiso', then 'scipy-splu') and reports
which one ran.

CHOLMOD runs on the system BLAS (OpenBLAS), which picks its kernels by the CPU model it knows:
an OpenBLAS older than the CPU falls back to its slowest kernels (Prescott, SSE3).  This module
imports scikit-sparse's CHOLMOD (:func:`import_cholmod`) with ``OPENBLAS_CORETYPE`` naming the
kernels the CPU's instruction sets allow, for that import only and unless the user has set it:
NumPy's and SciPy's own OpenBLAS are loaded before and keep their choice (issue 28).  It takes
effect only where this module is imported before anything else loads CHOLMOD (``scipy.optimize``
tries scikit-sparse on import): ``compare``, ``benchmarks/fingerprint.py`` and the tests'
``conftest.py`` import it first; a process that loads CHOLMOD earlier keeps OpenBLAS's choice.
"""

from __future__ import annotations

import os
from collections.abc import Callable, MutableMapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from .errors import InputError

BACKENDS = ("cholmod", "pypardiso", "scipy-splu")
#: OpenBLAS kernel sets (``OPENBLAS_CORETYPE``) by the instruction sets they need, best
#: first.  The system OpenBLAS 0.3.21 does not know an Emerald Rapids CPU (family 6, model
#: 207) and fell back to Prescott: cattaneo rings body 1's CHOLMOD factorisation CPU s
#: (natural_cholesky) Prescott / SkylakeX: level 5 7.2-9.2 / 3.8-4.1, level 6 31.6-37.0 /
#: 11.3-12.0.
OPENBLAS_CORES = (
    ("SkylakeX", frozenset({"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"})),
    ("Haswell", frozenset({"avx2", "fma"})),
)
#: The CPU's instruction-set flags (Linux); elsewhere OpenBLAS is left to its own choice.
CPUINFO = Path("/proc/cpuinfo")


def blas_core_for(flags: frozenset[str] | set[str]) -> str | None:
    """The best OPENBLAS_CORES kernel set whose instruction sets are all in ``flags``."""
    return next((core for core, need in OPENBLAS_CORES if need <= flags), None)


def cpu_flags(cpuinfo: Path = CPUINFO) -> frozenset[str]:
    """Instruction-set flags of the first CPU listed in ``cpuinfo`` (empty if unreadable)."""
    try:
        text = cpuinfo.read_text()
    except OSError:
        return frozenset()
    for line in text.splitlines():
        key, _, value = line.partition(":")
        if key.strip() == "flags":
            return frozenset(value.split())
    return frozenset()


def prefer_blas_kernels(environ: MutableMapping[str, str],
                        flags: frozenset[str]) -> str | None:
    """Set ``OPENBLAS_CORETYPE`` in ``environ`` to the best OPENBLAS_CORES kernel set the CPU
    ``flags`` allow, unless it is set already; returns the value set (None: nothing set)."""
    if "OPENBLAS_CORETYPE" in environ:
        return None
    core = blas_core_for(flags)
    if core is not None:
        environ["OPENBLAS_CORETYPE"] = core
    return core


def import_cholmod() -> bool:
    """Import ``sksparse.cholmod`` (loading the system BLAS it links) with
    :func:`prefer_blas_kernels` in effect for the import only; False if it is not installed.
    An OpenBLAS reads ``OPENBLAS_CORETYPE`` once, when it is loaded: SciPy's linear algebra
    (and NumPy's) are imported first so that theirs keep their own choice."""
    import scipy.linalg  # noqa: F401

    core = prefer_blas_kernels(os.environ, cpu_flags())
    try:
        import sksparse.cholmod  # noqa: F401
    except ImportError:
        return False
    finally:
        if core is not None:
            del os.environ["OPENBLAS_CORETYPE"]
    return True


import_cholmod()


@dataclass(frozen=True)
class Factor:
    """A factorised symmetric positive definite matrix; ``solve(B)`` accepts 1-D or 2-D B.

    ``pair_solve(lam, out=None, rows=None, add=False)``, when set (``fem.condense``), gives
    ``solve`` of the pair loads of the pair forces ``lam`` (columns) by a cheaper route than a
    general solve; with ``out`` it writes the solution's dof i into ``out[rows[i]]`` (adds it
    with ``add``; and returns out) instead of allocating it (the recovery fills the full-field
    array, which holds the far field already, directly).
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
