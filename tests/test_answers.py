"""Answers an engineer can act on (issue 42): what the commands say about
mistakes that earlier passed, each through the command a user types."""
import dataclasses
import re
from importlib import metadata

import numpy as np
import pytest

from tests.commandline import ROOT, nudge, nudge_here

STUDY = ROOT / "examples" / "studies" / "margins.yaml"


@pytest.mark.parametrize("override, field", [
    ("samples=true", "samples"),                               # read as 1 sample before
    ("chunk_samples=false", "chunk_samples"),
    ("seed=true", "seed"),
    ("planner.margin_deg=true", "planner.margin_deg"),
    ("execution.fence_angle=true", "execution.fence_angle"),   # a robustness dataclass
    ("friction.mu_f=[true,0.8]", "friction.mu_f"),             # inside a range
])
def test_true_or_false_is_never_a_number(override, field):
    """pydantic's lax mode read ``--set samples=true`` as one sample and ran it."""
    r = nudge_here("sweep", STUDY, "--dry-run", "--set", override)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1, r.stderr
    assert re.search(rf"{re.escape(field)}: expected (a number|an integer), not true/false",
                     lines[0]), lines[0]


def test_true_stays_a_switch_where_a_switch_is_meant():
    r = nudge_here("sweep", STUDY, "--dry-run", "--set", "report=false", "--set", "bounds=true")
    assert r.returncode == 0, r.stderr


def test_a_planner_support_the_planner_cannot_take_is_not_offered_back():
    """``planner.support: tripod`` was refused by a line that listed tripod as a choice."""
    r = nudge_here("sweep", STUDY, "--dry-run", "--set", "planner.support=tripod")
    line = r.stderr.strip()
    assert r.returncode == 2 and "\n" not in line, r.stderr
    offered = line.split("give one of", 1)[1].split("(", 1)[0]
    assert "tripod" not in offered and "points" not in offered, line
    assert "friction.support" in line     # where tripod does belong


def test_version():
    r = nudge("--version")
    assert r.returncode == 0 and r.stderr == "", r.stderr
    assert r.stdout.startswith(f"nudge {metadata.version('nudge')} (python ")
    assert "jax " in r.stdout and "mujoco " in r.stdout


def test_plan_text_numbers_pushes_as_its_figure_does(tmp_path):
    """The text numbered pushes 0..6 while the figure's legend said push 1..7 (pose i
    after push i): both now count from 1."""
    fig = tmp_path / "plan.png"
    r = nudge_here("plan-push", "nice_stable", "--start", "0,0,0", "--goal", "0.05,0.02,1.0",
                   "--plot", fig)
    assert r.returncode == 0, r.stderr
    rows = [ln.split() for ln in r.stdout.splitlines()
            if re.match(r"^\s*\d+ (translate|reorient)\b", ln)]
    assert [int(row[0]) for row in rows] == list(range(1, len(rows) + 1)) and len(rows) >= 2
    assert fig.exists()


@pytest.mark.slow
def test_a_plan_that_does_not_certify_gets_next_steps(tmp_path):
    """A not-certified line never suggested --synthesize, more fence friction or a
    measured support; one that needs only more samples says how many."""
    cfg = ROOT / "examples" / "certify_triangle.yaml"
    r = nudge_here("certify", cfg, "--n-samples", "40", "--out", tmp_path / "a")
    assert r.returncode == 1, r.stderr
    lines = r.stdout.splitlines()
    turn = next(i for i, ln in enumerate(lines) if ln.startswith("turn "))
    assert "slip" in lines[turn] and "below_requirement" in lines[turn]
    step = next(ln.strip() for ln in lines[turn + 1:] if ln.strip().startswith("next:"))
    assert step.startswith("next: more samples cannot certify this plan; try")
    for hint in ("friction.mu_f", "planner.min_fence_mu", "--synthesize", "friction.support",
                 "--design"):
        assert hint in step, (hint, step)
    translate = next(i for i, ln in enumerate(lines) if ln.startswith("translate "))
    assert "certified" in lines[translate] and not lines[translate + 2].strip().startswith("next:")

    r = nudge_here("certify", cfg, "--n-samples", "10", "--out", tmp_path / "b")
    lines = r.stdout.splitlines()
    translate = next(i for i, ln in enumerate(lines) if ln.startswith("translate "))
    assert "too_few_samples" in lines[translate]
    need = re.search(r"at least (\d+) successes", lines[translate + 1]).group(1)
    assert lines[translate + 2].strip().startswith(f"next: more samples: --n-samples {need} ")


