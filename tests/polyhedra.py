"""Polyhedra for the tumbling tests: the bundled examples, boxes and seeded
random hulls (metres)."""
import pathlib

import numpy as np
import yaml

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"


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
