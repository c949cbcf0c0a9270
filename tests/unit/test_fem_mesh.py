"""Unit tests of the fem mesh generator, mesh files, zone extraction and solvers."""

import numpy as np
import pytest

import fem
from fem.bulk import discretise, free_dofs, reduced_stiffness
from fem.condense import compliance, condense, pair_dofs
from fem.linsolve import available_backends, factorize
from fem.mesh import build_mesh, graded_sizes, read_mesh, write_msh
from fem.results import runs, sqrt_edge


def test_graded_sizes_sum_and_growth():
    s = graded_sizes(0.1, 10.0, 1.2)
    assert np.isclose(s.sum(), 10.0)
    assert np.allclose(s[1:] / s[:-1], 1.2)


def test_mesh_has_kinks_and_matching_interface():
    m = build_mesh(fem.MeshSpec(level=0), (-1.5, 1.5), kinks=(-1.0, 0.0, 1.0, 3.0))
    x1 = np.sort(m.bodies[0].p[0, m.nodes["contact_upper"]])
    x2 = np.sort(m.bodies[1].p[0, m.nodes["contact_lower"]])
    assert np.array_equal(x1, x2)
    for k in (-1.0, 0.0, 1.0, 3.0):
        assert np.min(np.abs(x1 - k)) < 1e-12
    width = 3.0 / 48
    assert np.isclose(m.h_min, width, rtol=0.2)


def test_q2_tributary_lengths_sum_to_width():
    m = build_mesh(fem.MeshSpec(level=0, order=2), (-1.0, 1.0))
    d = discretise(m, 2, 1.0, 0.3)
    x = d.interface.x
    assert np.isclose(d.interface.w.sum(), x[-1] - x[0])
    assert np.all(d.interface.w > 0)


def test_msh_round_trip_and_missing_boundary(tmp_path):
    m = build_mesh(fem.MeshSpec(level=-2), (-1.0, 1.0))
    path = write_msh(m, tmp_path / "two.msh")
    back = read_mesh(fem.MeshFile(path))
    assert back.bodies[0].p.shape == m.bodies[0].p.shape
    assert np.isclose(back.h_min, m.h_min)
    text = path.read_text().replace('"top"', '"lid"')
    bad = tmp_path / "bad.msh"
    bad.write_text(text)
    with pytest.raises(fem.InputError, match="top"):
        read_mesh(fem.MeshFile(bad))



@pytest.mark.parametrize("name, text, words", [
    ("garbage.msh", "not a mesh\n", "as either of ansys, gmsh"),
    ("cut.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0\n", "ValueError: cannot"),
    ("mesh.xyz", "1 2 3\n", "Could not deduce file format"),
])
def test_unreadable_mesh_file_one_error_nothing_printed(tmp_path, capsys, name, text, words):
    """meshio prints its readers' failures and ends the process (sys.exit) on a file none
    reads: read_mesh must raise one InputError instead, and print nothing."""
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(fem.InputError, match=f"mesh file .*{name}' cannot be read by meshio") as e:
        read_mesh(fem.MeshFile(path))
    assert words in str(e.value) and "allowed: a file in a format meshio reads" in str(e.value)
    assert capsys.readouterr() == ("", "")


def test_gmsh_file_read_without_printing(tmp_path, capsys):
    """A good gmsh file is read without the blank line meshio's ansys reader prints."""
    path = write_msh(build_mesh(fem.MeshSpec(level=-2), (-1.0, 1.0)), tmp_path / "two.msh")
    capsys.readouterr()
    read_mesh(fem.MeshFile(path))
    assert capsys.readouterr() == ("", "")

def test_mesh_file_with_triangles_is_refused(tmp_path):
    """A mixed file's triangles would leave holes in the bodies if dropped: one clear error."""
    import meshio

    m = build_mesh(fem.MeshSpec(level=-2), (-1.0, 1.0))
    good = meshio.read(write_msh(m, tmp_path / "two.msh"))
    quads = next(c for c in good.cells if c.type == "quad").data
    cells = [*good.cells, meshio.CellBlock("triangle", quads[:2, :3])]
    data = {k: [*v, np.zeros(2, dtype=v[0].dtype)] for k, v in good.cell_data.items()}
    mixed = meshio.Mesh(good.points, cells, cell_data=data, field_data=good.field_data)
    path = tmp_path / "mixed.msh"
    meshio.write(path, mixed, file_format="gmsh22", binary=False)
    with pytest.raises(fem.InputError, match="2 'triangle' cells: fem reads meshes of 4-node"):
        read_mesh(fem.MeshFile(path))



