"""A command's searches leave their objects frozen until the next search (hbtp.collector); a loop of
many small searches (labelling training examples) hands them to the collector instead."""

from __future__ import annotations

import gc

from hbtp.collector import search_memory, searches_collected, searches_frozen
from hbtp.domains import Scenario
from hbtp.planning import plan


def test_searches_inside_searches_collected_are_not_frozen(robowaiter: Scenario) -> None:
    goal = "On_Coffee_Table1"
    with searches_frozen() as memory:
        plan(robowaiter.task, goal, "obtea")
        assert memory.frozen
        assert gc.get_freeze_count() > 0
        with searches_collected():
            assert not memory.frozen  # what the command's last search left is released first
            assert gc.get_freeze_count() == 0
            assert search_memory() is None
            for _ in range(3):
                assert plan(robowaiter.task, goal, "obtea").solved
                assert gc.get_freeze_count() == 0
        assert search_memory() is memory  # the command's own regime again after the block
        plan(robowaiter.task, goal, "obtea")
        assert memory.frozen
    assert gc.get_freeze_count() == 0
