"""The pieces of benchmarks.studies.seed_spread on inputs whose answer is known by construction."""

from __future__ import annotations

import math

import pytest
import torch

from benchmarks.studies.seed_spread import log_ratio_spread, seed_set_errors
from bnerr.errors import ValueRangeError


def test_seed_set_errors_pool_every_pixel_and_the_rest():
    mask = torch.zeros(2, 2, dtype=torch.bool)
    mask[0, 0] = True
    err = torch.ones(3, 2, 2, dtype=torch.float64)
    err[:, 0, 0] = 9.0  # the masked pixel
    total, rest = seed_set_errors([err, err], mask)
    assert total == pytest.approx((9 + 1 + 1 + 1) / 4)
    assert rest == pytest.approx(1.0)
    with pytest.raises(ValueRangeError):
        seed_set_errors([], mask)
    with pytest.raises(ValueRangeError):
        seed_set_errors([err], torch.ones(2, 2, dtype=torch.bool))


def test_the_spread_is_the_sd_of_the_log_ratios():
    assert log_ratio_spread([2.0, 4.0, 8.0], [1.0, 2.0, 4.0]) == pytest.approx(0.0, abs=1e-15)
    got = log_ratio_spread([1.0, math.e], [1.0, 1.0])
    assert got == pytest.approx(math.sqrt(0.5))  # logs 0 and 1: sd = 1 / sqrt(2)
    with pytest.raises(ValueRangeError):
        log_ratio_spread([1.0], [1.0])
