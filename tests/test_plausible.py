"""Plausibility of the numbers a user types (sweeps.plausible): angles that only
make sense in degrees, tolerances and accuracies as large as the part, friction
beyond any material, a part in millimetres.  Through the commands (one line
naming the field and the fix, before any work; errors exit 2 and write nothing)
and in-process through the validation entry points (fast: no planning)."""
import math

import numpy as np
import pytest

from sweeps import catalog, certify, plan_push, plan_tumble, plausible, run
from sweeps.config import ConfigError
from sweeps.partfile import load_part
from sweeps.study import load_design
from sweeps.tasks import plan_row
from tests.commandline import call

RECT = 0.02 * math.sqrt(5)          # the bundled rectangle (40 mm x 20 mm) is 44.7 mm across

STUDY = """study: sane
kind: push
part: rectangle
tasks:
  - {name: a, start: [0, 0, 0], goal: [0.08, 0.03, 1.0]}
tolerances: {tau_v: 2e-5, tau_com: 1e-4}
friction: {mu_f: [0.3, 0.8]}
execution: {start_xy: 5e-4, start_theta: 0.01, distance_rel: 0.005}
eps: {pos_eps_m: 0.003, theta_eps_rad: 0.05}
model: exact
samples: 4
report: false
"""

CERTIFY = """part: rectangle
tolerances: {tau_v: 2e-5}
eps: {pos_eps_m: 0.003, theta_eps_rad: 0.05}
n_samples: 4
tasks:
  - {name: a, start: [0, 0, 0], goal: [0.08, 0.03, 0]}
"""

MM_RECT = "name: rect_mm\nkind: polygon\nvertices: [[0, 0], [40, 0], [40, 20], [0, 20]]\n"
MM_CUBE = ("name: cube_mm\nkind: polyhedron\nvertices:\n"
           + "".join(f"  - [{x}, {y}, {z}]\n" for x in (-50, 50) for y in (-50, 50)
                     for z in (-50, 50)))


