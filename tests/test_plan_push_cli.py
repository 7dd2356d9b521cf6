"""``nudge plan-push``'s planner options (issue 10): --strategy, --support-c,
--min-fence-mu, --workspace; their help, their errors (one line naming the
flag, exit status 2), a workspace that holds no plan (exit 1) and the PSD
figure marking the plan's reorient steps.

In process (``sweeps.plan_push.main``), as a user types the arguments; one
subprocess checks the installed console script's help."""
from __future__ import annotations

import json
import pathlib

import numpy as np
import pytest

from planning.pushing.plan import PushPlan
from sweeps import plan_push as push
from sweeps.figures.plan_steps import arrow_span
from tests.commandline import nudge

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"
RECT = str(EXAMPLES / "rectangle.yaml")
UNI = str(EXAMPLES / "unistable.yaml")
POSES = ["--start", "0,0,0", "--goal", "0.05,0.02,90deg"]
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _run(capsys, *argv):
    rc = push.main([str(a) for a in argv])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def _json_plan(capsys, *argv) -> PushPlan:
    rc, out, err = _run(capsys, *argv, "--json")
    assert rc == 0, err
    plan = PushPlan.from_dict(json.loads(out))
    assert max(plan.final_error) < 1e-9
    np.testing.assert_allclose(plan.pushes[-1].pose_after, plan.goal, atol=1e-9)
    return plan


def test_options_reach_the_planner_and_the_plan_records_them(capsys):
    plan = _json_plan(capsys, RECT, *POSES, "--strategy", "paper", "--support-c", "0.006", "0.012",
                      "--min-fence-mu", "0.8", "--workspace", "-0.1", "0.15", "-0.1", "0.12")
    o = plan.options
    assert o.strategy == "paper"
    assert plan.distance_rule == "quasi-static"
    assert plan.support_c == o.support.c == (0.006, 0.012)
    assert o.min_fence_mu == 0.8
    assert o.workspace == (-0.1, 0.15, -0.1, 0.12)
    # slip-aware: the rectangle's long edges slip at the landing for c >= 6 mm at mu 0.8
    # (kernels.reorient.sticking_angle_limit), so every reorient push lands a short edge
    short = {(1, 2), (3, 0)}
    assert plan.n_reorients > 0
    assert all(p.edge in short for p in plan.pushes if p.kind == "reorient")
    default = _json_plan(capsys, RECT, *POSES)
    assert (default.options.strategy, default.distance_rule, default.options.workspace) == ("search", "peshkin", None)


#: a value other than the default for each PushOptions field, as flags
OTHER_VALUES = {"margin_deg": ["--margin-deg", "9"], "safety_factor": ["--safety-factor", "1.3"],
                "objective": ["--objective", "pushes"], "solver": ["--solver", "cvxpy"],
                "strategy": ["--strategy", "paper"], "support": ["--support", "rigid"],
                "min_fence_mu": ["--support", "rigid", "--min-fence-mu", "0.5"],
                "workspace": ["--workspace", "-1", "1", "-1", "1"],
                "max_reorients": ["--max-reorients", "7"], "extra_steps": ["--extra-steps", "1"]}


def test_every_planner_option_is_a_flag_made_from_its_field():
    """The flags are generated from planning.PushOptions' fields (issue 39): each
    field's flag sets that field and no other (support: also --support-c), and
    a field added to PushOptions without a value here fails this test."""
    import dataclasses

    from planning import PushOptions

    fields = [f.name for f in dataclasses.fields(PushOptions)]
    assert sorted(OTHER_VALUES) == sorted(fields)
    parser = push.build_parser()
    base = ["rectangle", *POSES]
    default = push._push_options(parser.parse_args(base))
    assert default == PushOptions()
    for name, flags in OTHER_VALUES.items():
        got = push._push_options(parser.parse_args(base + flags))
        changed = {f for f in fields if getattr(got, f) != getattr(default, f)}
        assert name in changed and changed <= {name, "support"}, (name, changed)
    got = push._push_options(parser.parse_args(base + ["--support-c", "0.004", "0.006"]))
    assert got.support.c == (0.004, 0.006)
    # their text is the field's
    actions = {a.dest: a for a in parser._actions}
    for f in dataclasses.fields(PushOptions):
        assert actions[f.name].help.startswith(f.metadata["doc"]), f.name