@pytest.mark.parametrize("order, words", [
    ([0, 2, 1, 3], "1 quad(s) not strictly convex"),  # a bow-tie
    ([3, 2, 1, 0], None),  # clockwise: turned round, read as the same mesh
])
def test_mesh_file_quads_convex_or_one_error(tmp_path, order, words):
    """A bow-tie quad ended in skfem's bare 'Zero Jacobian determinant': one InputError naming
    the file, the body and the element's corners; a clockwise quad is only turned round."""
    import meshio

    m = build_mesh(fem.MeshSpec(level=-2), (-1.0, 1.0))
    good = meshio.read(write_msh(m, tmp_path / "two.msh"))
    quads = next(c for c in good.cells if c.type == "quad").data.copy()
    quads[0] = quads[0][order]
    cells = [meshio.CellBlock("quad", quads) if c.type == "quad" else c for c in good.cells]
    path = tmp_path / "odd.msh"
    meshio.write(path, meshio.Mesh(good.points, cells, cell_data=good.cell_data,
                                   field_data=good.field_data), file_format="gmsh22",
                 binary=False)
    if words is None:
        back = read_mesh(fem.MeshFile(path))
        assert all(np.array_equal(np.sort(b.t, axis=0), np.sort(a.t, axis=0))
                   for a, b in zip(read_mesh(fem.MeshFile(tmp_path / "two.msh")).bodies,
                                   back.bodies, strict=True))
        return
    with pytest.raises(fem.InputError, match=r"odd.msh', the body with 'top': 1 quad\(s\) not "
                       r"strictly convex, the first with corners \(") as exc:
        read_mesh(fem.MeshFile(path))
    assert words in str(exc.value) and "no bow-ties" in str(exc.value)

def test_non_matching_interface_rejected(tmp_path):
    from skfem import MeshQuad

    from fem.mesh import from_bodies

    upper = MeshQuad.init_tensor(np.linspace(-1, 1, 5), np.linspace(0, 1, 3))
    lower = MeshQuad.init_tensor(np.linspace(-1, 1, 7), np.linspace(-1, 0, 3))
    with pytest.raises(fem.InputError, match="non-matching"):
        from_bodies(upper, lower, "test")


def test_runs_and_sqrt_edge_extrapolation():
    assert runs(np.array([0, 1, 1, 0, 1], bool)) == [(1, 2), (4, 4)]
    x = np.linspace(0.0, 1.0, 11)
    a = 0.73
    f = np.sqrt(np.clip(a - x, 0, None))
    inner = int(np.flatnonzero(f > 0)[-1])
    assert abs(sqrt_edge(x, f, (0, inner), +1) - a) < 1e-12


def test_backends_agree_and_schur_equals_blocked_solves():
    m = build_mesh(fem.MeshSpec(level=-2), (-1.0, 1.0))
    d = discretise(m, 1, 1.0, 0.3)
    free, index = free_dofs(d)
    K = reduced_stiffness(d, free)
    cand = np.flatnonzero(np.abs(d.interface.x) < 1.2)
    f1, f2 = pair_dofs(d, index, cand)
    ref = compliance(factorize(K, "scipy-splu"), f1, f2)
    for backend in available_backends():
        factor, C = condense(K, f1, f2, backend)
        assert factor.backend == backend
        assert np.allclose(C, ref, rtol=1e-9, atol=1e-12 * np.abs(ref).max())
        b = np.random.default_rng(0).normal(size=K.shape[0])
        assert np.allclose(K @ factor.solve(b), b, atol=1e-8 * np.abs(b).max())


def test_history_identical_with_every_backend():
    a = np.sqrt(2 * 3.64 * 0.01 * 100 / np.pi)
    runs_ = [
        fem.solve_history(
            lambda x: x**2 / 200.0,
            0.01,
            0.002,
            0.5,
            1.0,
            0.3,
            window=(-1.3 * a, 1.3 * a),
            mesh=fem.MeshSpec(level=-2),
            increments=fem.LoadPath(n_normal=2, n_tangential=1),
            backend=b,
        )
        for b in available_backends()
    ]
    for h, b in zip(runs_, available_backends(), strict=True):
        assert h.backend == b
        assert np.allclose(h.steps[-1].interface.p, runs_[0].steps[-1].interface.p, rtol=1e-8)