def test_next_steps_leave_out_what_the_run_already_did():
    from sweeps.certify import next_steps

    cert = dict(verdict="not certified", reason="failures", kind="push",
                dominant_failure_mode="position")
    both = next_steps(cert, support="rigid", synthesized=True, designed=True)
    assert "--synthesize" not in both and "--design" not in both and "friction.support" not in both
    assert both.startswith("next: to certify it, try tighter execution errors")
    assert next_steps(dict(cert, verdict="certified")) == ""
    assert "--synthesize" not in next_steps(dict(cert, kind="tumble"))


def _frames(lows, planned=((True, True), (True, True))):
    """A two-configuration, two-task summary and plans table."""
    import pandas as pd

    summ, plans = [], []
    for cid, (cfg_lows, cfg_planned) in enumerate(zip(lows, planned)):
        for t, (low, ok) in enumerate(zip(cfg_lows, cfg_planned)):
            plans.append(dict(config_id=cid, task=f"t{t}", planned=ok, n_steps=7))
            if ok:
                summ.append(dict(config_id=cid, task=f"t{t}", n=100, n_success=int(100 * low),
                                 ci_low_one_sided=low, dominant_failure_mode="slip"))
    return pd.DataFrame(summ), pd.DataFrame(plans)


def _design():
    from types import SimpleNamespace as NS

    return NS(top=NS(required=NS(probability=0.9, confidence=0.95)), paths=["friction.mu_f"],
              points=[{"friction.mu_f": 0.5}, {"friction.mu_f": 1.5}], configs=[0, 1])


def test_the_recommendation_names_the_configuration_to_use_or_says_none_meets():
    """The study report never said which configuration to use, or that none meets
    the requirement."""
    from sweeps.report import recommendation

    rec = recommendation(*_frames([(0.5, 0.95), (0.93, 0.91)]), _design())
    assert rec.startswith("use configuration 1 (friction.mu_f=1.5): worst task's lower bound 0.910")
    assert "1 of 2 configuration(s) meet P(success) >= 0.9 at 95% confidence on every task" in rec
    rec = recommendation(*_frames([(0.5, 0.85), (0.8, 0.6)]), _design())
    assert rec.startswith("no configuration meets P(success) >= 0.9") and "dominant failure slip" in rec
    assert "the best is configuration 1 (friction.mu_f=1.5): worst task's lower bound 0.600" in rec
    # a configuration that plans every task beats one with a higher bound on fewer tasks
    rec = recommendation(*_frames([(0.6, 0.6), (0.99, 0.0)], ((True, True), (True, False))),
                         _design())
    assert "the best is configuration 0" in rec


@pytest.mark.parametrize("content, words", [
    (b"\x89PNG\r\n\x1a\n" + bytes(200), "is a PNG image, not an STL mesh"),
    ((ROOT / "examples" / "bracket.stl").read_bytes()[:300],
     "is not a whole binary STL: its header promises 824 triangles (41284 bytes), the file has "
     "300 bytes"),
    (b"\x00" * 40, "fewer than a binary STL's 84-byte header"),
])
def test_a_file_that_is_no_stl_says_what_it_is(tmp_path, content, words):
    """A PNG renamed .stl or a truncated STL said "No module named
    'charset_normalizer'" (the mesh library's guess at an ASCII file)."""
    p = tmp_path / "part.stl"
    p.write_bytes(content)
    r = nudge_here("plan-push", p, "--units", "mm", "--start", "0,0,0", "--goal", "0.05,0,0")
    line = r.stderr.strip()
    assert r.returncode == 2 and "\n" not in line and words in line, r.stderr
    assert line.startswith(f"error: {p}: footprint: part.stl ")


