"""Validation of the public arguments of :func:`fem.solve_history` (type, finiteness, range).

The same pattern as ``analytic/_validate.py`` (fem and analytic never import each other): every
check returns the converted value or raises :class:`fem.errors.InputError` with one message
``"<name>=<value> is not allowed: need <what is allowed>"``.  Numbers may be Python or numpy
scalars, 0-d arrays or 1-element sequences; ``bool``, ``None``, strings and complex values are
refused, and non-finite values never reach the solver.
"""

from __future__ import annotations

import contextlib
import math
import numbers
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from .errors import InputError
from .settings import ContactSettings, LoadPath, MeshFile, MeshSpec

BACKENDS = ("auto", "cholmod", "pypardiso", "scipy-splu")
#: Halvings of one increment at most: 2**20 sub-increments of one load step; max_cutbacks=100
#: would try up to 2**100 before it gave up (the default, 8, is 256).
MAX_CUTBACKS = 20


def refuse(name: str, value: object, need: str) -> InputError:
    """The one error message: the parameter, its value and what is allowed."""
    text = repr(value)
    return InputError(f"{name}={text if len(text) <= 80 else text[:77] + '...'} is not allowed: "
                      f"need {need}")


def real(name: str, value: object, need: str = "a finite number",
         test: Callable[[float], bool] | None = None) -> float:
    """A finite real number (scalar, 0-d or 1-element array) that passes ``test``."""
    x = None
    if isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)):
        x = float(value)
    elif value is not None and not isinstance(value, (bool, np.bool_, str, bytes)):
        with contextlib.suppress(TypeError, ValueError):
            arr = np.asarray(value)
            x = float(arr.reshape(())) if arr.size == 1 and arr.dtype.kind in "iuf" else None
    if x is None or not math.isfinite(x) or (test is not None and not test(x)):
        raise refuse(name, value, need)
    return x


def integer(name: str, value: object, low: int, high: int | None = None) -> int:
    """An integer (Python or numpy; not a float such as 2.0, which the solver's ``range`` and
    array shapes refuse later with a bare TypeError) in ``[low, high]``."""
    need = f"an integer >= {low}" if high is None else f"an integer {low} <= {name} <= {high}"
    if not isinstance(value, numbers.Integral) or isinstance(value, (bool, np.bool_)):
        raise refuse(name, value, need)
    return int(real(name, value, need, lambda v: v >= low and (high is None or v <= high)))


def _optional_positive(name: str, value: object) -> None:
    if value is not None:
        real(name, value, "a finite value > 0 or None (default)", lambda v: v > 0)


def check_scalars(P0, Q0, mu, E, nu, M) -> tuple[float, float, float, float, float, float | None]:
    """The loads and the material as floats (ranges: P0, mu, E > 0; -1 < nu < 0.5; Q0 >= 0)."""
    P0 = real("P0", P0, "a finite normal load P0 > 0", lambda v: v > 0)
    mu = real("mu", mu, "a finite friction coefficient mu > 0", lambda v: v > 0)
    Q0 = real("Q0", Q0, f"0 <= Q0 <= mu*P0 = {mu * P0:g}",
              lambda v: 0 <= v <= mu * P0 * (1 + 1e-12))
    E = real("E", E, "a finite Young's modulus E > 0", lambda v: v > 0)
    nu = real("nu", nu, "a Poisson ratio -1 < nu < 0.5", lambda v: -1 < v < 0.5)
    M = None if M is None else real("M", M, "a finite moment or None")
    return P0, Q0, mu, E, nu, M


def check_settings(h0, mesh, contact, increments, kinks, window, vtk_dir, backend) -> None:
    """Types and ranges of the non-scalar arguments of :func:`fem.solve_history`."""
    if not callable(h0):
        raise refuse("h0", h0, "a vectorised callable h0(x) >= 0 (np.inf where no contact)")
    if isinstance(mesh, MeshSpec):
        check_mesh_spec(mesh)
    if isinstance(mesh, (MeshSpec, MeshFile)) and not isinstance(mesh.incompatible, bool):
        raise refuse("incompatible", mesh.incompatible, "True or False")
    if not (mesh is None or isinstance(mesh, (MeshSpec, MeshFile, str, Path))):
        raise refuse("mesh", mesh, "None, a MeshSpec, a MeshFile or a mesh file path")
    if contact is not None:
        check_contact(contact)
    if increments is not None:
        check_load_path(increments)
    _vector("kinks", kinks, 0)
    if window is not None:
        _windows(window)
    if not (vtk_dir is None or isinstance(vtk_dir, (str, Path))):
        raise refuse("vtk_dir", vtk_dir, "None or a directory path")
    if vtk_dir is not None:
        _writable_dir(Path(vtk_dir))
    if not isinstance(backend, str) or backend not in BACKENDS:
        raise refuse("backend", backend, "one of " + ", ".join(map(repr, BACKENDS)))


