"""Polyhedra for the tumbling tests (metres): the bundled examples, boxes, seeded
random hulls, and the hard families -- non-triangular faces (prisms, frustums,
antiprism-like bands), nearly coplanar faces, slivers -- with a hypothesis
strategy over all of them; and a brute-force enumeration of tumble words."""
import math
import pathlib

import numpy as np
import yaml
from hypothesis import strategies as st

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"


def non_backtracking_words(table, root, depth):
    """Brute force: every word of 1..``depth`` tumbles from face ``root`` that never
    rolls straight back (a face sequence; ``table.neighbors[f]`` the faces next to f),
    shortest first."""
    frontier = [((), root, None)]
    for _ in range(depth):
        nxt = []
        for w, f, prev in frontier:
            for g in table.neighbors[f]:
                if g != prev:
                    nxt.append((w + (g,), g, f))
        yield from (w for w, _, _ in nxt)
        frontier = nxt


def example(name):
    """(vertices, com or None) of ``examples/<name>.yaml``."""
    doc = yaml.safe_load((EXAMPLES / f"{name}.yaml").read_text())
    return doc["vertices"], doc.get("com")


def box(a, b, c):
    """The 8 corners of an a x b x c box centred at the origin."""
    return [[x, y, z] for x in (-a / 2, a / 2) for y in (-b / 2, b / 2) for z in (-c / 2, c / 2)]


def random_polyhedron(seed, n):
    """n points on a random ellipsoid (semi-axes 3-10 cm): a seeded random convex polyhedron."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return d * rng.uniform(0.03, 0.1, size=3)


def convex_polygon(rng, n, radius=0.05):
    """n points in strictly convex position on a random ellipse (CCW), (n, 2) metres."""
    ang = np.linspace(0, 2 * math.pi, n, endpoint=False) + rng.uniform(0, 2 * math.pi)
    ang += rng.uniform(-0.3, 0.3, n) * (math.pi / n)
    sx, sy = radius * rng.uniform(0.5, 1.0, 2)
    return np.stack([sx * np.cos(ang), sy * np.sin(ang)], 1)


def prism(rng, n, height=None):
    """A right prism over a random convex n-gon: two n-gon faces, n quadrilaterals."""
    base = convex_polygon(rng, n)
    h = rng.uniform(0.02, 0.1) if height is None else height
    return np.concatenate([np.c_[base, np.zeros(n)], np.c_[base, np.full(n, h)]])


def frustum(rng, n, shrink=None):
    """A truncated pyramid over a random convex n-gon (quadrilateral sides)."""
    base = convex_polygon(rng, n)
    s = rng.uniform(0.3, 0.95) if shrink is None else shrink
    h = rng.uniform(0.02, 0.08)
    c = base.mean(0)
    top = c + s * (base - c)
    return np.concatenate([np.c_[base, np.zeros(n)], np.c_[top, np.full(n, h)]])


def near_coplanar(rng, rel=1e-7):
    """A box whose top face is split by a ridge ``rel`` x size high: two faces
    coplanar to within ~rel (kept apart when rel exceeds the merge tolerance)."""
    a, b, c = rng.uniform(0.03, 0.1, 3)
    V = np.array(box(a, b, c), dtype=float)
    ridge = [[0.0, -b / 2, c / 2 + rel * max(a, b, c)], [0.0, b / 2, c / 2 + rel * max(a, b, c)]]
    return np.concatenate([V, ridge])


def sliver(rng, flat=1e-3):
    """A sliver: a tetrahedron of height ``flat`` x its base, or a thin needle
    (a triangular prism ``flat`` x its length across)."""
    if rng.uniform() < 0.5:
        tri = convex_polygon(rng, 3)
        apex = np.r_[tri.mean(0) + rng.uniform(-0.01, 0.01, 2), flat * 0.05]
        return np.concatenate([np.c_[tri, np.zeros(3)], apex[None]])
    tri = convex_polygon(rng, 3, radius=0.05 * flat) if flat > 1e-2 else convex_polygon(rng, 3, 1e-3)
    return np.concatenate([np.c_[tri, np.zeros(3)], np.c_[tri, np.full(3, 0.1)]])


def noisy(V, noise, seed):
    """``V`` with every coordinate moved uniformly within +-noise (metres)."""
    V = np.asarray(V, dtype=float)
    return V + np.random.default_rng(seed).uniform(-noise, noise, V.shape)


FAMILIES = ("random", "prism", "frustum", "near_coplanar", "sliver", "box")


def family_member(family, seed):
    """A seeded member of one of ``FAMILIES`` (vertices, metres)."""
    rng = np.random.default_rng(seed)
    if family == "random":
        return random_polyhedron(seed, int(rng.integers(5, 12)))
    if family == "prism":
        return prism(rng, int(rng.integers(3, 9)))
    if family == "frustum":
        return frustum(rng, int(rng.integers(3, 8)))
    if family == "near_coplanar":
        return near_coplanar(rng, float(10.0 ** rng.uniform(-11, -4)))
    if family == "sliver":
        return sliver(rng, float(10.0 ** rng.uniform(-3, -1)))
    return np.array(box(*rng.uniform(0.02, 0.1, 3)))


@st.composite
def polyhedra(draw, families=FAMILIES):
    """Hypothesis strategy: ``(family, vertices)`` over the hard families."""
    family = draw(st.sampled_from(families))
    return family, family_member(family, draw(st.integers(0, 2**31 - 1)))
