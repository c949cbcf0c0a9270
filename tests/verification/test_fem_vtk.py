"""VTK output: round trip through pyvista and an off-screen screenshot."""

import numpy as np
import pytest

import fem

E, NU, R, P, MU = 1.0, 0.3, 100.0, 0.01, 0.5
A_HERTZ = np.sqrt(2 * 4 * (1 - NU**2) / E * P * R / np.pi)


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("vtk")
    h = fem.solve_history(
        lambda x: x**2 / (2 * R),
        P,
        0.5 * MU * P,
        MU,
        E,
        NU,
        window=(-1.3 * A_HERTZ, 1.3 * A_HERTZ),
        mesh=fem.MeshSpec(level=-1, order=2),
        increments=fem.LoadPath(n_normal=2, n_tangential=1),
        vtk_dir=out,
    )
    return h, out / "history.pvd"


def test_pvd_round_trip(written):
    pv = pytest.importorskip("pyvista")
    h, pvd = written
    assert pvd.is_file() and not list(pvd.parent.glob(".*.tmp"))
    reader = pv.get_reader(str(pvd))
    assert np.allclose(reader.time_values, [s.t for s in h.steps])
    step = h.steps[-1]
    reader.set_active_time_value(step.t)
    bodies, iface = reader.read()
    n_pts = sum(b.N for b in h.fields.disc.scalar_bases)
    assert bodies.n_points == n_pts
    assert bodies["displacement"].shape == (n_pts, 3)
    assert bodies["stress"].shape == (n_pts, 9)
    assert set(np.unique(bodies["body"])) == {1, 2}
    u1, u2 = h.displacement(step)
    assert np.allclose(bodies["displacement"][:, :2].ravel(), np.r_[u1, u2])
    s1, s2 = h.stress(step)
    assert np.allclose(bodies["stress"][:, 8], np.r_[s1[3], s2[3]])
    for name in ("p", "q", "status", "slip", "penetration"):
        assert np.allclose(iface[name], getattr(step.interface, name))


def test_offscreen_screenshot_not_blank(written, tmp_path):
    pv = pytest.importorskip("pyvista")
    _, pvd = written
    reader = pv.get_reader(str(pvd))
    reader.set_active_time_value(reader.time_values[-1])
    bodies = reader.read()[0]
    try:
        plotter = pv.Plotter(off_screen=True, window_size=(400, 300))
        plotter.add_mesh(bodies, scalars="von_mises")
        plotter.view_xy()
        img = plotter.screenshot(str(tmp_path / "shot.png"), return_img=True)
        plotter.close()
    except Exception as exc:  # rendering stack missing (no EGL/OSMesa/X)
        pytest.skip(f"off-screen rendering impossible here: {exc}")
    assert (tmp_path / "shot.png").is_file()
    assert img.std() > 1.0
    assert len(np.unique(img.reshape(-1, img.shape[-1]), axis=0)) > 10


def test_bodies_readable_by_meshio_in_single_precision(written):
    import meshio

    h, pvd = written
    step = h.steps[-1]
    bodies = meshio.read(pvd.parent / f"bodies_{step.index:04d}.vtu")
    assert bodies.point_data["von_mises"].dtype == np.float32
    u1, u2 = h.displacement(step)
    want = np.r_[u1, u2]
    got = bodies.point_data["displacement"][:, :2].ravel()
    assert np.max(np.abs(got - want)) <= 1e-6 * np.max(np.abs(want))  # float32: 6e-8


def test_stage_ends_only(written, tmp_path):
    h, _ = written
    pvd = fem.write_vtk(h, tmp_path, steps="ends")
    ends = [h.stage(k)[-1].index for k in (1, 2, 3) if h.stage(k)]
    loaded = h.stage(2)[-1].index
    names = sorted(p.name for p in tmp_path.glob("*.vtu"))
    assert names == sorted([f"bodies_{loaded:04d}.vtu"] + [f"interface_{i:04d}.vtu" for i in ends])
    assert pvd.read_text().count("<DataSet") == len(ends) + 1 < 2 * len(h.steps)
    with pytest.raises(fem.InputError, match="steps = 'some'"):
        fem.write_vtk(h, tmp_path, steps="some")
