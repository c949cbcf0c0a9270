"""Bad inputs give one clear fem.InputError naming the value and the allowed range."""

import numpy as np
import pytest

import fem

R = 100.0


def hertz(x):
    """Cylinder gap h0 = x^2 / (2R)."""
    return x**2 / (2 * R)


def run(**kw):
    args = dict(h0=hertz, P0=0.01, Q0=0.002, mu=0.5, E=1.0, nu=0.3)
    args.update(kw)
    h0 = args.pop("h0")
    keys = ("window", "mesh", "increments", "contact", "vtk_dir", "kinks")
    opts = {k: args.pop(k) for k in keys if k in args}
    opts.setdefault("window", (-2.0, 2.0))
    opts.setdefault("increments", fem.LoadPath(n_normal=2, n_tangential=1))
    return fem.solve_history(h0, args["P0"], args["Q0"], args["mu"], args["E"], args["nu"], **opts)


@pytest.mark.parametrize(
    "kw,match",
    [
        (dict(nu=0.5), "nu=0.5"),
        (dict(nu=-1.0), "nu=-1.0"),
        (dict(E=0.0), "E=0.0"),
        (dict(Q0=0.006), r"Q0=0.006.*mu\*P0"),
        (dict(P0=-1.0), "P0=-1.0"),
        (dict(mu=0.0), "mu=0.0"),
        (dict(window=None), "window=None"),
        (dict(mesh=fem.MeshSpec(order=3)), "order=3"),
        (dict(h0=lambda x: x - 10.0), "h0"),
        (dict(increments=fem.LoadPath(stage2=(0.001,))), "stage2"),
        (dict(mesh="/nonexistent/mesh.msh"), "does not exist"),
        # counts as floats passed the check and crashed in range() with a bare TypeError
        (dict(increments=fem.LoadPath(n_normal=2.0)), r"n_normal=2.0 is not allowed: need an "
                                                      "integer"),
        (dict(contact=fem.ContactSettings(max_cutbacks=2.0)), "max_cutbacks=2.0"),
        (dict(mesh=fem.MeshSpec(level=1.0)), "level=1.0"),
        # a user's h0 of the wrong shape or kind (numpy's broadcast error, float(None), or the
        # imaginary part dropped with a warning)
        (dict(h0=lambda x: np.zeros(3)), r"h0 returned an array of 3 float64 value\(s\) for"),
        (dict(h0=lambda x: None), "h0 returned None for"),
        (dict(h0=lambda x: hertz(x) + 0j), "complex128"),
    ],
)
def test_bad_input_is_one_clear_error(kw, match):
    with pytest.raises(fem.InputError, match=match):
        run(**kw)


def test_mesh_too_coarse_for_contact_zone():
    with pytest.raises(fem.InputError, match="mesh too coarse"):
        run(window=(-40.0, 40.0), mesh=fem.MeshSpec(level=-2, W=200.0))


def test_mesh_file_too_coarse_names_the_file():
    """A mesh file is refined in the file, not by MeshSpec.level: the advice says so."""
    from pathlib import Path

    path = Path(__file__).parents[2] / "meshes" / "hertz_L0.msh"
    with pytest.raises(fem.InputError, match=r"mesh too coarse.*: refine the mesh file "
                                             r".*hertz_L0.msh at the interface"):
        run(P0=1e-4, Q0=0.0, mesh=path, window=None)


def test_window_too_small_is_detected():
    with pytest.raises(fem.InputError, match="window too small"):
        run(window=(-0.4, 0.4), mesh=fem.MeshSpec(level=0, W=30.0))


def test_nonconvergence_raises_with_diagnostics():
    with pytest.raises(fem.ConvergenceError, match="stage 1"):
        run(contact=fem.ContactSettings(max_newton=1, max_cutbacks=0))


def test_at_unknown_q_lists_available():
    h = run(mesh=fem.MeshSpec(level=-1))
    with pytest.raises(fem.InputError, match="available"):
        h.at(2, Q=np.pi)


