"""Tests of bnerr.ldbn.quality: the white share of a toroidal Gaussian blur, and that shuffled
keys measure white while a blue arrangement measures less."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bnerr.errors import ShapeError
from bnerr.ldbn.quality import blurred_share, white_share


def test_white_share_is_one_over_four_pi_sigma_squared_on_a_large_torus():
    assert white_share(128, 2.0) == pytest.approx(1 / (4 * math.pi * 4), rel=0.01)
    assert white_share(64, 1.0) == pytest.approx(1 / (4 * math.pi), rel=0.01)


def test_random_keys_keep_the_white_share():
    rng = np.random.default_rng(0)
    scramble = rng.integers(0, 1 << 24, (1, 32, 32, 2), dtype=np.int32)
    rank = rng.integers(0, 4, (1, 32, 32, 1), dtype=np.int32)
    shares = [blurred_share(scramble, rank, 4)]
    for _ in range(4):
        shuffled = rng.permutation(scramble.reshape(-1, 2)).reshape(scramble.shape)
        shares.append(blurred_share(shuffled, rank, 4))
    mean, sd = float(np.mean(shares)), float(np.std(shares, ddof=1))
    assert abs(mean - white_share(32)) < max(4 * sd / math.sqrt(len(shares)), 0.1 * mean)


def test_shapes_are_checked():
    with pytest.raises(ShapeError):
        blurred_share(np.zeros((8, 8, 2), np.int32), np.zeros((8, 8, 1), np.int32), 1)
