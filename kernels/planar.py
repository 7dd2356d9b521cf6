"""Small planar formulas shared by every layer: angle wraps and 2-D rotations.

One definition of each, with its numpy twin beside the JAX one where the host
side needs it too (planners' reference paths, figures, tables).  Units:
radians, CCW positive; the canonical range of a wrapped angle is (-pi, pi].
"""
from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np

TWO_PI = 2.0 * math.pi


def wrap_angle(a):
    """Angles (rad) wrapped to (-pi, pi] (JAX; exact at the ends: pi stays pi, -pi becomes pi)."""
    return jnp.pi - jnp.remainder(jnp.pi - a, TWO_PI)


def wrap_angle_np(a):
    """numpy / float twin of :func:`wrap_angle`: angles (rad) wrapped to (-pi, pi]."""
    if np.ndim(a) == 0 and not isinstance(a, np.ndarray):
        return math.pi - (math.pi - float(a)) % TWO_PI
    return np.pi - np.remainder(np.pi - np.asarray(a, np.float64), TWO_PI)


def wrap_angle_near(a):
    """Angles within a few turns of zero wrapped to [-pi, pi] by rounding the
    number of turns (JAX).  Cheaper than :func:`wrap_angle` in a hot loop; at
    exactly +-pi either end may come out, so use it only where that is immaterial."""
    return a - TWO_PI * jnp.round(a / TWO_PI)


def angle_distance(a, b) -> float:
    """|a - b| wrapped to [0, pi] (rad, floats)."""
    return abs(wrap_angle_np(float(a) - float(b)))


def mod_2pi(a):
    """Angles (rad) reduced to [0, 2 pi) (JAX)."""
    return jnp.remainder(a, TWO_PI)


def cross2(a, b):
    """z-component of the cross product of 2-D vectors (last axis; JAX or numpy arrays)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def rot2(theta):
    """2x2 matrix of a CCW rotation by ``theta`` rad (JAX, a scalar angle)."""
    c, s = jnp.cos(theta), jnp.sin(theta)
    return jnp.stack([jnp.stack([c, -s]), jnp.stack([s, c])])


def rot2_np(theta) -> np.ndarray:
    """numpy twin of :func:`rot2` (float64)."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])
