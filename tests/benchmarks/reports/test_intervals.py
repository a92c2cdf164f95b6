"""Tests of benchmarks.reports.intervals: a table's intervals computed together, by shape, into
the rows that asked for them, with the single calls' bits, fallbacks and errors."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.reports.intervals import Intervals
from bnerr.errors import ValueRangeError
from bnerr.metrics import bootstrap_interval, paired_ratio


def _stats(seed: int, s: int, f: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.stack([rng.lognormal(0.0, 0.2, (s, f)), np.full((s, f), 256.0)], axis=-1)


def _filled(estimate, prefix):
    return {prefix: estimate.value, f"{prefix}_lo": estimate.lo, f"{prefix}_hi": estimate.hi}


def test_every_row_gets_the_single_calls_interval_whatever_the_shapes():
    # shapes mixed as an adaptive suite's are (8 and 16 seed sets), and one seed set (the frames'
    # within-run interval, which the batched calls do not take)
    shapes = [(8, 3), (16, 3), (8, 3), (1, 5), (16, 3)]
    intervals, rows, want = Intervals(), [], []
    for i, (s, f) in enumerate(shapes):
        mine, base = _stats(2 * i, s, f), _stats(2 * i + 1, s, f)
        row: dict = {"cell": i}
        intervals.interval(row, "den_mse", mine)
        intervals.ratio(row, "den_mse_ratio", mine, base)
        rows.append(row)
        want.append(
            {
                "cell": i,
                **_filled(bootstrap_interval(mine), "den_mse"),
                **_filled(paired_ratio(mine, base), "den_mse_ratio"),
            }
        )
    intervals.fill()
    assert rows == want
    assert intervals.singles == [] and intervals.pairs == []  # asked once, filled once


def test_a_cell_the_batch_refuses_gets_the_single_calls_error():
    mine, base = _stats(0, 4, 3), _stats(1, 4, 3)
    bad = mine.copy()
    bad[2, :, 0] = 0.0  # a seed set without error: no log ratio
    intervals = Intervals()
    intervals.ratio({}, "den_mse_ratio", mine, base)
    intervals.ratio({}, "den_mse_ratio", bad, base)
    with pytest.raises(ValueRangeError, match="values: expected positive means per seed set"):
        intervals.fill()


def test_the_bootstrap_settings_reach_the_single_calls():
    intervals = Intervals(resamples=50)
    intervals.interval({}, "raw_mse", _stats(0, 1, 4))
    with pytest.raises(ValueRangeError, match="resamples"):
        intervals.fill()