def _write(tmp_path, text, name="study.yaml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def _errors(r, n):
    """The ``n`` lines of a refused command (``call``'s ``(status, stdout, stderr)``):
    exit 2, nothing on stdout, no traceback, only ``error:`` lines."""
    code, out, err = r
    assert code == 2, (code, out, err)
    assert "Traceback" not in err and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == n and all(ln.startswith("error: ") for ln in lines), err
    return lines


# ---------------------------------------------------------------- through the commands
def test_heading_in_degrees_without_deg_is_refused_before_any_work(tmp_path):
    text = STUDY.replace("  - {name: a, start: [0, 0, 0], goal: [0.08, 0.03, 1.0]}\n",
                         "  sample: {n: 3, annulus: [0.05, 0.15], heading: [-180, 180]}\n")
    out = tmp_path / "out"
    (line,) = _errors(call(run.main, _write(tmp_path, text), "--out", out), n=1)
    assert "tasks.sample.heading" in line and "[-180, 180]" in line, line
    assert "looks like degrees" in line and "[-180deg, 180deg]" in line, line
    assert not out.exists()


def test_certify_lengths_as_large_as_the_part_exit_2_and_write_nothing(tmp_path):
    text = CERTIFY.replace("tau_v: 2e-5", "tau_v: 0.5").replace("pos_eps_m: 0.003", "pos_eps_m: 3")
    out = tmp_path / "out"
    errors = _errors(call(certify.main, _write(tmp_path, text, "cfg.yaml"), "--out", out, "--quiet"),
                     n=2)
    assert any("tolerances.tau_v" in ln and "0.5 m" in ln and "0.0447 m" in ln for ln in errors), errors
    assert any("eps.pos_eps_m" in ln and "3 m" in ln and "0.003" in ln for ln in errors), errors
    assert not out.exists()


def test_mm_part_and_friction_beyond_any_material_warn_even_with_quiet(tmp_path):
    _write(tmp_path, MM_RECT, "rect_mm.yaml")
    text = STUDY.replace("part: rectangle", "part: rect_mm.yaml") \
        .replace("mu_f: [0.3, 0.8]", "mu_f: [5, 80]")
    code, out, err = call(run.main, _write(tmp_path, text), "--dry-run", "--quiet", "--out",
                          tmp_path / "out")
    assert code == 0, err
    warns = [ln for ln in err.splitlines() if ln.startswith("warning: ")]
    assert any("vertices" in ln and "44.7 m across" in ln and "millimetres" in ln
               for ln in warns), err
    assert any("friction.mu_f" in ln and "[5, 80]" in ln for ln in warns), err
    assert not (tmp_path / "out").exists()


def test_plan_push_refuses_a_goal_angle_in_degrees_without_deg(tmp_path):
    r = call(plan_push.main, "rectangle", "--start", "0,0,0", "--goal", "0.1,0.05,90")
    (line,) = _errors(r, n=1)
    assert "--goal" in line and "90deg" in line and "looks like degrees" in line, line


def test_plan_tumble_eps_and_tau_v_as_large_as_the_part_exit_2(tmp_path):
    r = call(plan_tumble.main, "cube", "--goal", "0.2,0,0,0", "--eps", "0.5", "--tau-v", "1e5")
    errors = _errors(r, n=2)
    assert any(ln.startswith("error: --eps:") and "0.173 m across" in ln for ln in errors), errors
    assert any(ln.startswith("error: --tau-v:") and "100000 m" in ln for ln in errors), errors


def test_plan_tumble_mm_part_warns_once_before_planning(tmp_path, monkeypatch):
    import sys

    import planning as planner   # the door the command uses

    original = planner.plan_tumble

    def marked(*args, **kw):
        sys.stderr.write("PLANNING\n")
        return original(*args, **kw)

    monkeypatch.setattr(planner, "plan_tumble", marked)
    p = _write(tmp_path, MM_CUBE, "cube_mm.yaml")
    code, out, err = call(plan_tumble.main, p, "--goal", "0,0,0,2", "--eps", "1", "--json")
    assert code == 0, err
    lines = err.splitlines()
    warns = [i for i, ln in enumerate(lines) if "m across" in ln]
    assert len(warns) == 1 and lines[warns[0]].startswith("warning: vertices:"), err
    assert "millimetres" in lines[warns[0]] and warns[0] < lines.index("PLANNING"), err


# ---------------------------------------------------------------- studies, in-process
def _design(tmp_path, text, overrides=()):
    return load_design(_write(tmp_path, text), overrides)


@pytest.mark.parametrize("edit,words", [
    (("tau_v: 2e-5", "tau_v: 1e5"), ["tolerances.tau_v", "100000 m", "0.0447 m across"]),
    (("tau_v: 2e-5", "tau_v: 0.5"), ["tolerances.tau_v", "0.5 m", "write 0.0005"]),
    (("tau_com: 1e-4", "tau_com: 0.05"), ["tolerances.tau_com", "0.05 m"]),
    (("pos_eps_m: 0.003", "pos_eps_m: 3"), ["eps.pos_eps_m", "3 m", "write 0.003"]),
    (("start_xy: 5e-4", "start_xy: 0.5"), ["execution.start_xy"]),
    (("theta_eps_rad: 0.05", "theta_eps_rad: 5"), ["eps.theta_eps_rad", "looks like degrees",
                                                   "0.0873 rad"]),
    (("start_theta: 0.01", "start_theta: 10"), ["execution.start_theta", "degrees"]),
    (("distance_rel: 0.005", "distance_rel: 5"), ["execution.distance_rel", "fraction"]),
    (("goal: [0.08, 0.03, 1.0]", "goal: [0.08, 0.03, 90]"), ["tasks[0].goal[2]", "90deg",
                                                            "looks like degrees"]),
    (("start: [0, 0, 0]", "start: [0, 0, -45]"), ["tasks[0].start[2]", "-45deg"]),
    (("model: exact", "model: exact\nplanner: {support_c: [2, 4]}"), ["planner.support_c", "[2, 4]"]),
    (("mu_f: [0.3, 0.8]", "mu_f: [0.3, 0.8], c: [0.01, 0.05]"), ["friction.c", "0.0447 m"]),
])
def test_study_values_that_cannot_be_meant_are_errors(tmp_path, edit, words):
    with pytest.raises(ConfigError) as info:
        _design(tmp_path, STUDY.replace(*edit))
    assert len(info.value.lines) == 1, info.value.lines
    line = info.value.lines[0]
    for w in words:
        assert w in line, line


def test_heading_ranges(tmp_path):
    sample = "  sample: {n: 200, annulus: [0.05, 0.15], heading: %s}\n"
    explicit = "  - {name: a, start: [0, 0, 0], goal: [0.08, 0.03, 1.0]}\n"
    for heading, words in (("[-4, 4]", ["tasks.sample.heading", "more than a full turn"]),
                           ("[0, 400deg]", ["tasks.sample.heading", "more than a full turn"]),
                           ("[-90, 90]", ["tasks.sample.heading", "[-90deg, 90deg]"])):
        with pytest.raises(ConfigError) as info:
            _design(tmp_path, STUDY.replace(explicit, sample % heading))
        for w in words:
            assert w in info.value.lines[0], info.value.lines
    # radians over a full turn are fine, and every goal is stored wrapped to (-pi, pi]
    d = _design(tmp_path, STUDY.replace(explicit, sample % "[0, 6.283185307179586]"))
    th = np.array([g[2] for _, _, g in d.tasks(0)])
    assert d.warnings == [] and np.all((th > -math.pi) & (th <= math.pi)) and np.any(th < 0)
    # a range inside (-pi, pi] is left bit for bit as sampled
    d = _design(tmp_path, STUDY.replace(explicit, sample % "[-180deg, 180deg]"))
    rng = np.random.default_rng([0, 0x7a5c])                # sweeps.study.sample_tasks' stream
    u = [rng.random() for _ in range(3 * 200)][2::3]         # radius, angle, heading per goal
    assert [g[2] for _, _, g in d.tasks(0)] == [-math.pi + x * 2 * math.pi for x in u]


def test_task_angles_are_stored_wrapped(tmp_path):
    d = _design(tmp_path, STUDY.replace("goal: [0.08, 0.03, 1.0]", "goal: [0.08, 0.03, 270deg]")
                .replace("start: [0, 0, 0]", "start: [0, 0, 4.0]"))
    (_, start, goal), = d.tasks(0)
    assert goal[2] == pytest.approx(-math.pi / 2) and start[2] == pytest.approx(4.0 - 2 * math.pi)
    row = plan_row(d.part(0), "a", start, goal, None, "x")
    assert -math.pi < row["goal_theta_rad"] <= math.pi and -math.pi < row["start_theta_rad"] <= math.pi
    assert plausible.wrap(math.pi) == math.pi and plausible.wrap(-math.pi) == math.pi
    for x in (-3.0, -1e-300, 0.0, 0.1, 1.0, 3.14159):
        assert plausible.wrap(x) == x          # inside (-pi, pi]: untouched, bit for bit


def test_swept_value_that_cannot_be_meant_names_its_configuration(tmp_path):
    with pytest.raises(ConfigError) as info:
        _design(tmp_path, STUDY + "params:\n  tolerances.tau_v: [1e-5, 0.5]\n")
    (line,) = info.value.lines
    assert "configuration 1" in line and "tolerances.tau_v" in line and "0.5 m" in line, line


@pytest.mark.parametrize("edit,words", [
    (("tau_v: 2e-5", "tau_v: 0.006"), ["tolerances.tau_v", "13%"]),
    (("pos_eps_m: 0.003", "pos_eps_m: 0.01"), ["eps.pos_eps_m", "22%"]),
    (("mu_f: [0.3, 0.8]", "mu_f: [5, 80]"), ["friction.mu_f", "[5, 80]", "3"]),
    (("mu_f: [0.3, 0.8]", "mu_f: [0.3, 0.8], mu_s: [0.2, 4]"), ["friction.mu_s"]),
    (("theta_eps_rad: 0.05", "theta_eps_rad: 1"), ["eps.theta_eps_rad", "57 deg"]),
    (("distance_rel: 0.005", "distance_rel: 0.5"), ["execution.distance_rel", "50%"]),
])
def test_large_but_possible_values_warn(tmp_path, edit, words):
    d = _design(tmp_path, STUDY.replace(*edit))
    assert len(d.warnings) == 1, d.warnings
    for w in words:
        assert w in d.warnings[0], d.warnings


def test_thresholds_at_their_edges(tmp_path):
    s = RECT
    assert plausible.length("f", 0.1 * s, s) == []
    (w,) = plausible.length("f", 0.11 * s, s)
    assert w.level == "warning"
    (e,) = plausible.length("f", s, s)
    assert e.level == "error"
    assert plausible.friction("f", (0.0, 3.0)) == []
    assert [f.level for f in plausible.friction("f", (0.0, 3.01))] == ["warning"]
    assert plausible.angle_tolerance("f", math.radians(20)) == []
    assert [f.level for f in plausible.angle_tolerance("f", 0.5)] == ["warning"]
    assert [f.level for f in plausible.angle_tolerance("f", math.pi)] == ["error"]
    assert plausible.pose_angle("f", 2 * math.pi) == [] and plausible.pose_angle("f", "720deg") == []
    assert [f.level for f in plausible.pose_angle("f", 6.3)] == ["error"]


# ---------------------------------------------------------------- sane inputs stay quiet
@pytest.mark.parametrize("name", sorted(catalog.bundled_studies()))
def test_bundled_studies_raise_no_warning(name):
    d = load_design(catalog.bundled_studies()[name])
    assert d.warnings == []


@pytest.mark.parametrize("name", sorted(catalog.bundled_certify_configs()))
def test_bundled_certify_configs_raise_no_warning(name, capfd):
    certify.load(catalog.bundled_certify_configs()[name])
    assert capfd.readouterr().err == ""


def test_bundled_parts_and_usual_command_lines_raise_no_warning():
    for name, path in catalog.bundled_parts().items():
        part = load_part(path)
        if part.kind == "polygon":
            got = plausible.cli_findings(part, poses={"--start": "0,0,0", "--goal": "0.1,0.05,90deg"},
                                         frictions={"--min-fence-mu": 0.8},
                                         limit_surface={"--support-c": (0.006, 0.012)})
        else:
            got = plausible.cli_findings(part, poses={"--start": None, "--goal": "0.2,0,1.57,3"},
                                         lengths={"--eps": 1e-3, "--tau-v": 1e-5})
        assert got == [], (name, got)


@pytest.mark.slow
def test_warnings_raised_while_a_study_runs_show_under_quiet(tmp_path):
    """A warning raised by the work itself (the planner replacing a non-convex
    part by its hull) reaches stderr under ``--quiet`` too (issue 21: quiet
    hid every warning)."""
    text = STUDY.replace("part: rectangle",
                         "part: {vertices: [[0, 0], [0.04, 0], [0.04, 0.03], [0.02, 0.01], [0, 0.03]]}")
    code, out, err = call(run.main, _write(tmp_path, text), "--quiet", "--out", tmp_path / "out")
    assert code == 0, err
    assert any(ln.startswith("warning: ") and "convex hull" in ln for ln in err.splitlines()), err
