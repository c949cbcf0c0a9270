"""Two-body quad meshes: graded tensor-product generator and meshio reader.

Geometry (see docs/conventions.md): body 1 (upper) occupies ``[xc-W, xc+W] x [0, H]``, body 2
(lower) ``[xc-W, xc+W] x [-H, 0]``. Both are flat rectangles: the profile enters only
through the initial gap ``h0(x)`` of the contact law (small-slope / half-plane
assumption, the same one the analytic solution makes). The two interface node rows
have the same x (node-to-node contact). Boundaries: ``contact_upper`` (body 1,
y = 0), ``contact_lower`` (body 2, y = 0), ``top`` (body 1, y = H, tied to the
rigid loading plate) and ``bottom`` (body 2, y = -H, clamped).
"""

from __future__ import annotations

import contextlib
import io
import os
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from skfem import MeshQuad

from .errors import InputError
from .rings import convex, quad_area, ring_body
from .settings import MeshFile, MeshSpec, validate_mesh_spec

BOUNDARY_NAMES = ("contact_upper", "contact_lower", "top", "bottom")
#: Surface cells (meshio names) a mesh file may not hold: fem's bodies are 4-node quads only.
NON_QUAD_CELLS = ("triangle", "triangle6", "triangle7", "quad8", "quad9", "polygon")
#: Relative tolerance (to the smallest interface element) for matching node x.
MATCH_TOL = 1e-6
#: Nodes with |y| below this (length) lie on the interface line y = 0.
INTERFACE_ATOL = 1e-12
#: Depth (multiple of the widest window) of the near-field grading under the contact: at 0.5
#: the Hertz width stayed 0.033 % short at level 1, at 2 0.020 %, at 4 0.019 % (1.1x the dofs).
NEAR_DEPTH = 2.0
#: What a mesh file may be (read_meshio's error).
MESHIO_ALLOWED = "a file in a format meshio reads, named by its extension (.msh, .vtu, .inp, ...)"


@dataclass(frozen=True)
class TwoBodyMesh:
    """Meshes of body 1 (upper) and body 2 (lower) with their named boundary nodes.

    bodies: (mesh1, mesh2) scikit-fem MeshQuad objects.
    nodes: boundary name -> vertex indices in the body that owns it
        (contact_upper, top: body 1; contact_lower, bottom: body 2).
    h_min: smallest element length along the interface.
    source: 'generated' or the file path.
    """

    bodies: tuple
    nodes: dict
    h_min: float
    source: str

    @property
    def n_elements(self) -> int:
        """Total number of quads of both bodies."""
        return int(sum(m.t.shape[1] for m in self.bodies))


def graded_sizes(first: float, length: float, growth: float) -> np.ndarray:
    """Element sizes starting at ``first`` and growing by ``growth``, summing to ``length``."""
    if length <= 0:
        return np.zeros(0)
    n = max(1, int(np.ceil(np.log1p(length * (growth - 1) / first) / np.log(growth))))
    sizes = first * growth ** np.arange(n)
    return sizes * (length / sizes.sum())


