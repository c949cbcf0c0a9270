"""A stored mesh file gives the same history as the generator it was written from."""

from pathlib import Path

import numpy as np
import pytest

import fem

MESHES = Path(__file__).resolve().parents[2] / "meshes"
E, NU, R, P, MU = 1.0, 0.3, 100.0, 0.01, 0.5
A_HERTZ = np.sqrt(2 * 4 * (1 - NU**2) / E * P * R / np.pi)


def test_stored_hertz_mesh_matches_generated():
    path = MESHES / "hertz_L0.msh"
    if not path.is_file():
        pytest.fail(f"stored mesh {path} missing: run python meshes/generate.py")
    kw = dict(
        window=(-1.3 * A_HERTZ, 1.3 * A_HERTZ), increments=fem.LoadPath(n_normal=3, n_tangential=2)
    )
    gap = lambda x: x**2 / (2 * R)  # noqa: E731
    from_file = fem.solve_history(gap, P, 0.5 * MU * P, MU, E, NU, mesh=fem.MeshFile(path), **kw)
    generated = fem.solve_history(gap, P, 0.5 * MU * P, MU, E, NU, mesh=fem.MeshSpec(level=0), **kw)
    for a, b in zip(from_file.steps, generated.steps, strict=True):
        assert np.allclose(a.interface.p, b.interface.p, rtol=1e-8, atol=1e-12)
        assert np.allclose(a.contact_zones, b.contact_zones, rtol=1e-8)
