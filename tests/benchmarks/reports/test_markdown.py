"""Tests of benchmarks.reports.markdown."""

from benchmarks.reports.markdown import table_lines


def test_a_table_is_header_rule_and_one_line_per_row():
    assert table_lines(["a", "b"], [["1", "2"], ("3", "4")]) == [
        "| a | b |",
        "|---|---|",
        "| 1 | 2 |",
        "| 3 | 4 |",
    ]
    assert table_lines(["only"], []) == ["| only |", "|---|"]
