"""Graded ring mesh of one body: element size growing geometrically away from the contact.

Body 1 (y >= 0) is built outwards from its fine interface row, layer by layer, each layer a
U-shaped ring (left side, top, right side) around everything built so far:

- a *graded* layer of thickness r extends every boundary node straight outwards (a tensor
  extension: quads r x its neighbour's spacing, a square r x r in each corner);
- a *transition* layer of thickness tau = 3 s (s the nominal spacing along the boundary) joins
  three boundary segments to one with the conforming 3:1 template (four quads: two on the
  outer ends, one in the middle against the fine row, one trapezoid against the coarse row;
  the usual 3-to-1 quad refinement pattern) wherever the three are together at most
  GROUP_MAX tau long; longer segments pass straight through until the rings have grown to
  their size: above a zone window coarser than the finest one (several windows) and next to
  the corners.  (Joining every three regardless coarsened the rings over the wider zones of
  the punch-and-cylinder cases before they were deep enough: pressure, shear and stress
  errors above tolerance at their library level.)

Radial sizes grow by ``growth`` per layer (size ``h + (growth - 1) d`` at distance d from the
fine row, in every direction); when the next would exceed TRANSITION_TRIGGER times the spacing
along the boundary a transition of thickness 3 s is made (and the radial grading goes on from
there), so the spacing along the rings triples as the rings grow.  The
interface row of the body is the fine row plus the bottom nodes of every ring (so the two
bodies, mirror images, have the same interface x).  The last layers are scaled per direction
so that the body is exactly ``[xc - W, xc + W] x [0, H]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import InputError

#: Spacing ratio of a transition layer (the conforming 3:1 quad template).
TRANSITION_RATIO = 3
#: A transition is made when the radial size reaches this multiple of the spacing along the
#: rings.  Hertz at level 0 (peak pressure / width error): 3 (transition as soon as the radial
#: size equals the coarse spacing): 4.0e-4 / 4.0e-4 with 8000 DOFs; 4.5: 8.5e-5 / 6.6e-4 with
#: 11232 DOFs (the tensor mesh: 6.2e-5 / 8.5e-4 with 11016); at level 1 3.6e-4 / 2.4e-4 (17992
#: DOFs) against 1.65e-4 / 3.8e-5 (24968; tensor 1.47e-4 / 5.1e-5 with 26520).  The price at
#: level 3 (cattaneo, bench_fem): 3: 1.09e5 DOFs, edge / stick 0.0012 / 0.0027 % of the width,
#: 3.6x less history time and 4.4x less memory than the tensor level 3; 4.5: 1.54e5 DOFs,
#: 0.0036 / 0.0049 %, 3.1x and 3.3x.  (3 fails test_fem_meshfile's level-0 peak tolerance.)
TRANSITION_TRIGGER = 4.5
#: Smallest factor by which the outermost layers may be squeezed to end exactly on the body
#: boundary (more layers are squeezed together if one alone would be squeezed more).
MIN_SQUEEZE = 0.5
#: A transition joins three boundary segments when they are together at most this multiple of
#: the layer thickness tau (three segments of the ring's nominal spacing make exactly tau).
GROUP_MAX = 2.0
#: Fraction of a transition layer's thickness at which its two inner template nodes sit.
TEMPLATE_DEPTH = 1.0 / 3.0


@dataclass(frozen=True)
class Layer:
    """One ring: 'graded' (every segment straight out) or 'transition' (3:1), thickness
    (length) per direction (left, top, right)."""

    kind: str
    thickness: tuple[float, float, float]


def layer_plan(h: float, growth: float, reach: tuple[float, float, float]) -> list[Layer]:
    """Layers from the fine row (size h) until the rings reach ``reach`` (distance to the body
    boundary from the fine row: left, up, right), the outermost squeezed to end on it."""
    kinds, sizes, s, r = [], [], h, h / growth
    while sum(sizes) < max(reach):
        r *= growth
        if r >= TRANSITION_TRIGGER * s * (1 - 1e-9):
            s *= TRANSITION_RATIO
            r = s
            kinds.append("transition")
        else:
            kinds.append("graded")
        sizes.append(r)
    scale = np.array([squeeze(np.array(sizes), d) for d in reach]).T
    return [Layer(k, tuple(float(v) for v in sizes[i] * scale[i])) for i, k in enumerate(kinds)]


def squeeze(sizes: np.ndarray, reach: float) -> np.ndarray:
    """Per-layer scale factors that make ``sizes`` sum to ``reach`` by squeezing the outermost
    layers (as few as keep the factor >= MIN_SQUEEZE; all of them if none does)."""
    total = np.cumsum(sizes)
    if reach <= 0:
        raise InputError(f"the body boundary is {reach:g} from the fine region: need > 0")
    scale = np.ones(sizes.size)
    for j in range(sizes.size - 1, -1, -1):
        inner = total[j - 1] if j > 0 else 0.0
        if inner >= reach:
            continue
        factor = (reach - inner) / (total[-1] - inner)
        if factor >= MIN_SQUEEZE or j == 0:
            scale[j:] = factor
            return scale
    return scale


class _Builder:
    """Nodes and quads of one body as the rings grow (U-shaped boundary: left and right side
    node lists bottom to top, top list left to right; the corners are shared)."""

    def __init__(self, x: np.ndarray):
        self.p = [(float(v), 0.0) for v in x]
        self.quads: list[tuple[int, int, int, int]] = []
        top = list(range(x.size))
        self.left, self.top, self.right = [top[0]], top, [top[-1]]
        self.L, self.R, self.T = float(x[0]), float(x[-1]), 0.0

    def node(self, x: float, y: float) -> int:
        self.p.append((x, y))
        return len(self.p) - 1

    def side(self, inner: list[int], axis: int, groups: list[int], place) -> list[int]:
        """Outer nodes of one side and its quads; ``place(s, n)``: the point at tangential
        coordinate s and outward distance n (from the side's inner line)."""
        s = [self.p[i][axis] for i in inner]
        outer = [self.node(*place(s[0], 1.0))]
        k = 0
        for g in groups:
            f = inner[k : k + g + 1]
            o = self.node(*place(s[k + g], 1.0))
            if g == 1:
                self.quads.append((f[0], f[1], o, outer[-1]))
            else:
                i1 = self.node(*place(s[k + 1], TEMPLATE_DEPTH))
                i2 = self.node(*place(s[k + 2], TEMPLATE_DEPTH))
                self.quads += [(f[0], f[1], i1, outer[-1]), (f[1], f[2], i2, i1),
                               (f[2], f[3], o, i2), (i1, i2, o, outer[-1])]
            outer.append(o)
            k += g
        return outer

    def groups(self, nodes: list[int], axis: int, tau: float, from_both_ends: bool) -> list[int]:
        """Quad groups of a transition on one side (:func:`transition_groups`); along the top
        from both ends towards the middle (a symmetric row stays symmetric)."""
        lengths = np.diff([self.p[i][axis] for i in nodes])
        if not from_both_ends:
            return transition_groups(lengths, tau)
        half = lengths.size // 2
        middle = [1] * (lengths.size - 2 * half)
        right = transition_groups(lengths[::-1][:half], tau)[::-1]
        return transition_groups(lengths[:half], tau) + middle + right

    def add(self, layer: Layer) -> None:
        """Grow one ring outwards."""
        tl, tt, tr = layer.thickness
        L, R, T = self.L, self.R, self.T
        if layer.kind == "graded":
            gl, gt, gr = ([1] * (len(v) - 1) for v in (self.left, self.top, self.right))
        else:
            gl, gr = (self.groups(v, 1, t, False) for v, t in ((self.left, tl), (self.right, tr)))
            gt = self.groups(self.top, 0, tt, True)
        left = self.side(self.left, 1, gl, lambda s, n: (L - n * tl, s))
        right = self.side(self.right, 1, gr, lambda s, n: (R + n * tr, s))
        top = self.side(self.top, 0, gt, lambda s, n: (s, T + n * tt))
        c_left, c_right = self.node(L - tl, T + tt), self.node(R + tr, T + tt)
        self.quads += [(left[-1], self.top[0], top[0], c_left),
                       (self.top[-1], right[-1], c_right, top[-1])]
        self.left, self.right = left + [c_left], right + [c_right]
        self.top = [c_left, *top, c_right]
        self.L, self.R, self.T = L - tl, R + tr, T + tt


def transition_groups(lengths: np.ndarray, tau: float) -> list[int]:
    """Segments per quad of a transition layer of thickness tau, from the first segment on:
    three joined by the 3:1 template where they are together at most GROUP_MAX tau long,
    otherwise one passing straight through."""
    out, k = [], 0
    while k < lengths.size:
        end = k + TRANSITION_RATIO
        if end <= lengths.size and lengths[k:end].sum() <= GROUP_MAX * tau * (1 + 1e-9):
            out.append(TRANSITION_RATIO)
            k = end
        else:
            out.append(1)
            k += 1
    return out


def ring_body(x: np.ndarray, h: float, growth: float, xc: float, W: float, H: float):
    """Points (2, N) and counter-clockwise quads (4, M) of body 1 (y >= 0) over the fine
    interface row ``x`` (spacing about h), graded by ``growth`` out to ``[xc - W, xc + W] x
    [0, H]``; the first ``x.size`` points are the fine row."""
    reach = (float(x[0] - (xc - W)), float(H), float(xc + W - x[-1]))
    b = _Builder(np.asarray(x, float))
    for layer in layer_plan(h, growth, reach):
        b.add(layer)
    p = np.array(b.p).T
    t = np.array(b.quads).T
    area = quad_area(p, t)
    t[:, area < 0] = t[::-1, area < 0]
    if not np.all(convex(p, t)):
        raise InputError("the graded ring mesh has an inverted element: refine the mesh")
    return p, t


def quad_area(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Shoelace signed area of each quad (positive = counter-clockwise)."""
    x, y = p[0, t], p[1, t]
    return 0.5 * np.sum(x * np.roll(y, -1, axis=0) - np.roll(x, -1, axis=0) * y, axis=0)


def convex(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """True for counter-clockwise strictly convex quads (positive Jacobian everywhere)."""
    e = p[:, np.roll(t, -1, axis=0)] - p[:, t]
    cross = e[0] * np.roll(e[1], -1, axis=0) - e[1] * np.roll(e[0], -1, axis=0)
    return np.all(cross > 0, axis=0)
