"""meshes/: the parametric .geo sources (tensor layout), the stored level-0 meshes (the default
ring layout) and the README table agree with each other and with fem's generator (no gmsh
needed: meshes/generate.py checks the meshes it makes from the .geo against the same
generator)."""

import re
from pathlib import Path

import numpy as np
import pytest

import fem
from fem.mesh import NEAR_DEPTH, read_mesh
from fem.settings import N_WINDOW_LEVEL0

MESHES = Path(__file__).resolve().parents[2] / "meshes"
E, NU, R, P = 1.0, 0.3, 100.0, 0.01
A_HERTZ = np.sqrt(2 * 4 * (1 - NU**2) / E * P * R / np.pi)
#: gmsh puts a block corner exactly on each kink (measured offset 0.0).
KINK_ATOL = 1e-12
#: Rows of the README table of fem's generator (not the graded gmsh table: gmsh's own meshes).
ROW = re.compile(r"^\| ((?!\w*_graded_)(\w+?)(_tensor)?_L(\d+)) \|.*\|$", re.MULTILINE)
#: fem writes its .msh node coordinates to 16 significant digits (measured offset 0).
WRITE_RTOL = 1e-15


def readme_rows() -> dict:
    """README table rows by mesh name -> (case, level, layout, row text)."""
    text = (MESHES / "README.md").read_text()
    return {m[1]: (m[2], int(m[4]), "tensor" if m[3] else "rings", m[0])
            for m in ROW.finditer(text)}


def test_geo_parameters_are_the_fem_defaults(gen):
    spec = fem.MeshSpec(layout="tensor")
    for case in gen.CASES:
        p = gen.geo_parameters(case)
        assert p["level"] == 0
        assert p["n_window"] == N_WINDOW_LEVEL0
        assert (p["growth"], p["margin"], p["size_factor"]) == (
            spec.growth,
            spec.margin,
            spec.size_factor,
        )
        assert p["near_depth"] == NEAR_DEPTH
    hertz = gen.geo_parameters("hertz")
    assert np.isclose(hertz["xmax"], 1.3 * A_HERTZ, rtol=1e-14)
    assert (hertz["xmin"], hertz["kinks"]) == (-hertz["xmax"], ())
    wedge = gen.geo_parameters("double_wedge")
    assert (wedge["xmin"], wedge["xmax"], wedge["kinks"]) == (-1.6, 1.6, (-1.0, 0.0, 1.0))


def test_readme_table_is_the_generator_at_the_geo_parameters(gen):
    rows = readme_rows()
    assert sorted(rows) == sorted(gen.mesh_name(c, lv, layout) for c in gen.CASES
                                  for lv in gen.LEVELS for layout in ("rings", "tensor"))
    for name, (case, level, layout, row) in rows.items():
        p = gen.geo_parameters(case)
        mesh = gen.reference_mesh(case, level, layout)
        assert gen.table_row(name, (p["xmin"], p["xmax"]), mesh) == row


@pytest.mark.parametrize("case", ["hertz", "double_wedge"])
def test_stored_mesh_is_the_default_ring_grid(gen, case):
    path = MESHES / f"{case}_L0.msh"
    if not path.is_file():
        pytest.fail(f"stored mesh {path} missing: run python meshes/generate.py 0")
    mesh = read_mesh(fem.MeshFile(path))
    p = gen.geo_parameters(case)
    row = readme_rows()[f"{case}_L0"][3]
    assert gen.table_row(f"{case}_L0", (p["xmin"], p["xmax"]), mesh) == row
    offset = gen.grid_offset(mesh, gen.reference_mesh(case, 0, "rings"))
    print(f"{case}_L0: nodes {offset:.2e} W off fem's ring generator")
    assert offset <= WRITE_RTOL
    for body, name in ((0, "contact_upper"), (1, "contact_lower")):
        x = mesh.bodies[body].p[0, mesh.nodes[name]]
        assert all(np.min(np.abs(x - k)) < KINK_ATOL for k in p["kinks"])


def test_grid_offset_sees_a_moved_node(gen):
    mesh = gen.reference_mesh("hertz", 0)
    moved = gen.reference_mesh("hertz", 0)
    moved.bodies[0].p[0, 7] += 1e-6
    assert gen.grid_offset(mesh, mesh) == 0.0
    assert gen.grid_offset(moved, mesh) > gen.GRID_RTOL
    assert gen.grid_offset(gen.reference_mesh("hertz", 1), mesh) == np.inf


def test_graded_geo_parameters_are_the_ring_defaults(gen):
    spec = fem.MeshSpec()
    assert spec.layout == "rings"
    for case in gen.CASES:
        p = gen.geo_parameters(case, "graded")
        assert (p["level"], p["layout"], p["n_window"]) == (0, 1, N_WINDOW_LEVEL0)
        assert (p["growth"], p["margin"], p["size_factor"]) == (
            spec.growth, spec.margin, spec.size_factor)
        for level in (0, 2):  # the rings' rate: fem.mesh.near_growth
            _, rate, _, _ = gen.graded_law(p, level)
            assert rate == fem.mesh.near_growth(fem.MeshSpec(level=level))


def test_generate_without_gmsh_says_how_to_get_it(gen, monkeypatch):
    monkeypatch.delenv("GMSH", raising=False)
    monkeypatch.setenv("PATH", "")
    monkeypatch.setattr(gen, "gmsh_module_available", lambda: False)
    with pytest.raises(SystemExit, match="pip install gmsh"):
        gen.gmsh_command()


def test_gmsh_command_prefers_gmsh_env_then_the_module(gen, monkeypatch):
    monkeypatch.setenv("GMSH", "/opt/gmsh/bin/gmsh")
    assert gen.gmsh_command() == ["/opt/gmsh/bin/gmsh"]
    monkeypatch.delenv("GMSH")
    monkeypatch.setattr(gen, "gmsh_module_available", lambda: True)
    assert gen.gmsh_command()[1:] == ["-c", gen.GMSH_MAIN]