@pytest.mark.parametrize("reply, words", [
    (None, "no Dask handshake in 2 s"),                       # an HTTP server: waits for a request
    (b"\xff" * 64 + b"garbage" * 100, "its reply is no Dask message"),
])
def test_an_address_that_answers_but_is_no_scheduler_is_one_line(tmp_path, monkeypatch, reply,
                                                                 words):
    """It was a MemoryError of 3.07 EiB (exit 3), or a hang of minutes (an HTTP server)."""
    import socket
    import threading

    from sweeps import executors

    monkeypatch.setattr(executors, "CONNECT_TIMEOUT_S", 2.0)
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    port = srv.getsockname()[1]
    held = []

    def serve():
        while True:
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            held.append(conn)
            if reply:
                conn.sendall(reply)

    threading.Thread(target=serve, daemon=True).start()
    try:
        r = nudge_here("sweep", STUDY, "--out", tmp_path / "out", "--set",
                       f"executor={{kind: dask, address: 'tcp://127.0.0.1:{port}'}}")
    finally:
        srv.close()
        for c in held:
            c.close()
    line = r.stderr.strip().splitlines()[-1]
    assert r.returncode == 2, r.stderr
    assert line.startswith(f"error: executor.address: something answers at tcp://127.0.0.1:{port} "
                           "but it is not a Dask scheduler (") and words in line, line


def test_config_lengths_on_a_part_in_millimetres_are_caught_before_work(tmp_path):
    """``goal: [120, 30, 0]`` on a part file in mm was a 120 m goal, planned
    silently (14 pushes, 0/100 succeed): one line naming the field and the fix."""
    study = tmp_path / "mm.yaml"
    study.write_text(f"study: mm\nkind: push\npart: {ROOT / 'examples' / 'plate.yaml'}\n"
                     "tasks:\n  - {name: a, start: [0, 0, 0], goal: [120, 30, 0]}\n"
                     "model: exact\nsamples: 10\n")
    r = nudge_here("sweep", study, "--dry-run")
    line = r.stderr.strip()
    assert r.returncode == 2 and "\n" not in line, r.stderr
    assert "tasks[0].goal: the part travels 124 m" in line
    assert "even when the part file is in mm: if you meant mm, write 0.12, 0.03" in line
    r = nudge_here("plan-push", ROOT / "examples" / "plate.yaml", "--start", "0,0,0",
                   "--goal", "120,30,0")
    assert r.returncode == 2 and "--goal: the part travels 124 m" in r.stderr
    # a long but possible travel is a warning, and the run goes on
    r = nudge_here("plan-push", ROOT / "examples" / "plate.yaml", "--start", "0,0,0",
                   "--goal", "12,3,0")
    assert "warning: --goal: the part travels 12.4 m" in r.stderr


@pytest.mark.parametrize("part, flags, words", [
    ("plate.dxf", ("--units", "m"), "--units: plate.dxf read in m is a part 102 m across"),
    ("bracket.stl", ("--units", "m"), "--units: bracket.stl read in m is a part 72.1 m across"),
    ("bracket.stl", ("--units", "um"), "--units: bracket.stl read in um is a part 7.21e-05 m"),
])
def test_a_stated_unit_that_makes_the_part_implausible_names_the_unit_that_fits(part, flags,
                                                                                 words):
    """``--units m`` on a mesh or DXF in millimetres got the kernels' "divide them
    by 1000" and planned with exit 0: the fix is ``--units mm``."""
    r = nudge_here("plan-push", ROOT / "examples" / part, *flags, "--start", "0,0,0",
                   "--goal", "0.05,0,0")
    errors = [ln for ln in r.stderr.splitlines() if ln.startswith("error: ")]
    assert r.returncode == 2 and len(errors) == 1, r.stderr
    assert errors[0].startswith(f"error: {words}"), errors[0]
    assert errors[0].endswith("its numbers look like mm: give --units mm"), errors[0]
    assert "divide them by 1000" not in r.stderr and "translate" not in r.stdout