def test_a_contact_far_from_the_origin_solves_like_one_at_it():
    """skfem's facet basis inverts its mapping with an absolute tolerance that the rounding of x
    failed at |x| / h > ~4000 (a contact at x = 10, level 1: a bare skfem Exception); the
    interface weights are now computed on the mesh centred on the interface."""
    def zone(c: float):
        h = fem.solve_history(lambda x: hertz(x - c), 0.01, 0.0, 0.5, 1.0, 0.3,
                              window=(c - 2.0, c + 2.0), mesh=fem.MeshSpec(level=1),
                              increments=fem.LoadPath(n_normal=1, n_tangential=1))
        (a, b), = h.stage(1)[-1].contact_zones
        return a - c, b - c

    near, far = zone(0.0), zone(5000.0)
    assert far == pytest.approx(near, abs=1e-9)


def test_a_step_of_zero_length_keeps_the_state():
    """A stage 3 listed from Q0 (np.linspace(Q0, -Q0, n)) failed after 256 cut-backs ("active set
    cycles"): a step to the load already reached keeps the converged state."""
    h = run(Q0=0.004, increments=fem.LoadPath(n_normal=2, stage2=(0.002, 0.004),
                                              stage3=(0.004, 0.0, -0.004)))
    end2, start3 = h.stage(2)[-1], h.stage(3)[0]
    assert start3.Q == end2.Q and start3.stick_zones == end2.stick_zones
    assert np.array_equal(start3.interface.q, end2.interface.q)


@pytest.mark.parametrize("window", [(10.0, 12.0), (500.0, 501.0)])
def test_a_window_that_misses_the_contact_says_so(window):
    """It said "mesh too coarse ... raise MeshSpec.level or narrow the window" (a zone of one
    node at the window's end), or "h0 is infinite at (nearly) all interface nodes"."""
    with pytest.raises(fem.InputError, match="window too small or misplaced: the contact at P0 "
                                             "reaches the end of the contact candidates"):
        run(window=window, mesh=fem.MeshSpec(level=-1))


def test_vtk_dir_that_is_a_file_is_refused_before_the_solve(tmp_path):
    """A vtk_dir that is a file raised FileExistsError after the whole solve."""
    f = tmp_path / "afile"
    f.write_text("x")
    with pytest.raises(fem.InputError, match="vtk_dir=.* is not allowed: need a directory path "
                                             r"\(this is an existing file\)"):
        run(vtk_dir=f, contact=fem.ContactSettings(max_newton=1, max_cutbacks=0))


def test_max_cutbacks_is_bounded():
    with pytest.raises(fem.InputError, match="max_cutbacks=100 is not allowed: need an integer 0 "
                                             "<= max_cutbacks <= 20"):
        run(contact=fem.ContactSettings(max_cutbacks=100))


@pytest.mark.parametrize("kinks, words", [
    ((0.01, 0.01 + 1e-12), "apart from each other and from the fine region's ends"),
    ((0.5, 0.5 + 1e-9), "give them as one kink"),
])
def test_kinks_too_close_are_one_clear_error(kinks, words):
    """Kinks 1e-12 apart made a degenerate element: the equilibrium check then failed as a
    ConvergenceError (a solver failure) instead of an input error."""
    with pytest.raises(fem.InputError, match=words):
        run(kinks=kinks, mesh=fem.MeshSpec(level=-1))


def test_two_kinks_sharing_a_coarse_node_are_refused():
    """Outside the fine region a kink takes its nearest node; a second kink on the same node
    moved it away from the first silently."""
    from fem.mesh import snap_kinks

    x = np.array([0.0, 1.0, 2.0, 4.0, 8.0])
    assert list(snap_kinks(x, [3.9])) == [0.0, 1.0, 2.0, 3.9, 8.0]
    with pytest.raises(fem.InputError, match="share their nearest node"):
        snap_kinks(x, [3.7, 4.2])
    assert list(snap_kinks(x, [9.0])) == list(x)  # beyond the bodies: no node to take
