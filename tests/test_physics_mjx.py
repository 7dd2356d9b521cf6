"""The MJX backend of the physics rollouts.

One tiny smoke test on the CPU (MJX compiles for about a minute here); the
rest need an accelerator and are marked ``gpu`` (skipped without one).
"""
import dataclasses
import pathlib

import jax
import numpy as np
import pytest

from kernels import polygon as pg
from planning import plan_pose
from robustness import FrictionRange, Sampler
from robustness.physics import PhysicsSettings, rollout_push_plan
from robustness.physics.settings import SOFT_IMPRATIO
from sweeps.partfile import load_part

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"
ACCELERATOR = jax.default_backend() in ("gpu", "cuda", "rocm", "tpu")
gpu = pytest.mark.skipif(not ACCELERATOR, reason="needs an accelerator (MJX on CPU is slow)")


def _translate_plan(distance):
    part = load_part(EXAMPLES / "rectangle.yaml")
    plan = plan_pose(part.vertices, (0.0, 0.0, 0.0), (distance, 0.0, 0.0), com=part.com)
    body = pg.make_polygon(part.vertices, part.com).body
    return plan, body


#: the contact model both engines run (MJX has no noslip solver)
SOFT = PhysicsSettings(noslip_iterations=0, impratio=SOFT_IMPRATIO)


def _copies_with_nudged_starts(draws, n, seed=0):
    """``n`` copies of a one-sample draw whose starts move by at most 1e-7 m and
    1e-6 rad (the first copy unmoved): far below anything a cell can set, so
    an engine whose final poses spread over these copies shows its own noise."""
    rng = np.random.default_rng(seed)
    off = np.zeros((n, 3))
    off[1:, :2] = rng.uniform(-1e-7, 1e-7, (n - 1, 2))
    off[1:, 2] = rng.uniform(-1e-6, 1e-6, n - 1)
    first = jax.tree_util.tree_map(
        lambda x, ax: x if ax is None else np.repeat(np.asarray(x)[:1], n, axis=0),
        draws.params, draws.in_axes)
    zeros = np.zeros((n, 1))
    params = dataclasses.replace(first, execution=dataclasses.replace(
        first.execution, start_offset=off, fence_angle=zeros, distance_rel=zeros,
        distance_abs=zeros))
    axes = dataclasses.replace(draws.in_axes, execution=dataclasses.replace(
        draws.in_axes.execution, start_offset=0, fence_angle=0, distance_rel=0,
        distance_abs=0))
    return dataclasses.replace(draws, params=params, in_axes=axes)


@pytest.mark.slow
def test_mjx_smoke_on_cpu_agrees_with_the_c_engine():
    """A 2 cm translation of a part resting on its own corners (rigid support:
    the underside mesh with flatness errors), the same (soft) contact model on
    both engines, over 8 copies of one sample whose starts differ by at most
    1e-7 m and 1e-6 rad.  MJX (float32) lands the planned edge on every copy
    and agrees with the C engine, the oracle, in distribution, not copy by copy.

    Measured (issue 37; mujoco 3.16 and 4.0.1, mujoco-mjx 3.16 and 3.17, jaxlib
    0.10.0 / 0.10.1 / 0.10.2, 8 and 16 copies, 2 CPU cores): the C engine's
    headings span 0.02-0.05 deg and its positions 0.03 mm; MJX's headings span
    0.45-1.94 deg, mostly within +-0.25 deg, with one copy in 8-16 at
    +-1.7 deg (a failure under the 1 deg criterion); MJX's median heading
    0.04-0.19 deg from C's, its positions a median 0.06-0.12 mm and at most
    0.17-0.71 mm from C's.  MJX's float32 trajectory of a part rocking on its
    corners is decided by rounding: jaxlib 0.10.1 and again 0.10.2 (XLA:CPU)
    round differently from 0.10.0 (which equals 0.9.2 here) and moved the one
    unmoved copy's heading from -0.134 deg to +0.098 and +0.254 deg, where
    the C engine says -0.06 to -0.08; mujoco 3.16 -> 4.0.1 moved the C engine
    by 0.02 deg and mujoco-mjx 3.16 -> 3.17 moved nothing.  The test once
    asked that one copy to agree within 0.1 deg: it passed by an accident of
    rounding.  The bounds below are those figures with room for another
    rounding change."""
    plan, body = _translate_plan(0.02)
    sam = Sampler(friction=FrictionRange(mu_f=(0.8, 0.8), mu_s=(0.5, 0.5), support="rigid"))
    n = 8
    params = _copies_with_nudged_starts(
        sam.sample(jax.random.key(0), n, n_vertices=4, dim=2, n_pushes=1, body=body), n)
    with jax.enable_x64(True):            # a caller inside a float64 scope is safe
        m = rollout_push_plan(plan, params, backend="mjx", settings=SOFT)
    c = rollout_push_plan(plan, params, backend="c", settings=SOFT)
    assert m.backend == "mjx" and m.steps == c.steps
    assert (m.edges[:, 0] == m.planned_edges[0]).all()
    np.testing.assert_array_equal(m.edges, c.edges)
    d = np.hypot(m.x - c.x, m.y - c.y)
    assert np.median(d) < 3e-4 and d.max() < 1.5e-3, d
    th_m, th_c = np.degrees(m.theta), np.degrees(c.theta)
    assert np.ptp(th_c) < 0.1 and np.ptp(c.y) < 1e-4, th_c  # the oracle is steady
    assert abs(np.median(th_m) - np.median(th_c)) < 0.35, (th_m, th_c)
    assert np.mean(np.abs(th_m - np.median(th_c)) < 0.5) >= 0.75, th_m
    assert np.abs(th_m).max() < 2.5, th_m
    assert c.success.all() and m.success.mean() >= 0.75


@pytest.mark.gpu
@gpu
def test_mjx_batch_agrees_with_the_c_engine_on_an_accelerator():
    """64 perturbed parts on their own corners (rigid support), 10 cm, the soft
    model on both engines: the same landed edges, and final positions a median
    0.5 mm and at most 2 mm apart (C engine the oracle).  Measured on 16 of these
    draws with MJX on a CPU: median 0.27 mm, largest 1.05 mm, 0.3 degrees: the
    soft model's creep over 10 cm, float32 against float64."""
    plan, body = _translate_plan(0.1)
    sam = Sampler(friction=FrictionRange(mu_f=(0.5, 1.0), mu_s=(0.3, 0.6), support="rigid"))
    params = sam.sample(jax.random.key(1), 64, n_vertices=4, dim=2, n_pushes=1, body=body)
    m = rollout_push_plan(plan, params, backend="mjx", settings=SOFT)
    c = rollout_push_plan(plan, params, backend="c", settings=SOFT)
    np.testing.assert_array_equal(m.edges, c.edges)
    d = np.hypot(m.x - c.x, m.y - c.y)
    assert np.median(d) < 5e-4 and np.max(d) < 2e-3, np.sort(d)
    assert m.success.mean() >= c.success.mean() - 0.05


@pytest.mark.gpu
@gpu
def test_auto_backend_is_mjx_on_an_accelerator():
    from robustness.physics import default_backend
    from robustness.physics.runner import resolve_backend

    assert default_backend() == "mjx"
    assert resolve_backend("auto", SOFT) == "mjx"
    assert resolve_backend("auto", PhysicsSettings()) == "c"   # noslip: the C engine
