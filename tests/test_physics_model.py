"""``model: mujoco`` through the commands a user types: a study and a certificate
whose samples are rolled out in MuJoCo (C engine, tiny batches), the config's
``physics:`` section, and the tumble device's friction check before any work."""
import math

import pandas as pd
import pytest

from tests.commandline import nudge, nudge_here

STUDY = """study: physics
kind: push
part: rectangle
tasks:
  - {{name: slide, start: [0, 0, 0], goal: [0.03, 0, 0]}}
tolerances: {{tau_com: 1e-4}}
friction: {{mu_f: [0.8, 0.8], mu_s: [0.5, 0.5]}}
eps: {{pos_eps_m: 0.002, theta_eps_rad: 0.05}}
model: mujoco
physics: {{backend: c, cell: {{timestep: 0.004}}}}
samples: 2
seed: 1
report: false
{extra}"""


def _input_error(r, *words):
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    for w in words:
        assert w in lines[0], lines[0]
    return lines[0]


@pytest.mark.slow
def test_sweep_rolls_out_in_mujoco(tmp_path):
    cfg = tmp_path / "physics.yaml"
    cfg.write_text(STUDY.format(extra=""))
    out = tmp_path / "out"
    r = nudge("sweep", cfg, "--out", out)
    assert r.returncode == 0, r.stderr
    s = pd.read_parquet(out / "samples")
    assert len(s) == 2 and (s["model"] == "mujoco").all() and (s["dtype"] == "float64").all()
    # a 3 cm translation of a flush rectangle in MuJoCo ends within a fraction of a mm
    assert s["success"].all() and (s["err_pos_m"] < 5e-4).all(), s[["err_pos_m", "failure_mode"]]
    assert s["max_tilt_rad"].between(0, math.radians(5)).all()
    # the kinematic models' answers on the same draws sit on the same rows
    assert (s["dpos_vs_quasistatic_m"] < 5e-4).all() and (s["dpos_vs_exact_m"] < 5e-4).all()
    assert (s["dtheta_vs_exact_rad"].abs() < math.radians(0.5)).all()
    assert s["success_quasistatic"].all() and s["success_exact"].all()
    summ = pd.read_parquet(out / "summary")
    assert (summ["model"] == "mujoco").all() and summ["n_left_workspace"].iloc[0] == 0
    # the analytic bound assumes a planar model: it is not computed for physics rows
    assert not s["in_bound_model"].any()


@pytest.mark.slow
def test_physics_section_is_validated_before_any_work(tmp_path):
    cfg = tmp_path / "bad.yaml"
    cfg.write_text(STUDY.format(extra="").replace("timestep: 0.004", "timestep: -1"))
    _input_error(nudge_here("sweep", cfg, "--out", tmp_path / "o"), "physics.cell", "timestep")
    cfg.write_text(STUDY.format(extra="").replace("backend: c", "backend: gpu"))
    _input_error(nudge_here("sweep", cfg, "--out", tmp_path / "o"), "physics.backend")
    assert not (tmp_path / "o" / "samples").exists()


def test_tumble_in_mujoco_needs_pad_friction(tmp_path):
    cfg = tmp_path / "tumble.yaml"
    cfg.write_text("""study: t
kind: tumble
part: cube
tasks:
  - {name: roll, goal: [0, 0, 0, 1]}
model: mujoco
friction: {mu_f: [0.5, 0.8], mu_s: [1.5, 1.5]}
samples: 2
report: false
""")
    _input_error(nudge_here("sweep", cfg, "--out", tmp_path / "o"), "friction.mu_f", "1.3")


@pytest.mark.slow
def test_certify_in_mujoco_says_which_model(tmp_path):
    """... with a part file's own material (thickness, density: taken into the cell
    once, when the config is read)."""
    cfg = tmp_path / "cert.yaml"
    cfg.write_text("""part:
  name: plate
  vertices: [[0, 0], [0.06, 0], [0.06, 0.03], [0, 0.03]]
  thickness: 0.005
  density: 2700
friction: {mu_f: [0.8, 0.8], mu_s: [0.5, 0.5]}
eps: {pos_eps_m: 0.002, theta_eps_rad: 0.05}
required: {probability: 0.5, confidence: 0.5}
n_samples: 2
model: mujoco
physics: {backend: c}
tasks:
  - {name: slide, start: [0, 0, 0], goal: [0.03, 0, 0]}
""")
    out = tmp_path / "out"
    r = nudge_here("certify", cfg, "--out", out, "--quiet")
    assert r.returncode in (0, 1), r.stderr
    c = pd.read_parquet(out / "certificates")
    assert (c["model"] == "mujoco").all()
    assert "mujoco" in r.stdout.lower()


