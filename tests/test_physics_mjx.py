"""The MJX backend of the physics rollouts.

One tiny smoke test on the CPU (MJX compiles for about a minute here); the
rest need an accelerator and are marked ``gpu`` (skipped without one).
"""
import math
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


@pytest.mark.slow
def test_mjx_smoke_on_cpu_agrees_with_the_c_engine():
    """One sample, a 2 cm translation of a part resting on its own corners
    (rigid support: the underside mesh with flatness errors), the same (soft)
    contact model on both engines: MJX (float32) lands the planned edge and
    agrees with the C engine, the oracle, to 0.5 mm (measured 0.04 mm; before
    the fence met a flat prism apart from the support's mesh, MJX let the fence
    pass through the part: 11 mm).  A tripod agrees to 0.03 mm (bench/fidelity.py)."""
    plan, body = _translate_plan(0.02)
    sam = Sampler(friction=FrictionRange(mu_f=(0.8, 0.8), mu_s=(0.5, 0.5), support="rigid"))
    params = sam.sample(jax.random.key(0), 1, n_vertices=4, dim=2, n_pushes=1, body=body)
    with jax.enable_x64(True):            # a caller inside a float64 scope is safe
        m = rollout_push_plan(plan, params, backend="mjx", settings=SOFT)
    c = rollout_push_plan(plan, params, backend="c", settings=SOFT)
    assert m["backend"] == "mjx" and m["steps"] == c["steps"]
    assert m["edges"][0, 0] == m["planned_edges"][0]
    assert math.hypot(m["x"][0] - c["x"][0], m["y"][0] - c["y"][0]) < 5e-4
    assert abs(m["theta"][0] - c["theta"][0]) < math.radians(0.1)
    assert m["success"][0]


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
    np.testing.assert_array_equal(m["edges"], c["edges"])
    d = np.hypot(m["x"] - c["x"], m["y"] - c["y"])
    assert np.median(d) < 5e-4 and np.max(d) < 2e-3, np.sort(d)
    assert m["success"].mean() >= c["success"].mean() - 0.05


@pytest.mark.gpu
@gpu
def test_auto_backend_is_mjx_on_an_accelerator():
    from robustness.physics import default_backend
    from robustness.physics.runner import resolve_backend

    assert default_backend() == "mjx"
    assert resolve_backend("auto", SOFT) == "mjx"
    assert resolve_backend("auto", PhysicsSettings()) == "c"   # noslip: the C engine
