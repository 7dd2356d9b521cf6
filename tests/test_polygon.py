"""kernels.polygon: part validation, push geometry, object classes, maximum
reorient angles and the Peshkin distance (by hand and against the replay)."""
from __future__ import annotations

import math
import re
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from kernels import polygon as pg
from kernels.push import replay_push
from tests import strategies as S
from oracles import push_numpy as oracle

pytestmark = pytest.mark.float64  # calls kernels on float64 arrays directly

geometry = jax.jit(pg.polygon_geometry)
reorient_table = jax.jit(pg.max_reorient_table)
classify = jax.jit(pg.object_class)
peshkin = jax.jit(pg.peshkin_distance)
replay_batch = jax.jit(jax.vmap(replay_push, in_axes=(None, 0, 0, 0)))
radius_fn = jax.jit(pg.radius_function)


def _geom(poly):
    return geometry(jnp.asarray(poly.body))


def _hull_edge(poly, a, b):
    return poly.caller_edge_to_hull((a, b))


# --------------------------------------------------------------------------
# make_polygon
# --------------------------------------------------------------------------
PENTAGON = np.array([[0.0, 0.0], [0.04, -0.01], [0.06, 0.02], [0.03, 0.05], [-0.01, 0.03]])  # CCW


@pytest.mark.parametrize("order", [[0, 1, 2, 3, 4], [4, 3, 2, 1, 0], [2, 0, 4, 1, 3], [3, 1, 4, 0, 2]])
def test_any_order_gives_ccw_hull(order):
    pts = PENTAGON[order]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        poly = pg.make_polygon(pts)
    assert poly.dropped == ()
    assert sorted(poly.hull_index) == list(range(5))
    # the hull visits the pentagon's vertices in their CCW cyclic order
    orig = [order[i] for i in poly.hull_index]
    start = orig.index(0)
    assert orig[start:] + orig[:start] == [0, 1, 2, 3, 4]
    area, centroid = pg.polygon_area_centroid(poly.vertices[list(poly.hull_index)])
    assert area > 0
    np.testing.assert_allclose(poly.com, centroid, atol=1e-15)
    np.testing.assert_allclose(poly.body, pts[list(poly.hull_index)] - poly.com, atol=1e-15)
    np.testing.assert_allclose(poly.vertices, pts)   # the caller's list is kept as given
    # edges are named by caller indices
    for e in range(5):
        a, b = poly.edge_vertices(e)
        assert (order[a], order[b]) in {(k, (k + 1) % 5) for k in range(5)}
        assert poly.caller_edge_to_hull((b, a)) == e


def test_area_centroid_by_hand():
    area, c = pg.polygon_area_centroid(np.array([[0, 0], [4, 0], [4, 2], [0, 2.0]]))
    assert area == pytest.approx(8.0) and np.allclose(c, [2.0, 1.0])
    area, c = pg.polygon_area_centroid(np.array([[0, 0], [3, 0], [0, 3.0]]))
    assert area == pytest.approx(4.5) and np.allclose(c, [1.0, 1.0])


@given(S.random_parts())
@settings(derandomize=True, deadline=None, max_examples=60)
def test_hull_and_com_match_oracle(part):
    pts, com = part
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pg.PartWarning)
        poly = pg.make_polygon(pts, com)
        poly_default = pg.make_polygon(pts)
    body, hidx, _ = oracle.body_from_part(pts, com)
    k = list(poly.hull_index).index(int(hidx[0]))
    assert list(poly.hull_index[k:] + poly.hull_index[:k]) == hidx.tolist()
    np.testing.assert_allclose(np.roll(poly.body, -k, axis=0), body, atol=1e-15)
    assert set(poly.dropped) == set(range(len(pts))) - set(hidx.tolist())
    np.testing.assert_allclose(poly_default.com, oracle.body_from_part(pts)[2], rtol=1e-12, atol=1e-15)


def test_non_convex_input_is_hulled_with_a_warning():
    pts = [[0, 0], [2, 0], [1, 0.5], [2, 2], [1, 2], [0, 2]]  # 2: reflex notch, 4: on the top edge
    with pytest.warns(pg.PartWarning, match=r"points \[2, 4\]"):
        poly = pg.make_polygon(pts)
    assert poly.dropped == (2, 4)
    assert sorted(poly.hull_index) == [0, 1, 3, 5]
    np.testing.assert_allclose(poly.com, [1.0, 1.0])
    with pytest.warns(pg.PartWarning, match=r"\[4\]"):
        pg.make_polygon([[0, 0], [2, 0], [2, 2], [0, 2], [1, 1]])  # interior point


