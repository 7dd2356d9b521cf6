"""One error type for bad input and one exit-status table at the edge."""
import os

import pytest

from sweeps.config import ConfigError
from sweeps.errors import Exit, UserError
from sweeps.partfile import PartFileError
from sweeps.store import RunError
from sweeps.tasks import PlanInputError
from sweeps.terminal import InputError, run_main
from sweeps.yamlio import YamlError


def test_every_bad_input_is_a_user_error():
    for cls in (ConfigError, PartFileError, RunError, PlanInputError, InputError, YamlError):
        assert issubclass(cls, UserError) and issubclass(cls, ValueError), cls


def test_exit_table():
    assert [int(e) for e in Exit] == [0, 1, 2, 3, 4, 130]


def test_running_out_of_memory_is_exit_4_in_one_line(capsys, monkeypatch):
    """Python's MemoryError (and XLA's RESOURCE_EXHAUSTED) is the machine's limit,
    not a bug: exit 4, one line saying the finished chunks are kept."""
    monkeypatch.delenv("NUDGE_DEBUG", raising=False)

    def big():
        raise MemoryError("Unable to allocate 3.07 EiB")

    code, err = _run(big, capsys)
    assert code == 4 and err.count("\n") == 1 and err.startswith("error: out of memory")
    assert "run the same command again to resume" in err


def test_a_command_gives_jax_a_cpu_device_per_core(capsys, monkeypatch):
    """Before the command runs (and imports JAX), ``$JAX_NUM_CPU_DEVICES``
    defaults to ``$NUDGE_THREADS`` or the cores: a batch's compiled replays
    spread over them (robustness.replay.replay_devices); a value set is kept."""
    seen = []

    def record():
        seen.append(os.environ["JAX_NUM_CPU_DEVICES"])
        return 0

    monkeypatch.setenv("JAX_NUM_CPU_DEVICES", "-")   # restored after the test, whatever it was
    for threads, preset, want in (("3", None, "3"), (None, None, str(len(os.sched_getaffinity(0)))),
                                  ("3", "1", "1")):
        monkeypatch.delenv("JAX_NUM_CPU_DEVICES")
        monkeypatch.delenv("NUDGE_THREADS", raising=False)
        if threads:
            monkeypatch.setenv("NUDGE_THREADS", threads)
        if preset:
            monkeypatch.setenv("JAX_NUM_CPU_DEVICES", preset)
        code, _ = _run(record, capsys)
        assert code == 0 and seen[-1] == want


def _run(fn, capsys):
    with pytest.raises(SystemExit) as info:
        run_main(fn)
    return info.value.code, capsys.readouterr().err


def test_a_user_error_that_reaches_the_guard_is_exit_2_in_one_line(capsys, monkeypatch):
    monkeypatch.delenv("NUDGE_DEBUG", raising=False)

    def bad():
        raise ConfigError("samples: must be >= 1,\n   got 0")

    code, err = _run(bad, capsys)
    assert code == 2 and err == "error: samples: must be >= 1, got 0\n"


def test_a_bug_is_exit_3_and_ctrl_c_130(capsys, monkeypatch):
    monkeypatch.delenv("NUDGE_DEBUG", raising=False)

    def bug():
        raise ValueError("not bad input: a bug")

    code, err = _run(bug, capsys)
    assert code == 3 and err.startswith("error: internal error (ValueError: not bad input")

    def interrupted():
        raise KeyboardInterrupt

    assert _run(interrupted, capsys)[0] == 130
    assert _run(lambda: Exit.NEGATIVE, capsys)[0] == 1


def test_push_defaults_have_one_home():
    """The planner's defaults live in planning.PushOptions; the study schema and
    nudge plan-push's flags give the same values."""
    from planning import PushOptions
    from sweeps.config import Planner
    from sweeps.plan_push import build_parser

    d = PushOptions()
    p = Planner()
    for f in ("margin_deg", "safety_factor", "objective", "strategy", "max_reorients", "extra_steps",
              "min_fence_mu", "workspace"):
        assert getattr(p, f) == getattr(d, f), f
    args = build_parser().parse_args(["rectangle", "--start", "0,0,0", "--goal", "0.1,0,0"])
    for f in ("margin_deg", "safety_factor", "objective", "solver", "strategy", "max_reorients",
              "extra_steps", "min_fence_mu", "workspace"):
        assert getattr(args, f) == getattr(d, f), f
    # and the values they build are the defaults whole
    from sweeps.plan_push import _push_options

    assert p.push_options() == d == _push_options(args)


