"""Tests of benchmarks.speed: every script's figures land in speed.json and speed.md."""

import json

import pytest
import torch

from benchmarks.speed import run_speed, speed_markdown
from benchmarks.suites import Suite


def test_speed_suite_stores_each_scripts_figures(tmp_path, monkeypatch):
    # The speed scripts time 1080p work for minutes; their own tests cover them. Here only the
    # plumbing: every script's measure() is called and its nested figures land in JSON and Markdown.
    import benchmarks.speed_masks as speed_masks

    def measure():
        """Seconds per
        mask.

        Not in the report."""
        return {"scalar_64": {"seconds": 0.5, "low": torch.tensor(0.01)}}

    monkeypatch.setattr(speed_masks, "measure", measure)
    suite = Suite("speed", "timings", scripts=("speed_masks",))
    text = run_speed(suite, tmp_path, progress=False)
    assert "## speed_masks\n\nSeconds per mask.\n\n| figure | value |" in text  # one line
    stored = json.loads((tmp_path / "speed.json").read_text())
    assert stored == {"speed_masks": {"scalar_64": {"seconds": 0.5, "low": pytest.approx(0.01)}}}
    assert "| scalar_64/seconds | 0.5 |" in text and (tmp_path / "speed.md").read_text() == text


def test_markdown_lists_every_leaf_under_its_path():
    suite = Suite("speed", "what it times", scripts=("a",))
    text = speed_markdown(suite, {"a": {"x": {"y": 1.23456789, "z": None}, "n": 3}}, {})
    assert text.startswith("# bnerr bench --suite speed\n\nwhat it times\n\n## a\n\n| figure |")
    assert "| x/y | 1.23457 |" in text and "| x/z | None |" in text and "| n | 3 |" in text