@pytest.mark.parametrize("vertices, com, field, detail", [
    ([[0, 0], [1, float("nan")], [0, 1]], None, "vertices", r"rows \[1\]"),
    ([[0, 0], [1, float("inf")], [0, 1]], None, "vertices", "NaN or inf"),
    ([[0, 0], [1, 0]], None, "vertices", "at least 3"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], None, "vertices", "shape"),
    ([[0, 0], [1, 1], [2, 2], [3, 3]], None, "vertices", "collinear"),
    ([[0, 0], [0, 0], [0, 0]], None, "vertices", ""),
    ([[0, 0], [1, 0], [0, 1]], [1.0, 1.0], "com", "not strictly inside"),        # outside
    ([[0, 0], [1, 0], [0, 1]], [0.5, 0.0], "com", "not strictly inside"),        # on an edge
    ([[0, 0], [1, 0], [0, 1]], [0.0, 0.0], "com", "not strictly inside"),        # on a vertex
    ([[0, 0], [1, 0], [0, 1]], [0.2, float("nan")], "com", "NaN"),
    ([[0, 0], [1, 0], [0, 1]], [0.2, 0.2, 0.0], "com", ""),
])
def test_bad_parts_raise_part_error_naming_the_field(vertices, com, field, detail):
    with pytest.raises(pg.PartError, match=f"^{field}") as exc:
        pg.make_polygon(vertices, com)
    assert re.search(detail, str(exc.value))
    assert isinstance(exc.value, ValueError)


def test_caller_edge_to_hull_rejects_non_edges():
    poly = pg.make_polygon([[0, 0], [1, 0], [1, 1], [0, 1]])
    with pytest.raises(pg.PartError, match="not an edge"):
        poly.caller_edge_to_hull((0, 2))
    assert poly.to_dict() == {"vertices": [[0, 0], [1, 0], [1, 1], [0, 1]], "com": [0.5, 0.5]}


@pytest.mark.parametrize("scale, warns", [(1e-5, True), (1.1e-4, False), (0.03, False), (5.0, False),
                                          (30.0, True), (1e9, True)])
def test_implausible_sizes_warn(scale, warns):
    """A part read as metres but 30 "m" across (millimetres?) or 10 um across
    warns, naming what was assumed; it is still accepted."""
    pts = np.array([[0, 0], [1, 0], [1, 0.6], [0, 0.6]]) * scale / math.hypot(1, 0.6)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        poly = pg.make_polygon(pts)
    msgs = [str(w.message) for w in seen if issubclass(w.category, pg.PartWarning)]
    assert bool(msgs) == warns, msgs
    if warns:
        assert "read as metres" in msgs[0]
    assert poly.size == pytest.approx(scale)


# --------------------------------------------------------------------------
# geometry: normals, feet, stability, radius function
# --------------------------------------------------------------------------
def test_rectangle_geometry_by_hand():
    a, b = 0.03, 0.01
    poly = pg.make_polygon([[-a, -b], [a, -b], [a, b], [-a, b]])
    g = _geom(poly)
    e_bottom = _hull_edge(poly, 0, 1)
    order = [e_bottom + k for k in range(4)]  # bottom, right, top, left
    nu = np.asarray(g.nu)[np.array(order) % 4]
    want = [-math.pi / 2, 0.0, math.pi / 2, math.pi]
    assert max(abs(oracle.wrap(x - y)) for x, y in zip(nu, want)) < 1e-15
    np.testing.assert_allclose(np.asarray(g.height)[np.array(order) % 4], [b, a, b, a], atol=1e-15)
    np.testing.assert_allclose(np.asarray(g.foot), 0.5, atol=1e-15)
    np.testing.assert_allclose(np.asarray(g.exterior), math.pi / 2, atol=1e-15)
    assert np.all(np.asarray(g.stable))
    assert float(g.radius) == pytest.approx(math.hypot(a, b))
    assert int(classify(g)) == pg.NICE_STABLE


def test_normal_angles_are_in_documented_range():
    """PolygonGeometry.nu is documented as wrapped to (-pi, pi]: an edge pointing
    straight down (e = (0, -h), so -e_x = -0.0, where arctan2 gives -pi) gets pi.
    Input: the axis-aligned rectangle [[-a,-b],[a,-b],[a,b],[-a,b]], its left edge."""
    a, b = 0.03, 0.01
    g = _geom(pg.make_polygon([[-a, -b], [a, -b], [a, b], [-a, b]]))
    nu = np.asarray(g.nu)
    assert np.all((nu > -math.pi) & (nu <= math.pi)), nu.tolist()


