"""The pieces of benchmarks.seed_spread on inputs whose answer is known by construction."""

from __future__ import annotations

import math

import pytest
import torch

from benchmarks.seed_spread import light_pixels, log_ratio_spread, seed_set_errors
from bnerr.errors import ShapeError, ValueRangeError


def test_light_pixels_are_the_lights_first_hits_grown_by_a_square_window():
    ids = torch.full((1, 6, 7), 2.0)
    ids[0, 2, 3] = 5.0  # a light
    ids[0, 5, 6] = 4.0  # another light, in the corner
    ids[0, 0, 0] = -1.0  # background
    want = torch.zeros(6, 7, dtype=torch.bool)
    want[1:4, 2:5] = True
    want[4:6, 5:7] = True
    assert torch.equal(light_pixels(ids, (5, 4), grow=1), want)
    assert torch.equal(light_pixels(ids, (5, 4), grow=0), (ids[0] == 5) | (ids[0] == 4))
    assert not light_pixels(ids, (), grow=3).any()  # no light: no pixel
    with pytest.raises(ShapeError):
        light_pixels(ids[0], (5,))


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
