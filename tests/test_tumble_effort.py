"""Tests of the tumble planner's effort budget (:mod:`planning.tumbling.effort`)."""
from __future__ import annotations

import math
import time

import pytest

from planning.tumbling.effort import BudgetExhausted, Effort


def test_charge_check_and_exhaustion():
    e = Effort(limit=100, time_limit=None)
    e.charge(60, "a")
    e.check(40, "b")  # exactly fits: nothing charged
    assert e.used == 60 and e.remaining == 40 and e.affordable(40) and not e.affordable(41)
    with pytest.raises(BudgetExhausted) as exc:
        e.check(41, "b")
    assert exc.value.stage == "b" and exc.value.needed == 101 and not exc.value.clock
    with pytest.raises(BudgetExhausted):
        e.charge(50, "c")
    assert e.used == 110 and e.by_stage == {"a": 60, "c": 50}
    assert e.exhausted.stage == "b"  # the first stage that ran out is kept
    e.add(5)  # counted, never raises
    assert e.used == 115 and e.remaining == 0


def test_charge_once_is_per_call_and_independent_of_caching():
    table = object()
    e1 = Effort(limit=None, time_limit=None)
    e1.charge_once(table, 30, "tables")
    e1.charge_once(table, 30, "tables")
    e2 = Effort(limit=None, time_limit=None)
    e2.charge_once(table, 30, "tables")
    assert e1.used == e2.used == 30 and e1.limit == math.inf


def test_wall_clock_backstop():
    e = Effort(limit=None, time_limit=1e-3)
    time.sleep(0.01)
    with pytest.raises(BudgetExhausted) as exc:
        e.charge(1, "slow stage")
    assert exc.value.clock and "wall-clock" in str(exc.value)
    assert Effort.unlimited().remaining == math.inf
