"""``benchmarks.speed.sequences.measure()`` for real with tiny sizes: the sampler calls and
the renders they drive."""

from __future__ import annotations

import functools

import pytest

from benchmarks.speed import sequences

pytestmark = pytest.mark.usefixtures("one_thread")


def test_sequences_times_each_sampler_call_and_each_driven_render(monkeypatch):
    # measure() takes no arguments: its two parts get the tiny sizes.
    samples = functools.partial(sequences.measure_samples, n=64, counts=(2,), repeats=1)
    renders = functools.partial(sequences.measure_render, size=8, spp=1, repeats=1)
    monkeypatch.setattr(sequences, "measure_samples", samples)
    monkeypatch.setattr(sequences, "measure_render", renders)
    figures = sequences.measure()
    assert set(figures) == {"sample", "render"}
    assert figures["sample"] and all(
        set(row) == {2} and row[2] > 0 for row in figures["sample"].values()
    )
    assert set(figures["render"]) == set(sequences.RENDERED)
    assert all(s > 0 for s in figures["render"].values())
