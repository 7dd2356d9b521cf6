"""The shared planar formulas: each JAX function against its numpy twin and
the documented range (-pi, pi]."""
import math

import jax
import numpy as np
import pytest
from hypothesis import given, strategies as st

from kernels.planar import (angle_distance, rot2, rot2_np, wrap_angle, wrap_angle_near,
                            wrap_angle_np)

pytestmark = pytest.mark.float64

ANGLES = st.floats(-1e3, 1e3, allow_nan=False)


@given(ANGLES)
def test_wrap_range_and_twin(a):
    w = wrap_angle_np(a)
    assert -math.pi < w <= math.pi
    assert math.isclose(math.cos(w), math.cos(a), abs_tol=1e-9)
    assert math.isclose(math.sin(w), math.sin(a), abs_tol=1e-9)
    assert float(wrap_angle(jax.numpy.asarray(a))) == w
    assert float(wrap_angle_np(np.array([a]))[0]) == w


def test_wrap_ends():
    for a in (math.pi, -math.pi, 3 * math.pi, -3 * math.pi):
        assert wrap_angle_np(a) == math.pi
        assert float(wrap_angle(jax.numpy.asarray(a))) == math.pi
    assert wrap_angle_np(0.0) == 0.0


@given(st.floats(-20.0, 20.0, allow_nan=False))
def test_wrap_near_agrees_away_from_pi(a):
    w = float(wrap_angle_near(jax.numpy.asarray(a)))
    assert abs(w) <= math.pi
    assert abs(wrap_angle_np(w - a)) < 1e-12


@given(ANGLES, ANGLES)
def test_angle_distance(a, b):
    d = angle_distance(a, b)
    assert 0.0 <= d <= math.pi
    assert abs(d - angle_distance(b, a)) <= 1e-14 * (1.0 + abs(a - b))  # rounding of a - b


@given(ANGLES)
def test_rotation_twins(t):
    R = np.asarray(rot2(jax.numpy.asarray(t)))
    assert np.allclose(R, rot2_np(t), atol=1e-15)
    assert np.allclose(R @ R.T, np.eye(2), atol=1e-12)
    assert math.isclose(np.linalg.det(R), 1.0, abs_tol=1e-12)
