"""Polyhedra for the tumbling tests (metres): the bundled examples, boxes, seeded
random hulls, and the hard families -- non-triangular faces (prisms, frustums,
antiprism-like bands), nearly coplanar faces, slivers -- with a hypothesis
strategy over all of them; a brute-force enumeration of tumble words; and two
independent checks of a tumble plan (:func:`check_plan`, the JAX kernel on the
plan's part; :func:`roll_on_vertices`, the bare points rolled in 3-D)."""
import math
import pathlib
import warnings

import numpy as np
import pytest
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


def check_plan(plan, V, com=None):
    """Independent verification of a :class:`~planning.tumbling.plan.TumblePlan`
    on the part ``(V, com)`` with its faces at the plan's tolerance: edges,
    kernel replay, error (tolerances relative to the part's size); a solved
    plan ends on the goal face within eps.  Returns the replayed error."""
    import jax.numpy as jnp

    from kernels.errors import PartWarning
    from kernels.polyhedron import make_polyhedron
    from kernels.tumble import make_config, replay
    from planning.tumbling.plan import config_error, reaches

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PartWarning)
        P = make_polyhedron(V, com, tau_v=plan.tau_v)
    hv = P.vertices[list(P.hull_vertices)]
    tol = 1e-9 * float(np.max(np.linalg.norm(hv[:, None] - hv[None], axis=-1)))
    f = plan.start[3]
    for t in plan.tumbles:
        assert t.face in P.neighbors(f)
        assert t.edge == P.shared_edge(f, t.face)
        f = t.face
    n = len(plan.tumbles)
    size = 256
    while size < n:  # pad with no-ops to a few fixed lengths: one compilation each
        size *= 16
    faces = np.full(size, -1, dtype=np.int32)
    faces[:n] = [t.face for t in plan.tumbles]
    s = plan.start
    final, ok = replay(P.geometry(jnp.float64), make_config(*s, dtype=jnp.float64), jnp.asarray(faces))
    assert bool(ok)
    cfg = (float(final.xy[0]), float(final.xy[1]), float(final.theta), int(final.face))
    assert config_error(cfg, plan.predicted_final) < tol
    err = config_error(cfg, plan.goal)
    assert err == pytest.approx(plan.error, abs=tol)
    if plan.verdict == "solved":
        assert err <= plan.eps and reaches(cfg, plan.goal, plan.eps)
    return err


def _rotation(axis, angle):
    """Rodrigues: the rotation by ``angle`` (rad) about the unit vector ``axis``."""
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * (K @ K)


def roll_on_vertices(plan, V, com=None, touch=1e-7):
    """Roll the bare points ``V`` through ``plan``'s tumbles in 3-D, knowing no
    faces: before each tumble the body settles, rigidly, onto the floor
    ``z = 0`` along the tumble's edge (both its vertices down, then turned
    about the edge until the next point on the support's side touches: a part
    whose face is split by a crease rocks onto the piece that holds the edge);
    then it turns about the edge, away from its support, until the next point
    touches.  The start and the goal are read with the face frames of the
    plan's part (the definition of a configuration; a frame off the floor by
    a crease is read projected).  Returns ``(error, touching)``: the paper's
    distance of the reached configuration of the goal face from the goal, and
    the sorted indices of the points within ``touch`` x the part's size of the
    floor at the end."""
    from kernels.errors import PartWarning
    from kernels.polyhedron import make_polyhedron
    from planning.tumbling.plan import config_error

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PartWarning)
        P = make_polyhedron(V, com, tau_v=plan.tau_v)
    v = P.vertices
    hull = list(P.hull_vertices)
    size = float(np.max(np.linalg.norm(v[hull][:, None] - v[hull][None], axis=-1)))
    low = 16 * plan.tau_v + 1e-9 * size  # the support: the points this near the floor
    up = np.array([0.0, 0.0, 1.0])
    c, s_ = math.cos(plan.start[2]), math.sin(plan.start[2])
    Rw = np.array([[c, -s_, 0.0], [s_, c, 0.0], [0.0, 0.0, 1.0]]) @ P.face_rotations[plan.start[3]]
    tw = np.array([plan.start[0], plan.start[1], 0.0]) - Rw @ P.face_origins[plan.start[3]]

    def turn(Q, pivot):
        return Q @ Rw, Q @ (tw - pivot) + pivot

    def polar(q, u, n):  # angle of each point about the floor line u, up from direction n
        rn, rz = q @ n, q[:, 2]
        return np.where(np.hypot(rn, rz) > 1e-9 * size, np.arctan2(rz, rn), np.inf)

    for t in plan.tumbles:
        a, b = t.edge
        others = [i for i in hull if i not in (a, b)]
        X = v @ Rw.T + tw
        n_in = np.mean(X[others][X[others][:, 2] <= X[:, 2].min() + low], axis=0) - X[a]
        tw = tw - X[a][2] * up                                   # settle: a down,
        X = v @ Rw.T + tw
        e = X[b] - X[a]
        e_flat = np.r_[e[:2], 0.0] * (np.linalg.norm(e) / np.linalg.norm(e[:2]))
        ax = np.cross(e, e_flat)
        if np.linalg.norm(ax) > 0:                               # b down,
            Rw, tw = turn(_rotation(ax / np.linalg.norm(ax),
                                    math.atan2(np.linalg.norm(ax), e @ e_flat)), X[a])
        X = v @ Rw.T + tw
        u = (X[b] - X[a]) / np.linalg.norm(X[b] - X[a])
        n = np.cross(up, u)
        n = n if n @ n_in > 0 else -n                            # in the floor, towards the support
        Rw, tw = turn(_rotation(np.cross(up, n), float(np.min(polar(X[others] - X[a], u, n)))),
                      X[a])                                      # the support touches; then roll
        X = v @ Rw.T + tw
        ang = polar(X[others] - X[a], u, -n)
        Rw, tw = turn(_rotation(np.cross(up, -n), float(np.min(ang[ang > 1e-12]))), X[a])
    G = plan.goal[3]
    M = Rw @ P.face_rotations[G].T   # the goal face's frame in the world
    o = Rw @ P.face_origins[G] + tw
    reached = (float(o[0]), float(o[1]), math.atan2(M[1, 0], M[0, 0]), G)
    z = (v[hull] @ Rw.T + tw)[:, 2]
    touching = sorted(int(hull[i]) for i in np.flatnonzero(np.abs(z) <= touch * size))
    return config_error(reached, plan.goal), touching