def _vector(name: str, value: object, min_size: int) -> np.ndarray:
    need = f"a 1-D sequence of at least {min_size} finite numbers"
    if value is None or isinstance(value, (str, bytes)):
        raise refuse(name, value, need)
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):
        raise refuse(name, value, need) from None
    if arr.dtype.kind not in "iuf" or arr.ndim > 1 or arr.size < min_size:
        raise refuse(name, value, need)
    arr = arr.astype(float).reshape(-1)
    if not np.all(np.isfinite(arr)):
        raise refuse(name, value, need)
    return arr


def _windows(window: object) -> np.ndarray:
    """``(xmin, xmax)`` or one such pair per expected zone, as an (n, 2) array."""
    need = "None, (xmin, xmax) or a sequence of (xmin, xmax) pairs, with finite xmin < xmax"
    if isinstance(window, (str, bytes)):
        raise refuse("window", window, need)
    try:
        arr = np.asarray(window)
    except (TypeError, ValueError):
        raise refuse("window", window, need) from None
    if arr.dtype.kind not in "iuf" or arr.ndim not in (1, 2) or arr.shape[-1] != 2 or arr.size < 2:
        raise refuse("window", window, need)
    arr = arr.astype(float).reshape(-1, 2)
    if not (np.all(np.isfinite(arr)) and np.all(arr[:, 1] > arr[:, 0])):
        raise refuse("window", window, need)
    return arr


def check_mesh_spec(spec: MeshSpec) -> None:
    """Field types and ranges of a :class:`MeshSpec`."""
    integer("level", spec.level, -3, 6)
    integer("order", spec.order, 1, 2)
    integer("n_window", spec.n_window, 2)
    _optional_positive("W", spec.W)
    _optional_positive("H", spec.H)
    real("growth", spec.growth, "1 < growth <= 2", lambda v: 1 < v <= 2)
    real("margin", spec.margin, "0 <= margin <= 1", lambda v: 0 <= v <= 1)
    real("size_factor", spec.size_factor, "size_factor >= 2", lambda v: v >= 2)


def check_contact(c: ContactSettings) -> None:
    """Field types and ranges of a :class:`ContactSettings`."""
    if not isinstance(c, ContactSettings):
        raise refuse("contact", c, "None or a fem.ContactSettings")
    for name in ("k_n", "k_t", "pen_tol"):
        _optional_positive(name, getattr(c, name))
    real("penalty_factor", c.penalty_factor, "a finite value > 0", lambda v: v > 0)
    if not isinstance(c.augmented, (bool, np.bool_)):
        raise refuse("augmented", c.augmented, "True or False")
    integer("max_uzawa", c.max_uzawa, 1)
    real("newton_tol", c.newton_tol, "0 < newton_tol < 1", lambda v: 0 < v < 1)
    integer("max_newton", c.max_newton, 1)
    integer("max_cutbacks", c.max_cutbacks, 0, MAX_CUTBACKS)


def _writable_dir(path: Path) -> None:
    """Refuse a ``vtk_dir`` that is a file, or whose nearest existing folder cannot be written
    (before the solve: the series is written after it)."""
    if path.exists() and not path.is_dir():
        raise refuse("vtk_dir", str(path), "a directory path (this is an existing file)")
    parent = path
    while not parent.exists():
        parent = parent.parent
    if not (parent.is_dir() and os.access(parent, os.W_OK | os.X_OK)):
        raise refuse("vtk_dir", str(path), f"a directory that can be created or written ({parent} "
                     "cannot be written)")


def check_load_path(path: LoadPath) -> None:
    """Field types and ranges of a :class:`LoadPath` (the Q sequences: in validate_path)."""
    if not isinstance(path, LoadPath):
        raise refuse("increments", path, "None or a fem.LoadPath")
    integer("n_normal", path.n_normal, 1)
    integer("n_tangential", path.n_tangential, 1)
    for name in ("stage2", "stage3"):
        if getattr(path, name) is not None:
            _vector(name, getattr(path, name), 1)
