"""Planning is float64 whatever the caller's JAX setting, and importing nudge
changes no global JAX setting (each check in a fresh interpreter)."""
import pytest
import json
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]

PLAN_POSE = """
import json, jax
{enable}
from planning import plan_pose
plan = plan_pose([[0, 0], [0.03, 0], [0.005, 0.02]], (0.0, 0.0, 6.0), (0.1, 0.05, 1.0))
print(json.dumps(plan.to_dict()))
"""


def _run(code: str) -> str:
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       timeout=600, env={"PATH": "/usr/bin:/bin", "JAX_PLATFORMS": "cpu",
                                         "HOME": str(ROOT)})
    assert p.returncode == 0, p.stderr[-3000:]
    return p.stdout.strip().splitlines()[-1]


@pytest.mark.slow
def test_imports_change_no_global_setting_and_tumble_plan_is_exact():
    out = _run("""
import json, jax
import kernels, planning, robustness, sweeps
before = bool(jax.config.jax_enable_x64)
from planning import plan_tumble
cube = [[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)]
plan = plan_tumble(cube, (-3.0, 1.0, 0.0, 0), eps=1e-9)
print(json.dumps([before, bool(jax.config.jax_enable_x64), plan.verdict, plan.error]))
""")
    before, after, verdict, err = json.loads(out)
    assert before is False and after is False
    assert verdict == "solved" and err < 1e-15


@pytest.mark.slow
def test_plan_pose_identical_with_and_without_global_x64():
    off = _run(PLAN_POSE.format(enable=""))
    on = _run(PLAN_POSE.format(enable='jax.config.update("jax_enable_x64", True)'))
    assert off == on


@pytest.mark.slow
def test_evaluate_float64_without_global_x64():
    out = _run("""
import json, jax
from planning import plan_pose
from robustness import Sampler, evaluate
plan = plan_pose([[0, 0], [0.03, 0], [0.005, 0.02]], (0.0, 0.0, 0.0), (0.1, 0.05, 1.0))
ev = evaluate(plan, Sampler(), 4, jax.random.key(0), model="exact")
print(json.dumps([ev.summary["dtype"], float(ev.samples["err_pos_m"].max()),
                  bool(jax.config.jax_enable_x64)]))
""")
    dtype, err, x64 = json.loads(out)
    assert dtype == "float64" and err < 1e-12 and x64 is False
