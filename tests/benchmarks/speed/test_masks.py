"""``benchmarks.speed.masks.measure()`` for real on tiny masks: time and low-frequency
fraction of each."""

from __future__ import annotations

import pytest

from benchmarks.speed import masks

pytestmark = pytest.mark.usefixtures("one_thread")


def test_masks_times_each_mask_and_measures_its_low_frequencies():
    figures = masks.measure(scalar_sizes=(16,), vector_dims=(2,), vector_size=16, repeats=1)
    assert set(figures) == {"scalar_16", "vector_16_d2"}
    for row in figures.values():
        assert row["seconds"] > 0 and 0 <= row["low_frequency_fraction"] < 0.049
