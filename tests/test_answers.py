"""Answers an engineer can act on (issue 42): what the commands say about
mistakes that earlier passed, each through the command a user types."""
import re
from importlib import metadata

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