def test_obtuse_triangle_has_an_unstable_edge():
    # centroid (3, 1/3): its foot on edge (4,0)-(5,1) falls before (4, 0)
    poly = pg.make_polygon([[0, 0], [4, 0], [5, 1]])
    g = _geom(poly)
    stable = {poly.edge_vertices(e) for e in range(3) if bool(g.stable[e])}
    assert stable == {(0, 1), (2, 0)}
    e = _hull_edge(poly, 1, 2)
    assert float(g.foot[e]) == pytest.approx(((3 - 4) * 1 + (1 / 3) * 1) / 2)
    assert int(classify(g)) == pg.BIPLUS_STABLE


UNI_HOUSE = np.array([  # com at the origin; only the bottom edge (0, 1) is stable
    [-math.cos(math.radians(30)), -0.5], [math.cos(math.radians(30)), -0.5],
    [2.2 * math.cos(math.radians(30)), 2.2 * 0.5], [0.0, 5.0],
    [-2.2 * math.cos(math.radians(30)), 2.2 * 0.5]]) * 0.01


@pytest.mark.parametrize("name, vertices, com, cls, n_stable", [
    ("uni house", UNI_HOUSE, [0.0, 0.0], pg.UNI_STABLE, 1),
    ("biplus obtuse triangle", [[0, 0], [0.4, 0], [0.5, 0.1]], None, pg.BIPLUS_STABLE, 2),
    # two opposite stable normals (gap exactly pi) do not span the plane
    ("biplus trapezoid", [[-0.1, 0], [0.1, 0], [0.3, 0.1], [-0.3, 0.1]], [0.0, 0.05], pg.BIPLUS_STABLE, 2),
    ("nice rectangle", [[0, 0], [3, 0], [3, 1], [0, 1]], None, pg.NICE_STABLE, 4),
    ("nice equilateral", [[0, 0], [1, 0], [0.5, math.sqrt(3) / 2]], None, pg.NICE_STABLE, 3),
    ("nice rectangle, com off-centre", [[0, 0], [3, 0], [3, 1], [0, 1]], [2.9, 0.95], pg.NICE_STABLE, 4),
])
def test_object_classes_by_hand(name, vertices, com, cls, n_stable):
    poly = pg.make_polygon(vertices, com)
    g = _geom(poly)
    assert int(np.sum(np.asarray(g.stable))) == n_stable, name
    assert int(classify(g)) == cls, name
    assert oracle.object_class(poly.body) == cls, name
    if name == "uni house":
        assert bool(g.stable[_hull_edge(poly, 0, 1)])


@given(st.one_of(S.random_parts(), S.parts_of_class(S.UNI)))
@settings(derandomize=True, deadline=None, max_examples=80)
def test_geometry_properties(part):
    pts, com = part
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pg.PartWarning)
        poly = pg.make_polygon(pts, com)
    g = _geom(poly)
    body = poly.body
    n = len(body)
    nu = np.asarray(g.nu)
    u = np.stack([np.cos(nu), np.sin(nu)], axis=1)
    proj = body @ u.T  # (vertex, edge)
    for e in range(n):
        # the edge's endpoints are on the support line with normal nu[e], at distance height[e]
        assert proj[e, e] == pytest.approx(float(g.height[e]), abs=1e-15)
        assert proj[(e + 1) % n, e] == pytest.approx(float(g.height[e]), abs=1e-15)
        assert np.all(proj[:, e] <= float(g.height[e]) + 1e-15)
        # radius function at an edge normal is that edge's height
        assert float(radius_fn(g, nu[e])) == pytest.approx(float(g.height[e]), abs=1e-15)
    assert float(np.sum(np.asarray(g.exterior))) == pytest.approx(2 * math.pi)
    assert np.all(np.asarray(g.exterior) > 0)
    assert sorted(np.flatnonzero(np.asarray(g.stable)).tolist()) == oracle.stable_edges(body)
    assert int(classify(g)) == oracle.object_class(body)
    assert float(g.radius) == pytest.approx(float(np.max(np.hypot(*body.T))))
    # radius function: its local minima are exactly the stable edges' normals
    phi = np.linspace(-math.pi, math.pi, 20001)[:-1]
    r = np.asarray(radius_fn(g, jnp.asarray(phi)))
    np.testing.assert_allclose(r, np.max(body @ np.stack([np.cos(phi), np.sin(phi)]), axis=0), atol=1e-15)
    is_min = (r < np.roll(r, 1)) & (r <= np.roll(r, -1))
    mins = phi[is_min]
    stable_nu = np.sort(nu[np.asarray(g.stable)])
    step = phi[1] - phi[0]
    wrap = np.vectorize(oracle.wrap)
    for m in mins:   # every minimum on the grid is a stable edge's normal
        assert np.min(np.abs(wrap(stable_nu - m))) <= step + 1e-12
    # ...and every stable edge shows up, but for near-marginal ones (foot within 1e-4 of an
    # end: a minimum too shallow for the grid)
    foot = np.asarray(g.foot)
    robust = np.asarray(g.stable) & (np.minimum(foot, 1.0 - foot) > 1e-4)
    for m in nu[robust]:
        assert len(mins) and np.min(np.abs(wrap(mins - m))) <= step + 1e-12