@pytest.mark.parametrize("setting, says", [
    ("planner.margin_deg=0", "planner.margin_deg: must be > 0, got 0; at zero a reorient"),
    ("planner.margin_deg=95", "planner.margin_deg: must be < 90, got 95; it is taken off"),
    ("planner.safety_factor=0.5", "planner.safety_factor: must be >= 1, got 0.5; below 1 the"),
    ("planner.workspace=[0.1,-0.1,0,1]", "planner.workspace: expected [xmin, xmax, ymin, ymax] "
                                          "(m) with xmin < xmax"),
])
def test_the_planners_bounds_have_one_home_and_say_why(setting, says):
    """A study's planner bounds are PushOptions' own (the config does not declare
    them again): `sweeps.run --dry-run` names the field and gives the reason of
    the bound it breaks, once."""
    from sweeps import run
    from tests.commandline import in_process

    r = in_process(run.main, "margins.yaml", "--dry-run", "--set", setting)
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert says in r.stderr and "; give" not in r.stderr, r.stderr
    from sweeps.config import Planner

    for f in ("margin_deg", "safety_factor", "min_fence_mu"):
        assert not Planner.model_fields[f].metadata, f      # no second set of bounds


def test_plan_pose_takes_one_options_value_that_travels():
    """The planner's options are one value: plan_pose takes it, the plan carries
    it (plan.options plans the same plan again), anything else is refused."""
    import numpy as np
    import pytest

    from planning import PushOptions, plan_pose

    rect = np.array([[0, 0], [0.04, 0], [0.04, 0.02], [0, 0.02]], float)
    options = PushOptions(margin_deg=9.0, strategy="paper", support="rigid", min_fence_mu=0.8)
    a = plan_pose(rect, (0, 0, 0), (0.05, 0.02, 1.0), options=options)
    assert a.options == options and a.options.margin_deg == 9.0 and a.options.support.family == "rigid"
    assert plan_pose(rect, (0, 0, 0), (0.05, 0.02, 1.0), None, a.options).to_dict() == a.to_dict()
    c = plan_pose(rect, (0, 0, 0), (0.05, 0.02, 1.0),
                  options=PushOptions(support={"c": [0.01, 0.02]}))
    assert c.options.support.c == (0.01, 0.02) and c.options == PushOptions(support=(0.01, 0.02))
    with pytest.raises(ValueError, match="^options: expected a planning.PushOptions, got dict"):
        plan_pose(rect, (0, 0, 0), (0.05, 0.02, 1.0), options={"margin_deg": 9.0})


def test_within_prefixes_every_line_and_keeps_the_type():
    err = ConfigError("a: bad", ["a: bad", "b: worse"]).within("study.yaml")
    assert type(err) is ConfigError and str(err) == "study.yaml: a: bad"
    assert err.lines == ["study.yaml: a: bad", "study.yaml: b: worse"]
    assert YamlError("x").within("p").lines == ["p: x"] and type(YamlError("x").within("p")) is YamlError


@pytest.mark.slow
@pytest.mark.parametrize("command", ["sweep", "certify"])
def test_a_yaml_syntax_error_in_a_config_is_one_line_exit_2(tmp_path, command):
    """The file's YamlError reaches the user as it is (no translation into another error type)."""
    from tests.commandline import nudge

    p = tmp_path / "broken.yaml"
    p.write_text("kind: push\nsamples: [1, 2\n")
    r = nudge(command, p, "--out", tmp_path / "out")
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1, r.stderr
    assert lines[0].startswith("error: ") and "YAML syntax error" in lines[0] and str(p) in lines[0]
    assert not (tmp_path / "out").exists()


def test_a_bad_thread_count_is_refused_before_any_work(capsys, monkeypatch):
    """``$NUDGE_THREADS`` that is no whole number >= 1: exit 2, one line naming it,
    before the command runs (here and through the console script)."""
    from tests.commandline import nudge

    ran = []
    monkeypatch.setenv("NUDGE_THREADS", "two")
    code, err = _run(lambda: ran.append(1) or 0, capsys)
    assert code == 2 and not ran
    assert err == "error: NUDGE_THREADS: expected a whole number >= 1, got 'two'; unset it to " \
                  "use every core\n"
    r = nudge("sweep", "margins.yaml", "--dry-run", env={"NUDGE_THREADS": "0"})
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "NUDGE_THREADS" in r.stderr
