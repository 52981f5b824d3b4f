"""The report's headline counts the rows that reproduce the paper's number, its trend only, and
those with no comparable figure apart, and reports the predictions beside them."""

from __future__ import annotations

import pytest

from k37.sim.reproduce.markdown import Row, Section, scoreboard


def test_the_headline_counts_each_kind_of_row_apart():
    sec = Section(1, "t", ())
    sec.row("a", "1", "1", "1%", True, kind="number")
    sec.row("b", "up", "up", "up", True, kind="trend")
    sec.row("c", "up", "down", "up", False, kind="trend")
    sec.row("d", "none", "2", "model", True, kind="quoted")
    assert scoreboard(sec.rows) == (
        "3 of 4 rows pass: 1 reproduce the paper's number within the stated tolerance, "
        "1 its trend or direction only, 1 have no comparable figure in the paper (the "
        "emulator against a model)")


def test_a_prediction_that_did_not_hold_is_reported_and_not_failed():
    sec = Section(1, "t", ())
    sec.row("a", "1", "1", "1%", True, kind="number")
    sec.row("b", "2", "5", "25%", False, kind="prediction")
    sec.row("c", "3", "3", "25%", True, kind="prediction")
    assert scoreboard(sec.rows) == (
        "1 of 1 rows pass: 1 reproduce the paper's number within the stated tolerance, "
        "0 its trend or direction only, 0 have no comparable figure in the paper (the "
        "emulator against a model); 1 of 2 predictions from parameters identified on "
        "another of the paper's numbers held")
    assert [row.failed for row in sec.rows] == [False, False, False]
    assert [row.verdict for row in sec.rows] == ["pass", "did not hold", "held"]
    sec.row("d", "up", "down", "up", False, kind="trend")
    assert sec.rows[-1].failed and sec.rows[-1].verdict == "**FAIL**"


def test_a_row_needs_a_known_kind():
    with pytest.raises(ValueError, match="kind is one of number, trend, quoted, prediction"):
        Row("a", "1", "1", "1%", True, "close")
