"""The pieces of benchmarks.studies.seed_spread on inputs whose answer is known by construction."""

from __future__ import annotations

import math

import pytest
import torch

from benchmarks.studies.seed_spread import log_ratio_spread, seed_set_errors, top_share
from bnerr.errors import ValueRangeError


def test_seed_set_errors_pool_every_pixel_the_rest_and_the_regions_share():
    mask = torch.zeros(2, 2, dtype=torch.bool)
    mask[0, 0] = True
    moved = torch.zeros(2, 2, dtype=torch.bool)
    moved[1, 1] = True  # the next frame's region moved with the camera
    err = torch.ones(3, 2, 2, dtype=torch.float64)
    err[:, 0, 0] = 9.0
    later = torch.ones(3, 2, 2, dtype=torch.float64)
    later[:, 1, 1] = 9.0
    total, rest, share = seed_set_errors([err, later], [mask, moved])
    assert total == pytest.approx((9 + 1 + 1 + 1) / 4)
    assert rest == pytest.approx(1.0)
    assert share == pytest.approx(9 / 12)
    with pytest.raises(ValueRangeError, match="one mask per frame"):
        seed_set_errors([], [])
    with pytest.raises(ValueRangeError, match="one mask per frame"):
        seed_set_errors([err, err], [mask])
    with pytest.raises(ValueRangeError, match="outside them"):
        seed_set_errors([err], [torch.ones(2, 2, dtype=torch.bool)])


def test_top_share_ranks_the_pixels_of_every_frame_together():
    err = torch.ones(3, 2, 2, dtype=torch.float64)
    err[:, 0, 0] = 5.0  # the worst pixel: 15 of the frame's 24
    calm = torch.ones(3, 2, 2, dtype=torch.float64)  # 12
    assert top_share([err, calm], 1) == pytest.approx(15 / 36)
    assert top_share([err, calm], 100) == pytest.approx(1.0)  # more than the pixels: all
    assert top_share([torch.zeros(3, 2, 2)], 1) == 0.0
    with pytest.raises(ValueRangeError):
        top_share([err], 0)


def test_the_spread_is_the_sd_of_the_log_ratios():
    assert log_ratio_spread([2.0, 4.0, 8.0], [1.0, 2.0, 4.0]) == pytest.approx(0.0, abs=1e-15)
    got = log_ratio_spread([1.0, math.e], [1.0, 1.0])
    assert got == pytest.approx(math.sqrt(0.5))  # logs 0 and 1: sd = 1 / sqrt(2)
    with pytest.raises(ValueRangeError):
        log_ratio_spread([1.0], [1.0])
