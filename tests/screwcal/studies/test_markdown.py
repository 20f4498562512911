"""The studies' Markdown tables (`screwcal.studies.markdown`)."""

import pytest

from screwcal.studies.markdown import markdown_table


def test_the_separator_has_a_dash_cell_per_column():
    assert markdown_table(("a", "b"), [("1", "2")]) == ["| a | b |", "|---|---|", "| 1 | 2 |"]


def test_a_row_of_the_wrong_width_is_refused():
    with pytest.raises(ValueError, match="3 cells under 2 columns"):
        markdown_table(("a", "b"), [("1", "2", "3")])