def test_geometry_vmaps_over_vertex_sets():
    rng = np.random.default_rng(0)
    body = pg.make_polygon(PENTAGON).body
    bodies = body[None] + rng.normal(scale=1e-3, size=(16, 5, 2))
    batched = jax.vmap(pg.polygon_geometry)(jnp.asarray(bodies))
    classes = jax.vmap(pg.object_class)(batched)
    tables = jax.vmap(pg.max_reorient_table)(batched)
    for i in range(16):
        gi = geometry(jnp.asarray(bodies[i]))
        for f in ("nu", "exterior", "foot", "height", "stable", "radius"):
            np.testing.assert_allclose(np.asarray(getattr(batched, f)[i]), np.asarray(getattr(gi, f)),
                                       atol=1e-15)
        assert int(classes[i]) == int(classify(gi))
        np.testing.assert_allclose(np.asarray(tables[i]), np.asarray(reorient_table(gi)), atol=1e-15)


# --------------------------------------------------------------------------
# maximum reorient angles, step angles, Peshkin distance
# --------------------------------------------------------------------------
@pytest.mark.parametrize("dx, dy", [(0.0, 0.0), (0.01, -0.004)])
def test_rectangle_max_reorient_by_hand(dx, dy):
    """CW pivots about the edge's start vertex, CCW about its end vertex; the
    angle is atan(offset of the pivot along the edge / height), below the
    90 degree exterior angle."""
    a, b = 0.03, 0.01
    poly = pg.make_polygon([[-a, -b], [a, -b], [a, b], [-a, b]], [dx, dy])
    g = _geom(poly)
    tab = np.asarray(reorient_table(g))
    bottom, right = _hull_edge(poly, 0, 1), _hull_edge(poly, 1, 2)
    assert tab[bottom, pg.CW] == pytest.approx(math.atan((a + dx) / (b + dy)))
    assert tab[bottom, pg.CCW] == pytest.approx(math.atan((a - dx) / (b + dy)))
    assert tab[right, pg.CW] == pytest.approx(math.atan((b + dy) / (a - dx)))
    assert tab[right, pg.CCW] == pytest.approx(math.atan((b - dy) / (a - dx)))
    for e in range(4):
        for sense in (pg.CW, pg.CCW):
            assert float(pg.max_reorient_angle(g, e, sense)) == pytest.approx(tab[e, sense])
            assert int(pg.pivot_vertex(4, e, sense)) == (e if sense == pg.CW else (e + 1) % 4)


def test_max_reorient_limited_by_exterior_angle():
    # flat hexagon: the bottom edge's alignment angle atan(2/0.3) = 81.5 deg exceeds the
    # exterior angle atan(0.3) = 16.7 deg at its ends, which then limits the reorientation
    poly = pg.make_polygon(np.array([[-3, 0], [-2, -0.3], [2, -0.3], [3, 0], [2, 0.3], [-2, 0.3]]) * 0.1,
                           [0.0, 0.0])
    g = _geom(poly)
    e = _hull_edge(poly, 1, 2)
    assert float(pg.alignment_angle(g, e, pg.CW)) == pytest.approx(math.atan(2 / 0.3))
    tab = np.asarray(reorient_table(g))
    assert tab[e, pg.CW] == pytest.approx(math.atan(0.3))
    assert tab[e, pg.CCW] == pytest.approx(math.atan(0.3))
    # an unstable edge has no reorient angle
    tri = pg.make_polygon([[0, 0], [0.4, 0], [0.5, 0.1]])
    gt = _geom(tri)
    eu = _hull_edge(tri, 1, 2)
    assert np.all(np.asarray(reorient_table(gt))[eu] == 0.0)