@pytest.mark.slow
def test_evaluate_tumble_in_mujoco_beside_the_exact_model():
    """A tumble plan's physics rows carry the exact kinematics' answer on the same draw;
    the quasi-static columns stay empty (tumbles have no quasi-static model)."""
    import pathlib
    import warnings

    import jax

    from planning import plan_tumble
    from robustness import FrictionRange, GeometryTolerance, Sampler, evaluate
    from robustness import Model
    from robustness.physics import PhysicsRun
    from sweeps.partfile import load_part

    cube = load_part(pathlib.Path(__file__).resolve().parents[1] / "examples" / "cube.yaml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plan = plan_tumble(cube.vertices, goal=(0.0, 0.0, 0.0, 1), com=cube.com, eps=2e-3)
    sam = Sampler(geometry=GeometryTolerance(tau_com=1e-3),
                  friction=FrictionRange(mu_f=(1.5, 1.5), mu_s=(1.5, 1.5)))
    ev = evaluate(plan, sam, 1, jax.random.key(0), model=Model("mujoco", physics=PhysicsRun(backend="c")))
    s = ev.samples
    assert ev.model == "mujoco" and (s["final_face"] == s["planned_face"]).all()
    assert s["success"].all() and s["success_exact"].all() and s["success_quasistatic"].isna().all()
    # the support's realised c is a push scene's reading: empty for a tumble
    assert s["c_physical_m"].isna().all() and s["support_ok"].isna().all()
    assert (s["dpos_vs_exact_m"] < 1e-3).all() and (s["dtheta_vs_exact_rad"].abs() < 0.01).all()
    with pytest.raises(ValueError, match="friction.mu_f"):
        evaluate(plan, Sampler(), 1, jax.random.key(0), model="mujoco")


SUPPORT_PART = """part:
  name: plate
  vertices: [[0, 0], [0.04, 0], [0.04, 0.02], [0, 0.02]]
  thickness: 0.005
  density: 2700
"""


@pytest.mark.slow
def test_sweep_in_mujoco_realises_the_support_family_and_the_part_material(tmp_path):
    """friction.support and the part file's thickness and density, through
    ``nudge sweep``: the samples name their family, and the scene stood the
    5 mm aluminium plate on it (the rows are the physics of that part)."""
    cfg = tmp_path / "physics.yaml"
    doc = STUDY.format(extra="").replace("part: rectangle\n", SUPPORT_PART).replace(
        "mu_s: [0.5, 0.5]}", "mu_s: [0.5, 0.5], support: rigid}")
    cfg.write_text(doc)
    out = tmp_path / "out"
    r = nudge_here("sweep", cfg, "--out", out)
    assert r.returncode == 0, r.stderr
    s = pd.read_parquet(out / "samples")
    assert (s["support"] == "rigid").all()
    # a centred rectangle on its corners rests on a diagonal: c is the corner radius
    assert s["c_m"].to_numpy() == pytest.approx(math.hypot(0.02, 0.01))
    assert s["success"].all(), s[["err_pos_m", "failure_mode"]]
    # ... and MuJoCo's settled support loads realise that c (the rigid part rocks between
    # corner triangles in soft contact: within 1 mm) with the com inside the loaded corners
    assert (s["c_physical_m"] - s["c_m"]).abs().max() < 1e-3, s[["c_m", "c_physical_m"]]
    assert s["support_ok"].all()
    # the material reached the scene: a different thickness is refused in physics.cell
    cfg.write_text(doc.replace("timestep: 0.004", "timestep: 0.004, part_thickness: 0.002"))
    _input_error(nudge_here("sweep", cfg, "--out", tmp_path / "o2"), "part_thickness",
                 "thickness:", "part-file")


def test_the_contact_model_does_not_change_with_the_backend(tmp_path):
    """MJX has no noslip solver: asking for it with the default (noslip)
    contact model is refused before any work, naming the fields."""
    cfg = tmp_path / "physics.yaml"
    cfg.write_text(STUDY.format(extra="").replace("backend: c", "backend: mjx"))
    _input_error(nudge_here("sweep", cfg, "--out", tmp_path / "o"), "noslip_iterations: 0",
                 "impratio: 30")
    assert not (tmp_path / "o").exists()


def test_a_points_support_cannot_be_rolled_out(tmp_path):
    cfg = tmp_path / "physics.yaml"
    cfg.write_text(STUDY.format(extra="").replace("mu_s: [0.5, 0.5]}",
                                                  "mu_s: [0.5, 0.5], support: points}"))
    _input_error(nudge_here("sweep", cfg, "--out", tmp_path / "o"), "support", "points")