def test_a_part_files_units_that_make_the_part_implausible_is_refused_before_work(tmp_path):
    part = tmp_path / "bracket_m.yaml"
    part.write_text(f"name: b\nmesh: {ROOT / 'examples' / 'bracket.stl'}\nunits: m\n")
    study = tmp_path / "s.yaml"
    study.write_text(f"study: s\nkind: tumble\npart: {part}\n"
                     "tasks:\n  - {name: a, start: [0, 0, 0, 0], goal: [0, 0, 0, 2]}\n"
                     "samples: 4\n")
    r = nudge_here("sweep", study, "--dry-run")
    line = r.stderr.strip()
    assert r.returncode == 2 and "\n" not in line, r.stderr
    assert line.startswith(f"error: {study}: units: bracket.stl read in m (the part file) is a "
                           "part 85 m across"), line
    assert line.endswith("its numbers look like mm: write units: mm in bracket_m.yaml"), line


def _box_obj(nan_at=None):
    """A 50 x 40 x 10 (mm) box as OBJ text; vertex ``nan_at`` (from 1) gets a NaN x."""
    v = [(x, y, z) for x in (0, 50) for y in (0, 40) for z in (0, 10)]
    quads = [(1, 2, 4, 3), (5, 7, 8, 6), (1, 5, 6, 2), (3, 4, 8, 7), (1, 3, 7, 5), (2, 6, 8, 4)]
    rows = [f"v {'nan' if i == nan_at else x} {y} {z}" for i, (x, y, z) in enumerate(v, 1)]
    rows += [f"f {a} {b} {c}\nf {a} {c} {d}" for a, b, c, d in quads]
    return "\n".join(rows) + "\n"


def _dxf(path, points):
    import ezdxf

    doc = ezdxf.new("R2010")
    doc.units = ezdxf.units.MM
    doc.modelspace().add_lwpolyline(points, close=True)
    doc.saveas(path)


@pytest.mark.parametrize("name, make, words", [
    ("tri.obj", lambda p: p.write_text("v 0 0 0\nv 50 0 0\nv 0 40 0\nf 1 2 3\n"),
     "tri.obj holds 1 triangle on 3 vertices: a solid needs a closed surface of at least 4 "
     "triangles"),                                                        # "holds no triangles"
    ("nan.obj", lambda p: p.write_text(_box_obj(nan_at=4)),
     "nan.obj: vertex 4 is not a finite number (nan, 40, 10)"),         # planned, "open edges"
    ("bowtie.dxf", lambda p: _dxf(p, [(0, 0), (60, 30), (60, 0), (0, 30)]),
     "bowtie.dxf: the loop LWPOLYLINE #2F (layer 0) crosses itself at (30, 15) mm"),  # no loop
    ("cross.dxf", lambda p: _dxf(p, [(0, 0), (60, 40), (60, 0), (0, 20)]),
     "cross.dxf: the loop LWPOLYLINE #2F (layer 0) crosses itself at (20, 13.33) mm"),  # com
])
def test_cad_messages_name_the_files_own_fault(tmp_path, name, make, words):
    """A one-triangle mesh "held no triangles", a self-intersecting DXF outline
    "had no closed loop" (or a centre of mass outside it), and an OBJ with a NaN
    vertex was planned with an "open edges" warning."""
    p = tmp_path / name
    make(p)
    if name.endswith(".dxf"):
        r = nudge_here("plan-push", p, "--start", "0,0,0", "--goal", "0.05,0,0")
    else:
        r = nudge_here("plan-tumble", p, "--units", "mm", "--goal", "0.1,0,0,1", "--eps", "0.002")
    errors = [ln for ln in r.stderr.splitlines() if ln.startswith("error: ")]
    assert r.returncode == 2 and len(errors) == 1 and "warning" not in r.stderr, r.stderr
    assert words in errors[0], errors[0]
    assert r.stdout == "" or "tumble plan" not in r.stdout


