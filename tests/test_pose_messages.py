"""The push planner's no-plan messages (issue 21): one line of at most 300
characters whatever the part (a 500-vertex polygon's message was 14,700
characters), naming each option to change as the user types it: the keyword,
the ``nudge plan-push`` flag and the study/certify config key."""
from __future__ import annotations

import math
import re

import numpy as np
import pytest

from planning.pushing import planner as pp
from tests.test_pose_planner import _plan

pytestmark = pytest.mark.float64

LIMIT = 300
MAX_REORIENTS = "max_reorients (--max-reorients, planner.max_reorients)"

# a sliver (3 mm x 10 cm) whose step angles are all under 5.3 degrees: 1.5 rad of
# turn needs 53 reorient pushes, beyond the default budget of 24
SLIVER = np.array([[0.09102, 0.00045], [0.07833, 0.00262], [0.00834, 0.00205], [0.03114, 0.00123],
                   [0.09941, 0.0019], [0.04769, 0.00266]])
SLIVER_TASK = ((0.0, 0.0, -0.6847704963990546), (-0.11114282156196073, 0.14411881361697534, -2.1275688123691))


def _message(pts, start, goal, **kw) -> str:
    with pytest.raises(pp.PlanningError) as err:
        _plan(pts, start, goal, **kw)
    msg = str(err.value)
    assert "\n" not in msg and len(msg) <= LIMIT, (len(msg), msg[:600])
    return msg


def test_budget_message_of_a_500_vertex_polygon():
    """500 stable edges, step angles of 0.18 deg: the message gives the largest
    step angle and the fewest reorient pushes any candidate needs, not every
    edge's step angles."""
    ang = np.linspace(0.0, 2 * math.pi, 500, endpoint=False)
    gon = 0.05 * np.c_[np.cos(ang), np.sin(ang)]
    msg = _message(gon, (0.0, 0.0, 0.0), (0.1, 0.05, 1.0))
    assert re.search(rf"max_reorients=24 .*raise {re.escape(MAX_REORIENTS)} to \d+ or more$", msg), msg


def test_budget_message_of_a_sliver_names_the_budget_that_plans():
    """The sliver needs 53 reorient pushes: the message says to raise
    max_reorients to 53, with 52 it says so again, and with 53 there is a plan."""
    start, goal = SLIVER_TASK
    for budget in (24, 52):
        msg = _message(SLIVER, start, goal, max_reorients=budget)
        assert msg.endswith(f"raise {MAX_REORIENTS} to 53 or more"), msg
        assert f"max_reorients={budget} " in msg
    assert _plan(SLIVER, start, goal, max_reorients=53).n_reorients == 53
    assert _message(SLIVER, start, goal, strategy="paper").endswith("to 53 or more")


def test_message_when_candidates_were_set_aside_for_the_budget():
    """Some candidates fit the budget but none spans the translation: the message
    counts those set aside, with the reorient pushes they need."""
    from tests.test_pose_planner import _fixed_parts

    pts, com = _fixed_parts()["uni"]
    msg = _message(pts, (0.0, 0.0, 0.0), (0.034, -0.0701, 0.3), com=com, max_reorients=2)
    assert re.search(rf"\d+ candidates needing \d+ to \d+ reorient pushes, over max_reorients=2, were not "
                     rf"tried: raise {re.escape(MAX_REORIENTS)}$", msg), msg


def test_replay_problems_are_listed_briefly(monkeypatch):
    """A replay that disagrees push after push lists three problems and a count."""
    real = pp.verify

    def bad(part, start, goal, directions, distances, edges):
        poses, err, _ = real(part, start, goal, directions, distances, edges)
        return poses, err, [f"push {i} ended on edge 7 instead of 3" for i in range(40)]

    monkeypatch.setattr(pp, "verify", bad)
    msg = _message([[0.0, 0.0], [0.03, 0.0], [0.005, 0.02]], (0.0, 0.0, 0.0), (0.1, 0.05, 1.0))
    assert msg.startswith("the exact replay of the plan does not reach the goal: push 0 ended") and \
        msg.endswith("push 2 ended on edge 7 instead of 3; and 37 more"), msg


def test_poses_are_left_out_rather_than_overflowing():
    """Slip-aware, the budget message says which pushes are allowed too; the
    poses are left out to keep it within the limit, the reason and advice kept."""
    start, goal = SLIVER_TASK
    msg = _message(SLIVER, start, goal, support={"c": [0.01, 0.03]}, min_fence_mu=1.0)
    assert msg.startswith("no pose plan for this biplus-stable part: every candidate needs more than "
                          "max_reorients=24"), msg
    assert "min_fence_mu=1 allowed" in msg and msg.endswith(f"raise {MAX_REORIENTS} to 53 or more")
