"""The ``## Pixel regions`` section of table.md (benchmarks.reports.regions) and the reports'
handling of coherent records: their coverage is shown, an empty region is left out, and results
without coverage keep their table.md byte for byte."""

from __future__ import annotations

import dataclasses

from benchmarks.reports import write_report
from benchmarks.reports.regions import coverage_markdown
from tests._records import metric_pairs, small_record


def _records(region="all", coverage=None, scale=1.0):
    out = []
    for strategy, v in (("white", 1.0), ("temporal", 0.8), ("oracle", 0.3)):
        metrics = {
            m: metric_pairs([[v * scale] * 2] * 2) for m in ("mse", "mse_blur1", "mse_blur2")
        }
        rec = small_record(strategy, "gaussian", raw=metrics, den=metrics, frames=2, seed_sets=2)
        cell = dataclasses.replace(rec.cell, region=region)
        out.append(dataclasses.replace(rec, cell=cell, coverage=coverage))
    return out


def test_the_section_gives_each_regions_mean_and_smallest_coverage():
    text = coverage_markdown(_records() + _records("coherent", [[0.25, 0.35], [0.25, 0.35]]))
    assert "## Pixel regions" in text
    assert "| direct (coherent regions only) | 16x16 | 30.0 % | 25.0 % |" in text
    assert "(all)" not in text and coverage_markdown(_records()) == ""


def test_old_results_keep_their_table_and_empty_regions_are_left_out(tmp_path):
    for name in ("old", "empty", "new"):
        (tmp_path / name).mkdir()
    old = write_report(tmp_path / "old", _records(), title="t", charts=False)
    empty = _records("coherent", [[0.0, 0.0], [0.0, 0.0]], scale=0.0)
    assert write_report(tmp_path / "empty", _records() + empty, title="t", charts=False) == old
    assert (tmp_path / "old" / "table.csv").read_text() == (
        tmp_path / "empty" / "table.csv"
    ).read_text()
    full = _records("coherent", [[0.3, 0.3], [0.3, 0.3]], scale=0.5)
    text = write_report(tmp_path / "new", _records() + full, title="t", charts=False)
    assert set(old.splitlines()) <= set(text.splitlines())  # the other rows are unchanged
    assert "### direct (coherent regions only)" in text and "## Pixel regions" in text
    gap = (tmp_path / "new" / "gap.md").read_text()
    assert "coherent" in gap