def test_step_angle_margin_rule():
    mx = jnp.array([0.5, 0.1, 0.0])
    margin = math.radians(7)
    np.testing.assert_allclose(np.asarray(pg.step_angle(mx, margin)), [0.5 - margin, 0.05, 0.0])


@pytest.mark.parametrize("safety", [1.0, 1.15])
def test_rectangle_peshkin_distance_by_hand(safety):
    a, b = 0.03, 0.01
    poly = pg.make_polygon([[-a, -b], [a, -b], [a, b], [-a, b]])
    g = _geom(poly)
    c = math.hypot(a, b)  # pivot distance = enclosing radius: (a^2 + c^2) / c = 2c
    beta2 = math.atan(a / b)
    for alpha in (0.1, 0.5, 1.2):
        want = safety * 2 * c * math.log(math.tan(beta2 / 2) / math.tan((beta2 - alpha) / 2))
        for sense in (pg.CW, pg.CCW):
            got = float(peshkin(g, _hull_edge(poly, 0, 1), sense, alpha, safety))
            assert got == pytest.approx(want, rel=1e-13)


@st.composite
def _reorient_case(draw):
    part = draw(st.one_of(S.parts_of_class(S.UNI), S.parts_of_class(S.BIPLUS), S.parts_of_class(S.NICE)))
    frac = draw(st.floats(0.05, 0.95))
    sense = draw(st.sampled_from([pg.CW, pg.CCW]))
    fence = draw(st.floats(-math.pi, math.pi))
    pick = draw(st.integers(0, 100))
    return part, frac, sense, fence, pick


@pytest.mark.slow
@given(_reorient_case())
@settings(derandomize=True, deadline=None, max_examples=60)
def test_peshkin_distance_is_what_the_replay_needs(case):
    """A reorient by alpha (a fraction of the maximum) onto a stable edge needs
    exactly the Peshkin distance in the exact replay: 0.999x stops short,
    1.0001x lands the edge."""
    (pts, com), frac, sense, fence, pick = case
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pg.PartWarning)
        poly = pg.make_polygon(pts, com)
    g = _geom(poly)
    n = poly.n
    stable = np.flatnonzero(np.asarray(g.stable))
    e = int(stable[pick % len(stable)])
    alpha = frac * float(reorient_table(g)[e, sense])
    # fence moving along d = (cos fence, sin fence); final orientation: edge e flush
    d = np.array([math.cos(fence), math.sin(fence)])
    th_final = fence + math.pi - float(g.nu[e])
    th0 = th_final + (alpha if sense == pg.CW else -alpha)  # CW turns theta down
    s = float(peshkin(g, e, sense, alpha, 1.0))
    # independent value from the oracle's closed form
    pivot = int(pg.pivot_vertex(n, e, sense))
    beta2 = float(pg.alignment_angle(g, e, sense))
    # an edge whose centre of mass's foot lies within ~1e-6 rad of its end (beta2 ~ 1e-9 in
    # one drawn part) fixes the distance to only ~eps / beta2 of itself: 1e-12 is unattainable
    tol = max(1e-12, 1e-15 / max(beta2, 1e-300))
    assert s == pytest.approx(oracle.peshkin_distance(poly.body, pivot, beta2 - alpha, beta2), rel=tol)
    assert float(peshkin(g, e, sense, alpha, 1.15)) == pytest.approx(1.15 * s, rel=1e-14)
    # the fence first touches the pivot vertex
    w = poly.body @ np.array([[math.cos(th0), -math.sin(th0)], [math.sin(th0), math.cos(th0)]]).T
    assert int(np.argmin(w @ d)) == pivot
    poses = np.tile([0.1, 0.2, th0], (2, 1))
    out = replay_batch(g, jnp.asarray(poses), jnp.asarray(np.tile(d, (2, 1))),
                       jnp.asarray([0.999 * s, 1.0001 * s]))
    assert not bool(out.complete[0]) and int(out.edge[0]) == -1
    assert bool(out.complete[1]) and int(out.edge[1]) == e
    assert abs(oracle.wrap(float(out.pose[1, 2]) - th_final)) < 1e-12
    assert float(out.rotation[1]) == pytest.approx(-alpha if sense == pg.CW else alpha, abs=1e-12)
    # the oracle agrees on both sides of the threshold
    for k, f in enumerate((0.999, 1.0001)):
        o = oracle.replay_push(poly.body, poses[k], d, f * s)
        assert o.complete == (k == 1)