def test_a_mesh_whose_hull_is_too_fine_is_refused_in_seconds(tmp_path):
    """A 200k-triangle sphere hung over 240 s in kernels/facets.py with no word:
    a hull of more than 2,000 vertices is refused right after the hull (a 4,418-
    vertex sphere here; the hull's faces took 3 s and the planner minutes)."""
    import trimesh

    p = tmp_path / "ball.stl"
    trimesh.creation.uv_sphere(radius=25.0, count=[48, 48]).export(p)
    r = nudge("plan-tumble", p, "--units", "mm", "--goal", "0.1,0,0,1", "--eps", "0.002",
              timeout=60)
    line = r.stderr.strip()
    assert r.returncode == 2 and "\n" not in line, r.stderr
    assert ("ball.stl: its convex hull has 4,418 vertices (8,832 triangles in the mesh: a curved "
            "surface finely tessellated); nudge takes hulls of at most 2,000 vertices - decimate "
            "the mesh") in line, line


TURN = f"""part: {ROOT / 'examples' / 'biplus_stable.yaml'}
tolerances: {{tau_v: 2.0e-5, tau_com: 1.0e-4}}
friction: {{mu_f: [0.3, 0.8], support: any}}
execution: {{start_xy: 5.0e-4, start_theta: 0.01, fence_angle: 0.002, distance_abs: 1.0e-4,
             distance_rel: 0.005}}
planner: {{margin_deg: 7, safety_factor: 1.15}}
eps: {{pos_eps_m: 0.003, theta_eps_rad: 0.05}}
n_samples: 40
model: quasistatic
design: {{n_samples: DRAWS}}
tasks:
  - {{name: turn, start: [0, 0, 0], goal: [0.10, 0.05, 60deg]}}
"""


def test_a_design_on_too_few_draws_is_refused_before_work(tmp_path):
    """40 design draws can never show P >= 0.9 at the design's 99.5%: the design
    ended in "+-0 mm ... NOT certified", or, verified at 95% on fresh draws, in a
    green "certified" box of zeros."""
    cfg = tmp_path / "turn.yaml"
    cfg.write_text(TURN.replace("DRAWS", "40"))
    r = nudge_here("certify", cfg, "--design", "--synthesize", "--out", tmp_path / "out")
    line = r.stderr.strip()
    assert r.returncode == 2 and "\n" not in line, r.stderr
    assert line == (f"error: {cfg}: design.n_samples: 40 design draws cannot show P(success) >= "
                    "0.9 at the design's 99.5% confidence (a tenth of the stated error rate: "
                    "headroom for its verification on fresh draws) even with no failure; give at "
                    "least 51 (default 1000)")
    assert not (tmp_path / "out").exists()


def test_the_drawing_line_never_states_a_design_of_zeros():
    from robustness import tolerance_design as td

    designs = [td.AxisDesign("tau_v", ("tolerances.tau_v",), (2e-5,), (0.0,), 0.0, False, 0.0,
                             "none_certifies", 3)]
    joint = td.JointDesign(0.0, {"tau_v": (0.0,)}, 0.1, 0, 0, 0.0, False, "perfect",
                           none_certifies=True, failure_rate_perfect=0.7)
    line = td.drawing_line(designs, joint, 0.9, 0.95, "quasistatic")
    assert line.startswith("no tolerance certifies this plan: with every tolerance perfect, 70% "
                           "of the design draws still fail (quasistatic model), more than the 10%")
    assert "+-0 mm" not in line and "certified P" not in line
    joint = dataclasses.replace(joint, failure_rate_perfect=0.02)
    assert td.drawing_line(designs, joint, 0.9, 0.95, "quasistatic").startswith(
        "no design certifies on these design draws: with every tolerance perfect, 2.0% of them fail")


