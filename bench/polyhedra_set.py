"""A fixed benchmark set of convex polyhedra for the tumble planner.

``polyhedra_set()`` returns a list of :class:`BenchPart` (name, vertices in
metres about the body origin, optional centre of mass, a one-line note).
Every part is about 0.1 m across; everything is deterministic (random hulls
use fixed seeds).  The set mixes parts whose reachable set is discrete (all
defect angles rational multiples of pi and commensurable translations),
dense along lines, and dense:

* the five example parts (``examples/*.yaml`` with kind polyhedron);
* boxes with commensurable edges (1:1:2, 1:2:3) and incommensurable ones
  (1:sqrt2:1, 1:sqrt2:sqrt3, 1:pi/3:e/2);
* truncated pyramids (square and rectangular base, strong and slight taper),
  a square pyramid;
* right prisms over a regular triangle, pentagon and hexagon, and over a
  3-4-5 right triangle (irrational face angles);
* a regular icosahedron;
* convex hulls of random points on ellipsoids (seeds 0..5; every point is a
  hull vertex).
"""
from __future__ import annotations

import dataclasses
import math
import pathlib
from typing import Optional

import numpy as np
import yaml

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"
EXAMPLE_NAMES = ("cube", "tetrahedron", "octahedron", "truncated_pyramid", "irregular_polyhedron")


@dataclasses.dataclass(frozen=True)
class BenchPart:
    name: str
    vertices: np.ndarray
    com: Optional[np.ndarray]
    note: str

    @property
    def diameter(self) -> float:
        v = self.vertices
        return float(np.max(np.linalg.norm(v[:, None] - v[None], axis=-1)))


def box(a: float, b: float, c: float) -> np.ndarray:
    return np.array([[sx * a / 2, sy * b / 2, sz * c / 2]
                     for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])


def frustum(a: float, b: float, h: float, shrink: float) -> np.ndarray:
    """Rectangular base a x b at z = 0, top scaled by ``shrink`` at z = h."""
    base = [[sx * a / 2, sy * b / 2, 0.0] for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    top = [[shrink * x, shrink * y, h] for x, y, _ in base]
    return np.array(base + top)


def pyramid(a: float, h: float) -> np.ndarray:
    return np.array([[-a / 2, -a / 2, 0.0], [a / 2, -a / 2, 0.0], [a / 2, a / 2, 0.0],
                     [-a / 2, a / 2, 0.0], [0.0, 0.0, h]])


def prism(polygon: np.ndarray, h: float) -> np.ndarray:
    p = np.asarray(polygon, dtype=float)
    p = p - p.mean(axis=0)
    return np.concatenate([np.c_[p, np.full(len(p), -h / 2)], np.c_[p, np.full(len(p), h / 2)]])


def regular_polygon(n: int, r: float) -> np.ndarray:
    t = 2 * math.pi * np.arange(n) / n
    return np.c_[r * np.cos(t), r * np.sin(t)]


def icosahedron(r: float) -> np.ndarray:
    g = (1 + math.sqrt(5)) / 2
    pts = []
    for s1 in (-1, 1):
        for s2 in (-1, 1):
            pts += [[0, s1, s2 * g], [s1, s2 * g, 0], [s2 * g, 0, s1]]
    p = np.array(pts, dtype=float)
    return p * (r / np.linalg.norm(p[0]))


def random_hull(seed: int, n: int, size: float = 0.1) -> np.ndarray:
    """``n`` points on a random ellipsoid (all are hull vertices), about ``size`` across."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    axes = rng.uniform(0.6, 1.0, size=3)
    return d * axes * (size / 2)


def _example(name: str) -> BenchPart:
    doc = yaml.safe_load((EXAMPLES / f"{name}.yaml").read_text())
    com = doc.get("com")
    return BenchPart(name, np.asarray(doc["vertices"], float),
                     None if com is None else np.asarray(com, float), f"examples/{name}.yaml")


def polyhedra_set() -> list[BenchPart]:
    """The benchmark set (25 parts, deterministic)."""
    s = 0.1
    parts = [_example(n) for n in EXAMPLE_NAMES]
    add = parts.append
    add(BenchPart("box_1_1_2", box(s / 2, s / 2, s), None, "box, commensurable edges 1:1:2"))
    add(BenchPart("box_1_2_3", box(s / 3, 2 * s / 3, s), None, "box, commensurable edges 1:2:3"))
    add(BenchPart("box_1_r2_1", box(s / 1.5, s * math.sqrt(2) / 1.5, s / 1.5), None,
                  "box, incommensurable edges 1:sqrt2:1"))
    add(BenchPart("box_1_r2_r3", box(s / 2, s * math.sqrt(2) / 2, s * math.sqrt(3) / 2), None,
                  "box, incommensurable edges 1:sqrt2:sqrt3"))
    add(BenchPart("box_1_pi3_e2", box(s * 0.8, s * 0.8 * math.pi / 3, s * 0.8 * math.e / 2), None,
                  "box, incommensurable edges 1:pi/3:e/2"))
    add(BenchPart("frustum_sq_0.8", frustum(s, s, s * 0.8, 0.8), None,
                  "truncated pyramid, square base, top 0.8"))
    add(BenchPart("frustum_sq_0.98", frustum(s, s, s, 0.98), None,
                  "truncated pyramid, square base, top 0.98 (nearly a cube)"))
    add(BenchPart("frustum_rect_0.7", frustum(s, 0.7 * s, 0.6 * s, 0.7), None,
                  "truncated pyramid, 1 x 0.7 base, top 0.7"))
    add(BenchPart("pyramid_sq", pyramid(s, 0.7 * s), None, "square pyramid"))
    add(BenchPart("prism_tri", prism(regular_polygon(3, s / math.sqrt(3)), s), None,
                  "right prism over an equilateral triangle"))
    add(BenchPart("prism_pent", prism(regular_polygon(5, s / 2), 0.8 * s), None,
                  "right prism over a regular pentagon"))
    add(BenchPart("prism_hex", prism(regular_polygon(6, s / 2), 0.6 * s), None,
                  "right prism over a regular hexagon"))
    add(BenchPart("prism_345", prism(np.array([[0, 0], [0.08, 0], [0, 0.06]]), 0.05), None,
                  "right prism over a 3-4-5 triangle"))
    add(BenchPart("icosahedron", icosahedron(s / 2), None, "regular icosahedron"))
    for seed, n in ((0, 6), (1, 7), (2, 8), (3, 9), (4, 10), (5, 12)):
        add(BenchPart(f"hull_s{seed}_n{n}", random_hull(seed, n, s), None,
                      f"hull of {n} random points on an ellipsoid, seed {seed}"))
    return parts


if __name__ == "__main__":  # pragma: no cover - listing
    for p in polyhedra_set():
        print(f"{p.name:18s} {len(p.vertices):3d} vertices  diameter {p.diameter:.4f} m  {p.note}")
