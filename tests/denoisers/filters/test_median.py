"""Tests of denoisers/filters/median.py: a firefly removed, an absurd window refused."""

import pytest
import torch

from bnerr.errors import MemoryLimitError
from denoisers import get_denoiser
from denoisers.filters import median_filter
from tests._images import random_frame


def test_median_removes_an_isolated_firefly():
    color = torch.full((3, 9, 9), 0.5)
    color[:, 4, 4] = 100.0
    assert torch.equal(median_filter(color, 3), torch.full((3, 9, 9), 0.5))


def test_an_absurd_kernel_is_refused_before_allocating():
    match = "median: kernel_size 2001 on 24x24: expected a size that fits in memory .* got an"
    with pytest.raises(MemoryLimitError, match=match):
        get_denoiser("median", kernel_size=2001)(random_frame(24, 24, seed=5))