@pytest.mark.slow
def test_a_design_no_tolerance_certifies_says_so_and_what_would(tmp_path):
    """With every tolerance perfect 75% of the draws fail (the unknown support):
    the design said "vertices within +-0 mm, centre of mass within 0 mm, ...: NOT
    certified", with no way out."""
    import pandas as pd

    cfg = tmp_path / "turn.yaml"
    cfg.write_text(TURN.replace("DRAWS", "60"))
    r = nudge_here("certify", cfg, "--design", "--out", tmp_path / "out")
    assert r.returncode == 1, r.stderr
    line = next(ln for ln in r.stderr.splitlines() if ln.startswith("[turn] tolerance design: "))
    assert line.startswith("[turn] tolerance design: no tolerance certifies this plan: with every "
                           "tolerance perfect, "), line
    assert "of the design draws still fail (quasistatic model), more than the 10%" in line
    for way in ("what would: a measured support (friction.support:", "more fence friction",
                "--synthesize"):
        assert way in line, (way, line)
    assert "+-0 mm" not in r.stdout + r.stderr
    html = (tmp_path / "out" / "report.html").read_text()
    assert '<p class="drawing no">no tolerance certifies this plan' in html
    assert "No joint design is stated" in html
    design = pd.read_parquet(tmp_path / "out" / "design")
    assert not design.joint_certified.any() and (design.joint_n_fresh == 0).all()
    assert design.joint_ci_low_fresh.isna().all() and all(np.isnan(v).all() for v in design.joint)


def test_an_auto_sample_cap_that_cannot_certify_is_refused_before_work(tmp_path):
    """``--n-samples auto --max-samples 5`` ran 5 samples, then said more were needed."""
    cfg = ROOT / "examples" / "certify_triangle.yaml"
    r = nudge_here("certify", cfg, "--n-samples", "auto", "--max-samples", "5",
                   "--out", tmp_path / "a")
    line = r.stderr.strip()
    assert r.returncode == 2 and "\n" not in line, r.stderr
    assert line == (f"error: {cfg}: --max-samples: 5 samples cannot certify P(success) >= 0.9 at "
                    "95% confidence even if every one succeeds: with p and confidence as given, "
                    "at least 29 samples are needed; raise --max-samples to 29 or more "
                    "(--n-samples auto)")
    assert not (tmp_path / "a").exists()
    # in the config file, with a stricter requirement
    own = tmp_path / "c.yaml"
    own.write_text(cfg.read_text().replace("part: biplus_stable.yaml",
                                           f"part: {ROOT / 'examples' / 'biplus_stable.yaml'}")
                   .replace("n_samples: 300", "n_samples: auto\nmax_samples: 100")
                   .replace("probability: 0.9", "probability: 0.99"))
    r = nudge_here("certify", own, "--out", tmp_path / "b")
    assert r.returncode == 2 and ("max_samples: 100 samples cannot certify P(success) >= 0.99 at "
                                  "95% confidence") in r.stderr and "at least 299 samples" in r.stderr


@pytest.mark.parametrize("command", ["certify", "sweep", "plan-push", "plan-tumble"])
def test_help_imports_nothing_heavy(command):
    """``nudge certify --help`` took 2.9 s (6.8 s in the issue): it imported JAX,
    MuJoCo and pandas to print its options; now 0.1 s."""
    import subprocess
    import sys

    code = ("import contextlib, io, sys\nfrom sweeps import cli\n"
            "with contextlib.redirect_stdout(io.StringIO()) as out:\n"
            f"    try:\n        cli.main([{command!r}, '--help'])\n"
            "    except SystemExit:\n        pass\n"
            "assert 'usage: nudge' in out.getvalue(), out.getvalue()\n"
            "print(' '.join(m for m in ('jax', 'mujoco', 'cvxpy', 'pandas', 'pyarrow', 'scipy')"
            " if m in sys.modules))\n")
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "", f"nudge {command} --help imports {r.stdout.strip()}"