def test_support_c_shortens_the_reorient_pushes(capsys):
    """The quasi-static rule's distance is at most Peshkin's (c_hi <= the part's radius)."""
    peshkin = _json_plan(capsys, UNI, *POSES)
    model = _json_plan(capsys, UNI, *POSES, "--support-c", "0.005", "0.01")
    assert model.distance_rule == "quasi-static"
    assert model.total_distance < peshkin.total_distance


@pytest.mark.parametrize("argv, needles", [
    (["--support-c", "0.02", "0.01"], ["--support-c", "lo <= hi"]),
    (["--support-c", "0", "0.01"], ["--support-c", "0 < lo"]),
    (["--min-fence-mu", "0.5"], ["--min-fence-mu", "--support-c"]),
    (["--min-fence-mu", "-1", "--support-c", "0.005", "0.01"], ["--min-fence-mu", ">= 0"]),
    (["--workspace", "0.1", "-0.1", "-0.1", "0.1"], ["--workspace", "xmin < xmax"]),
    (["--workspace", "-0.01", "0.01", "-0.01", "0.01"], ["--workspace", "start pose", "not inside"]),
])
def test_bad_option_values_exit_2_naming_the_flag(capsys, argv, needles):
    rc, out, err = _run(capsys, RECT, *POSES, *argv)
    assert rc == 2 and out == ""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    for n in needles:
        assert n in lines[0], lines[0]


@pytest.mark.parametrize("argv, flag", [
    (["--workspace", "1", "2", "3"], "--workspace"),
    (["--workspace", "a", "1", "0", "1"], "--workspace"),
    (["--support-c", "0.01", "nan"], "--support-c"),
    (["--support-c", "0.01"], "--support-c"),
    (["--min-fence-mu", "lots"], "--min-fence-mu"),
    (["--strategy", "greedy"], "--strategy"),
])
def test_malformed_options_exit_2_naming_the_flag(capsys, argv, flag):
    with pytest.raises(SystemExit) as exc:
        push.main([RECT, *POSES, *argv])
    err = capsys.readouterr().err
    assert exc.value.code == 2
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and flag in lines[0], err


def test_workspace_too_small_exits_1_with_the_smallest_found(capsys):
    """The uni-stable part's reorient pushes sweep far (Peshkin distances):
    no plan fits; the message names the workspace and the smallest one found."""
    rc, out, err = _run(capsys, UNI, "--start", "0,0,0", "--goal", "0.05,0.02,3.14159",
                        "--workspace", "-0.06", "0.1", "-0.05", "0.08")
    assert rc == 1 and out == ""
    assert "inside the workspace" in err and "smallest workspace found" in err


def test_psd_marks_the_plans_steps(capsys, tmp_path):
    plain, marked = tmp_path / "plain.png", tmp_path / "marked.png"
    assert _run(capsys, UNI, "--psd", plain)[0] == 0
    rc, out, err = _run(capsys, UNI, "--start", "0,0,0", "--goal", "0.05,0.02,3.14159", "--psd", marked)
    assert rc == 0, err
    assert marked.read_bytes()[:8] == PNG_MAGIC
    assert marked.read_bytes() != plain.read_bytes()


@pytest.mark.parametrize("end, rot, want", [
    (0.0, -40.0, (40.0, 0.0)),         # CW step onto the edge at 0 deg: from 40 down to 0
    (0.0, 25.0, (335.0, 360.0)),       # CCW step onto it: from 335 up to 360 (the same orientation)
    (300.0, 20.0, (280.0, 300.0)),
    (10.0, 30.0, (-20.0, 10.0)),       # crosses 0: drawn in two pieces, the head at 10
    (359.9999999, -5.0, (4.9999999, 0.0)),
])
def test_arrow_span(end, rot, want):
    np.testing.assert_allclose(arrow_span(end, rot), want, atol=1e-6)


def test_help_explains_the_options_and_units():
    r = nudge("plan-push", "--help")
    assert r.returncode == 0
    text = " ".join(r.stdout.split())
    for needle in ("--strategy {search,paper}", "--support-c LO HI", "--min-fence-mu MU",
                   "--workspace XMIN XMAX YMIN YMAX", "limit-surface ratio", "in metres",
                   "needs a support other than any", "Exit status: 0 ok, 1 no plan, 2 bad input"):
        assert needle in text, needle
