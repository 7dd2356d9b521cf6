"""The chosen plan confirmed in physics (robustness.confirmation): when physics
and the model are said to agree, and what the certificate's note says."""
import math

import pytest

from robustness import NO_PHYSICS, PhysicsCheck, stats


def test_physics_and_model_disagree_only_when_their_intervals_do_not_overlap():
    # the model: 299/300; physics: 17/24 -> [0.49, 0.87] at 95%, far below the model's
    low = PhysicsCheck(24, 17, "limit_surface", 300, 299, 0.95)
    assert not low.agrees
    s = low.sentence()
    assert "DISAGREE" in s and "more success" in s and "17/24" in s and "299/300" in s
    # 23/24 -> [0.79, 1.0]: overlaps the model's [0.98, 1.0]
    ok = PhysicsCheck(24, 23, "limit_surface", 300, 299, 0.95)
    assert ok.agrees and "consistent with the limit_surface model" in ok.sentence()
    # physics better than the model says: the model predicts less success
    hi = PhysicsCheck(40, 40, "quasistatic", 300, 150, 0.95)
    assert not hi.agrees and "less success" in hi.sentence()
    # the boundary: intervals that touch agree
    a, b = stats.clopper_pearson(10, 24, 0.95)
    assert PhysicsCheck(24, 10, "m", 24, 10, 0.95).agrees


def test_the_physics_columns():
    row = PhysicsCheck(24, 20, "limit_surface", 300, 280, 0.95).to_row()
    assert row["physics_n_samples"] == 24 and row["physics_n_success"] == 20
    assert row["physics_ci_low"] == pytest.approx(stats.one_sided_lower(20, 24, 0.95))
    assert row["physics_agrees"] is True
    assert NO_PHYSICS["physics_n_samples"] == 0 and math.isnan(NO_PHYSICS["physics_ci_low"])
    assert NO_PHYSICS["physics_agrees"] is None
