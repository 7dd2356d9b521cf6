"""Tests of planning.tumbling.words: tumble sequences and their free reduction."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planning.tumbling.words import concat, end_face, inverse, is_walk, power, purge

SETTINGS = settings(derandomize=True, max_examples=200, deadline=None)


def _sym(edges):
    adj: dict[int, set[int]] = {}
    for a, b in edges:
        adj.setdefault(a, set()).add(b)
        adj.setdefault(b, set()).add(a)
    return adj


# cube: faces 0..5, opposite pairs (0,1), (2,3), (4,5)
CUBE = {f: {g for g in range(6) if g != f and g // 2 != f // 2} for f in range(6)}
# octahedron faces = cube vertices (sign triples); adjacent iff they differ in one sign
OCTA = {f: {f ^ 1, f ^ 2, f ^ 4} for f in range(8)}
TETRA = {f: {g for g in range(4) if g != f} for f in range(4)}
PATH3 = _sym([(0, 1), (1, 2)])  # a tree: every closed walk reduces to ()
GRAPHS = [CUBE, OCTA, TETRA, PATH3, _sym([(0, 1), (1, 2), (2, 0), (2, 3), (3, 4), (4, 2)])]


@st.composite
def walks(draw, closed=False):
    adj = draw(st.sampled_from(GRAPHS))
    start = draw(st.sampled_from(sorted(adj)))
    choices = draw(st.lists(st.integers(0, 10**6), max_size=30))
    w, cur = [], start
    for c in choices:
        nb = sorted(adj[cur])
        cur = nb[c % len(nb)]
        w.append(cur)
    w = tuple(w)
    if closed and w and w[-1] != start:
        w = concat(w, _shortest(adj, w[-1], start))  # close the loop
    return adj, start, w


def _shortest(adj, a, b):
    """BFS walk from a to b as a word (faces after a)."""
    prev = {a: None}
    frontier = [a]
    while b not in prev:
        nxt = []
        for f in frontier:
            for g in sorted(adj[f]):
                if g not in prev:
                    prev[g] = f
                    nxt.append(g)
        frontier = nxt
    out = []
    f = b
    while f != a:
        out.append(f)
        f = prev[f]
    return tuple(reversed(out))


def _no_backtrack(path):
    return all(path[i] != path[i + 2] for i in range(len(path) - 2))


@SETTINGS
@given(walks())
def test_purge_properties(case):
    adj, start, w = case
    assert is_walk(w, start, adj)
    p = purge(w, start, adj)
    assert purge(p, start) == p  # idempotent
    assert len(p) <= len(w)
    assert end_face(p, start) == end_face(w, start)
    assert is_walk(p, start, adj)
    assert _no_backtrack((start,) + p)
    assert (len(w) - len(p)) % 2 == 0  # cancellations remove pairs


@SETTINGS
@given(walks())
def test_inverse_cancels(case):
    adj, start, w = case
    wi = inverse(w, start)
    end = end_face(w, start)
    assert len(wi) == len(w)
    assert is_walk(wi, end, adj)
    assert end_face(wi, end) == start
    assert inverse(wi, end) == w
    assert purge(concat(w, wi), start) == ()
    assert purge(concat(wi, w), end) == ()


@SETTINGS
@given(walks(), walks())
def test_purge_is_a_homomorphism(c1, c2):
    adj, start, w1 = c1
    end = end_face(w1, start)
    # build a second walk on the same graph starting where w1 ends
    _, _, w2raw = c2
    w2, cur = [], end
    for f in w2raw:
        nb = sorted(adj[cur])
        cur = nb[f % len(nb)]
        w2.append(cur)
    w2 = tuple(w2)
    full = purge(concat(w1, w2), start)
    assert full == purge(concat(purge(w1, start), w2), start)
    assert full == purge(concat(w1, purge(w2, end)), start)


@SETTINGS
@given(walks(closed=True), st.integers(-4, 4))
def test_power_of_loops(case, n):
    adj, start, w = case
    assert end_face(w, start) == start
    wn = power(w, n, start)
    assert is_walk(wn, start, adj)
    assert len(wn) == abs(n) * len(w)
    assert purge(concat(wn, power(w, -n, start)), start) == ()
    assert purge(concat(power(w, n, start), w), start) == purge(power(w, n + 1, start), start)
    if adj is PATH3:  # a tree has trivial loop group
        assert purge(w, start) == ()


def test_examples():
    assert inverse((2, 3, 4), 1) == (3, 2, 1)
    assert inverse((), 7) == ()
    assert purge((2, 1), 1) == ()
    assert purge((2, 3, 2, 1, 5), 1) == (5,)
    assert purge((2, 3, 4, 3, 2, 1), 1) == ()
    assert purge((), 0) == ()
    assert power((2, 1), 3, 1) == (2, 1, 2, 1, 2, 1)
    assert power((2, 3, 1), -1, 1) == (3, 2, 1)
    assert power((2, 3), 1, 1) == (2, 3) and power((2, 3), -1, 1) == (2, 1)
    assert power((2, 3), 0, 1) == ()
    with pytest.raises(ValueError):
        power((2, 3), 2, 1)
    with pytest.raises(ValueError):
        purge((1, 1), 0)
    with pytest.raises(ValueError):
        purge((0,), 0)
    with pytest.raises(ValueError):
        purge((1,), 0, adjacency=CUBE)  # opposite faces are not adjacent
    assert concat((1, 2), (), (3,)) == (1, 2, 3)
