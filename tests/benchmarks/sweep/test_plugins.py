"""benchmarks.sweep.plugins: what ``--report-only`` says of the plug-ins a folder's records were
measured with (issue 54, item 10): a spec it cannot load and, now, an installed entry point that
this environment lacks (it was silent about those), each one line."""

from __future__ import annotations

import dataclasses

from benchmarks.sweep.plugins import load_recorded
from tests._records import metric_pairs, small_record


def _record(plugins: dict):
    pairs = metric_pairs([[1.0, 2.0]])
    record = small_record("white", "gaussian", raw={"mse": pairs}, den={"mse": pairs},
                          frames=2, seed_sets=1)  # fmt: skip
    return dataclasses.replace(record, plugins=plugins)


def test_report_only_names_a_missing_entry_point_and_a_missing_spec(tmp_path):
    records = [
        _record(
            {
                "bnerr.denoisers:gone_den": {
                    "spec": "entry point gone_den",
                    "fingerprint": "gonedist==1.2",
                },
                "bnerr.metrics:gone_metric": {
                    "spec": f"{tmp_path / 'gone.py'}:metric",
                    "fingerprint": "sha256:0",
                },
            }
        )
    ]
    notes = load_recorded(records)
    assert len(notes) == 2 and all("\n" not in n for n in notes)
    entry = next(n for n in notes if "gone_den" in n)
    assert "entry point gone_den of group bnerr.denoisers" in entry
    assert "gonedist==1.2" in entry and "reported from its records" in entry
    assert any("gone.py:metric" in n for n in notes)


def test_a_shipped_or_present_plug_in_gives_no_note():
    assert load_recorded([_record({})]) == []