def as_windows(window) -> tuple[tuple[float, float], ...]:
    """One window (xmin, xmax) or several ((xmin, xmax), ...) as a sorted tuple of disjoint
    windows (overlapping ones are merged)."""
    arr = np.asarray(window, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 1:
        raise InputError(
            f"window={window!r} is not allowed: need (xmin, xmax) or a sequence of such pairs"
        )
    for lo, hi in arr:
        if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
            raise InputError(f"window=({lo!r}, {hi!r}) is not allowed: need finite xmin < xmax")
    merged: list[list[float]] = []
    for lo, hi in sorted(arr.tolist()):
        if merged and lo <= merged[-1][1]:  # overlapping windows: their union
            merged[-1][1] = max(merged[-1][1], hi)
        else:
            merged.append([lo, hi])
    return tuple((float(lo), float(hi)) for lo, hi in merged)


def fine_regions(windows, spec: MeshSpec) -> list[list[float]]:
    """[xl, xr, h] of each window widened by its margin, with its own element size
    ``h = width / (n_window 2**level)``.  Where two widened windows overlap they are cut
    half-way between the windows; the coarser one then gives up the length its grading down
    to the finer size needs, ``|h0 - h1| / (growth - 1)`` (a zone next to a much narrower one
    is graded at that edge: finer, never coarser)."""
    out = []
    for lo, hi in windows:
        width = hi - lo
        out.append([lo - spec.margin * width, hi + spec.margin * width, width / spec_cells(spec)])
    for k, ((_, hi0), (lo1, _)) in enumerate(zip(windows[:-1], windows[1:], strict=True)):
        left, right = out[k], out[k + 1]
        if left[1] > right[0]:
            left[1] = right[0] = 0.5 * (hi0 + lo1)
        need = abs(left[2] - right[2]) / (spec.growth - 1.0) - (right[0] - left[1])
        if need > 0 and left[2] > right[2]:
            left[1] = max(left[1] - need, left[0] + left[2])
        elif need > 0:
            right[0] = min(right[0] + need, right[1] - right[2])
    return out


def spec_cells(spec: MeshSpec) -> float:
    """Elements across one window: ``n_window 2**level``."""
    return spec.n_window * 2.0**spec.level


#: Two kinks (or a kink and a fine region's end) closer than this fraction of the element size
#: make an element too thin to solve: at h = 0.17, kinks 1e-6 apart (6e-6 h) failed the
#: equilibrium check as a solver error (1e-12 apart too), 1e-4 apart (6e-4 h) solved.
KINK_MIN_GAP = 1e-4


def uniform_axis(xl: float, xr: float, h: float, kinks) -> np.ndarray:
    """Nodes of size <= h on [xl, xr] (both ends included) with a node on every kink inside."""
    inner = [k for k in sorted(set(float(k) for k in kinks)) if xl < k < xr]
    breaks = [xl, *inner, xr]
    close = [(a, b) for a, b in zip(breaks[:-1], breaks[1:], strict=True)
             if b - a < KINK_MIN_GAP * h]
    if close:
        a, b = close[0]
        raise InputError(f"kinks={list(kinks)} is not allowed: need kinks at least "
                         f"{KINK_MIN_GAP:g} of the element size h={h:g} apart from each other and "
                         f"from the fine region's ends (x={a!r} and x={b!r} are {b - a:.3g} "
                         "apart: an element that thin is degenerate); give them as one kink")
    fine = [
        np.linspace(a, b, max(1, int(np.ceil((b - a) / h - 1e-9))) + 1)[:-1]
        for a, b in zip(breaks[:-1], breaks[1:], strict=True)
    ]
    return np.r_[np.concatenate(fine), xr]


def graded_gap(a: float, b: float, ha: float, hb: float, growth: float) -> np.ndarray:
    """Interior nodes of (a, b), graded from size ha at a and hb at b, coarsest in between
    (where the two geometric gradings ``h + (growth - 1) distance`` meet)."""
    meet = 0.5 * (a + b + (hb - ha) / (growth - 1.0))
    meet = float(np.clip(meet, a, b))
    if meet - a < ha * growth:  # no room for a graded run on that side: one run fills the gap
        meet = a
    elif b - meet < hb * growth:
        meet = b
    left = a + np.cumsum(graded_sizes(ha * growth, meet - a, growth))[:-1]
    right = b - np.cumsum(graded_sizes(hb * growth, b - meet, growth))[:-1]
    return np.r_[left, [meet] if a < meet < b else [], right[::-1]]


def inner_axis(windows, kinks, spec: MeshSpec) -> np.ndarray:
    """Node x from the first fine region's left end to the last one's right end: a uniform fine
    size in every window (+ margin; size relative to its own width), nodes at the kinks inside
    them, graded across the gaps between windows (each graded run starts at growth times the
    spacing it continues)."""
    fine = [uniform_axis(*r, kinks) for r in fine_regions(windows, spec)]
    parts = [fine[0]]
    for a, b in zip(fine[:-1], fine[1:], strict=True):
        gap = graded_gap(a[-1], b[0], a[-1] - a[-2], b[1] - b[0], spec.growth)
        parts += [gap, b[1:] if b[0] == a[-1] else b]
    return np.concatenate(parts)


def outer_kinks(windows, kinks, spec: MeshSpec) -> list[float]:
    """The kinks outside every fine region (put on the nearest node after grading)."""
    regions = fine_regions(windows, spec)
    return [k for k in kinks if not any(a < k < b for a, b, _ in regions)]


def window_axis(windows, kinks, spec: MeshSpec, W: float) -> np.ndarray:
    """Node x of the tensor mesh: :func:`inner_axis`, graded out to +-W by growth, a node on
    every kink."""
    xc = 0.5 * (windows[0][0] + windows[-1][1])
    inner, g = inner_axis(windows, kinks, spec), spec.growth
    xl, xr = inner[0], inner[-1]
    left = xl - np.cumsum(graded_sizes((inner[1] - xl) * g, xl - (xc - W), g))
    right = xr + np.cumsum(graded_sizes((xr - inner[-2]) * g, xc + W - xr, g))
    x = np.r_[left[::-1], inner, right]
    return snap_kinks(x, outer_kinks(windows, kinks, spec))


def snap_kinks(x: np.ndarray, kinks) -> np.ndarray:
    """Move the nearest interior node onto each kink outside the fine region (a kink beyond the
    bodies has no node to take: the profile's corner is outside the model; two kinks sharing
    their nearest node are refused: one would not get its node)."""
    x, taken = x.copy(), {}
    for k in sorted(float(v) for v in kinks if x[0] < v < x[-1]):
        i = int(np.clip(np.argmin(np.abs(x - k)), 1, x.size - 2))
        if i in taken:
            raise InputError(f"kinks={list(kinks)} is not allowed: x={taken[i]!r} and x={k!r} "
                             f"share their nearest node (elements of {x[i + 1] - x[i - 1]:.3g} "
                             "there): give them as one kink, or a window holding both")
        taken[i], x[i] = k, k
    if np.any(np.diff(x) <= 0):
        raise InputError(f"kinks={list(kinks)} could not be placed on mesh nodes: refine the mesh")
    return x


def near_growth(spec: MeshSpec) -> float:
    """Depth growth ratio in the near field of the contact: ``1 + (growth - 1)
    2**(-(level + 1) / 2)``.  The Q1 error there scales like (ratio - 1)**2 (the Hertz width
    was 0.09 % short at every level with the ratio fixed at 1.2); this makes it fall like h."""
    return 1.0 + (spec.growth - 1.0) * 2.0 ** (-(spec.level + 1) / 2)


def depth_axis(h: float, H: float, near: float, spec: MeshSpec) -> np.ndarray:
    """Layer depths from 0 (excluded) to H: graded from h by :func:`near_growth` down to the
    depth ``near`` (the widest window: the near field of every zone), then by ``growth``."""
    near = min(near, H)
    top = np.cumsum(graded_sizes(h, near, near_growth(spec)))
    if near >= H:
        return top
    last = top[-1] - top[-2] if top.size > 1 else top[-1]
    return np.r_[top, near + np.cumsum(graded_sizes(last * spec.growth, H - near, spec.growth))]


def build_mesh(spec: MeshSpec, window, kinks=()) -> TwoBodyMesh:
    """Generate the two-body mesh refined in one window (xmin, xmax) or in several
    ((xmin, xmax), ...), e.g. one per expected contact zone: graded rings (``layout="rings"``,
    the default, :mod:`fem.rings`) or the tensor product of an x and a depth axis
    (``layout="tensor"``)."""
    validate_mesh_spec(spec)
    windows = as_windows(window)
    span = windows[-1][1] - windows[0][0]
    W = spec.W if spec.W is not None else spec.size_factor * 0.5 * span
    H = spec.H if spec.H is not None else W
    regions = fine_regions(windows, spec)
    xc = 0.5 * (windows[0][0] + windows[-1][1])
    half = max(xc - regions[0][0], regions[-1][1] - xc)
    if W <= half * 1.05:
        raise InputError(
            f"W={W:g} is not allowed: need W > {half * 1.05:g} "
            "(the window plus its margin must fit in the bodies)"
        )
    h = min(r[2] for r in regions)
    if spec.layout == "rings":
        rate = replace(spec, growth=near_growth(spec))  # the rings' h + (rate - 1) d everywhere
        x = inner_axis(windows, kinks, rate)
        p, t = ring_body(x, h, rate.growth, xc, W, H)
        p = snap_interface_kinks(p, t, outer_kinks(windows, kinks, rate))
        # row-major arrays, as skfem keeps them (it would copy them itself, with a warning)
        upper = MeshQuad(np.ascontiguousarray(p), np.ascontiguousarray(t))
        return from_bodies(upper, mirror_body(upper), "generated")
    x = window_axis(windows, kinks, spec, W)
    depth = depth_axis(h, H, NEAR_DEPTH * max(b - a for a, b in windows), spec)
    upper = MeshQuad.init_tensor(x, np.r_[0.0, depth])
    return from_bodies(upper, mirror_body(upper), "generated")


def mirror_body(upper: MeshQuad) -> MeshQuad:
    """Body 2 as the mirror image (y -> -y) of body 1 with the same node and element numbering
    (each element's nodes reversed to keep it counter-clockwise): between elastically similar
    bodies ``fem.condense`` then factorises one body for both and the compliance's
    tangential-normal blocks are zero (``fem.activeset`` factorises them apart)."""
    return MeshQuad(upper.p * np.array([[1.0], [-1.0]]), upper.t[::-1].copy())


def snap_interface_kinks(p: np.ndarray, t: np.ndarray, kinks) -> np.ndarray:
    """Move the interface node (y = 0) nearest to each kink onto it; refuse if an element
    would turn inside out."""
    on = np.flatnonzero(np.abs(p[1]) <= INTERFACE_ATOL)
    row = on[np.argsort(p[0, on])]
    p = p.copy()
    p[0, row] = snap_kinks(p[0, row], kinks)
    if not np.all(convex(p, t)):
        raise InputError(f"kinks={list(kinks)} could not be placed on mesh nodes: refine the mesh")
    return p


def from_bodies(upper: MeshQuad, lower: MeshQuad, source: str) -> TwoBodyMesh:
    """Find the named boundaries of two rectangles-on-y=0 meshes by coordinates."""
    y1, y2 = upper.p[1], lower.p[1]
    nodes = {
        "contact_upper": np.flatnonzero(np.isclose(y1, 0.0, atol=INTERFACE_ATOL)),
        "top": np.flatnonzero(np.isclose(y1, y1.max())),
        "contact_lower": np.flatnonzero(np.isclose(y2, 0.0, atol=INTERFACE_ATOL)),
        "bottom": np.flatnonzero(np.isclose(y2, y2.min())),
    }
    return finish(upper, lower, nodes, source)


def finish(upper: MeshQuad, lower: MeshQuad, nodes: dict, source: str) -> TwoBodyMesh:
    """Check the interface rows match node-to-node and package the mesh."""
    xu = np.sort(upper.p[0, nodes["contact_upper"]])
    xl = np.sort(lower.p[0, nodes["contact_lower"]])
    if xu.size < 2 or xl.size < 2:
        raise InputError(f"interface rows have {xu.size} and {xl.size} nodes: need >= 2 each")
    h_min = float(np.min(np.diff(xl)))
    if xu.size != xl.size or np.max(np.abs(xu - xl)) > MATCH_TOL * h_min:
        raise InputError(
            f"non-matching interface nodes in {source}: contact_upper has {xu.size} nodes, "
            f"contact_lower {xl.size}; node-to-node contact needs the same x on both rows "
            "(node-to-segment contact is not supported)"
        )
    for name, mesh in (("contact_upper", upper), ("contact_lower", lower)):
        if np.max(np.abs(mesh.p[1, nodes[name]])) > MATCH_TOL * h_min:
            raise InputError(
                f"boundary {name} of {source} is not on y = 0: the interface must be "
                "the flat line y = 0 (the profile enters through h0)"
            )
    return TwoBodyMesh(bodies=(upper, lower), nodes=nodes, h_min=h_min, source=source)


def read_mesh(spec: MeshFile) -> TwoBodyMesh:
    """Read a meshio file with two disconnected quad bodies and named boundaries."""
    path = Path(spec.path)
    if not path.is_file():
        raise InputError(f"mesh file {str(path)!r} does not exist")
    m = read_meshio(path)
    others: dict[str, int] = {}
    for c in m.cells:
        if c.type in NON_QUAD_CELLS:
            others[c.type] = others.get(c.type, 0) + len(c.data)
    if others:
        found = ", ".join(f"{n} '{t}'" for t, n in others.items())
        raise InputError(
            f"mesh file {str(path)!r} has {found} cells: fem reads meshes of 4-node 'quad' cells "
            "only (no holes where other cells were dropped; recombine into quads, e.g. gmsh's "
            "Mesh.SubdivisionAlgorithm = 1, or take the element order from MeshFile(order=))"
        )
    quads = np.concatenate([c.data for c in m.cells if c.type == "quad"] or [np.zeros((0, 4), int)])
    if quads.shape[0] == 0:
        raise InputError(f"mesh file {str(path)!r} has no 'quad' cells: need a quad mesh")
    named = named_line_nodes(m, path)
    pts = m.points[:, :2]
    comp = body_components(quads, pts.shape[0])
    top_comp = np.unique(comp[named["top"]])
    if np.unique(comp[np.unique(quads)]).size != 2 or top_comp.size != 1:
        raise InputError(
            f"mesh file {str(path)!r} must hold exactly two disconnected bodies "
            "with 'top' on the upper one"
        )
    meshes, nodes = {}, {}
    for body, names in (
        (top_comp[0], ("contact_upper", "top")),
        (1 - top_comp[0], ("contact_lower", "bottom")),
    ):
        mesh, old2new = sub_mesh(pts, quads[comp[quads[:, 0]] == body])
        check_convex(mesh, f"{str(path)!r}, the body with {names[1]!r}")
        meshes[names[0]] = mesh
        for name in names:
            idx = old2new[named[name]]
            if np.any(idx < 0):
                raise InputError(f"boundary {name} of {str(path)!r} lies on the wrong body")
            nodes[name] = idx
    return finish(meshes["contact_upper"], meshes["contact_lower"], nodes, str(path))


def read_meshio(path: Path, what: str = "mesh file", allowed: str = MESHIO_ALLOWED):
    """``meshio.read(path)`` as a library call: the mesh, or one InputError naming the file.

    meshio (5.3) tries every reader its extension allows (``.msh``: ansys, then gmsh) and prints
    each one's failure to stdout (a blank line when the ansys reader turns down a gmsh file);
    when none reads the file it prints an error and ends the process (``sys.exit(1)``), and an
    unknown extension raises its own ReadError.  Its output is captured here and goes into the
    error if the file cannot be read; ``what`` names the file in it, ``allowed`` what it may be."""
    import meshio

    said = io.StringIO()
    try:
        with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
            return meshio.read(path)
    except SystemExit:
        why = " ".join(said.getvalue().split()) or "no reader took it"
    except Exception as exc:  # noqa: BLE001 - any reader failure is a bad file
        why = f"{type(exc).__name__}: {exc}"
    raise InputError(f"{what} {str(path)!r} cannot be read by meshio ({why}); allowed: {allowed}")


def named_line_nodes(m, path: Path) -> dict:
    """Map each required boundary name to the node indices of its line cells."""
    found = {}
    for name, blocks in (m.cell_sets or {}).items():
        ids = [
            m.cells[b].data[np.asarray(s, int)].ravel()
            for b, s in enumerate(blocks)
            if s is not None and len(s) and m.cells[b].type == "line"
        ]
        if ids:
            found[name] = np.unique(np.concatenate(ids))
    phys = m.cell_data.get("gmsh:physical")
    for name, (tag, dim) in (m.field_data or {}).items():
        if phys is None or name in found or dim != 1:
            continue
        ids = [c.data[phys[b] == tag].ravel() for b, c in enumerate(m.cells) if c.type == "line"]
        found[name] = np.unique(np.concatenate(ids)) if ids else np.zeros(0, int)
    missing = [n for n in BOUNDARY_NAMES if n not in found or found[n].size == 0]
    if missing:
        raise InputError(
            f"mesh file {str(path)!r} lacks boundary name(s) {missing}: need line "
            f"cells named {list(BOUNDARY_NAMES)} (gmsh physical groups)"
        )
    return found


def body_components(quads: np.ndarray, n_points: int) -> np.ndarray:
    """Connected-component label of every point (quads sharing nodes are connected)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    rows = np.repeat(quads[:, 0], 3)
    cols = quads[:, 1:].ravel()
    graph = coo_matrix((np.ones(rows.size), (rows, cols)), shape=(n_points, n_points))
    return connected_components(graph, directed=False)[1]


def check_convex(mesh: MeshQuad, where: str) -> None:
    """InputError unless every quad is strictly convex (a bow-tie or a collapsed corner has a
    Jacobian that vanishes or changes sign inside the element)."""
    bad = np.flatnonzero(~convex(mesh.p, mesh.t))
    if bad.size:
        x, y = mesh.p[:, mesh.t[:, bad[0]]]
        corners = ", ".join(f"({a:.6g}, {b:.6g})" for a, b in zip(x, y, strict=True))
        raise InputError(f"mesh file {where}: {bad.size} quad(s) not strictly convex, the first "
                         f"with corners {corners}; allowed: convex quads with their four nodes in "
                         "order around them (no bow-ties, no collapsed or straight corners)")


def sub_mesh(pts: np.ndarray, quads: np.ndarray) -> tuple[MeshQuad, np.ndarray]:
    """Build a MeshQuad from a subset of quads; return it and the old->new node map."""
    used = np.unique(quads)
    old2new = -np.ones(pts.shape[0], dtype=np.int64)
    old2new[used] = np.arange(used.size)
    t = old2new[quads]
    area = quad_area(pts[used].T, t.T)
    t[area < 0] = t[area < 0][:, ::-1]
    return MeshQuad(pts[used].T.copy(), t.T.copy()), old2new


def write_msh(mesh: TwoBodyMesh, path: Path) -> Path:
    """Write a two-body mesh as gmsh 2.2 .msh with physical names (atomic write)."""
    import meshio

    upper, lower = mesh.bodies
    off = upper.p.shape[1]
    pts = np.c_[np.hstack([upper.p, lower.p]).T, np.zeros(off + lower.p.shape[1])]
    quads = np.vstack([upper.t.T, lower.t.T + off])
    cells, phys, tags = [("quad", quads)], [np.full(quads.shape[0], 1)], {}
    for k, (name, body) in enumerate(
        (("contact_upper", 0), ("contact_lower", 1), ("top", 0), ("bottom", 1)), start=2
    ):
        m = mesh.bodies[body]
        segs = boundary_segments(m, mesh.nodes[name]) + (off if body else 0)
        cells.append(("line", segs))
        phys.append(np.full(segs.shape[0], k))
        tags[name] = np.array([k, 1])
    tags["bodies"] = np.array([1, 2])
    out = meshio.Mesh(
        pts, cells, cell_data={"gmsh:physical": phys, "gmsh:geometrical": phys}, field_data=tags
    )
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp.msh")
    meshio.write(tmp, out, file_format="gmsh22", binary=False)
    os.replace(tmp, path)
    return path


def boundary_segments(m: MeshQuad, nodes: np.ndarray) -> np.ndarray:
    """Boundary facets (as node pairs) whose both ends are in ``nodes``."""
    f = m.facets[:, m.boundary_facets()]
    inside = np.isin(f, nodes).all(axis=0)
    return f[:, inside].T.copy()
