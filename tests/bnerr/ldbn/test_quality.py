"""Tests of bnerr.ldbn.quality: the white share of a toroidal Gaussian blur, and that shuffled
keys measure white while a blue arrangement measures less."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bnerr.errors import ShapeError, ValueRangeError
from bnerr.ldbn.quality import blurred_share, white_share


def test_white_share_is_one_over_four_pi_sigma_squared_on_a_large_torus():
    assert white_share(128, 2.0) == pytest.approx(1 / (4 * math.pi * 4), rel=0.01)
    assert white_share(64, 1.0) == pytest.approx(1 / (4 * math.pi), rel=0.01)


@pytest.mark.parametrize("pair", [0, (0, 1)])
def test_random_keys_keep_the_white_share(pair):
    """One pair on 2-D tests, and two pairs measured jointly on 4-D tests: random keys are white
    either way (the margin: four standard errors over five arrangements, or 10 %)."""
    rng = np.random.default_rng(0)
    scramble = rng.integers(0, 1 << 24, (1, 32, 32, 4), dtype=np.int32)
    rank = rng.integers(0, 4, (1, 32, 32, 2), dtype=np.int32)
    shares = [blurred_share(scramble, rank, 4, pair=pair)]
    for _ in range(4):
        shuffled = rng.permutation(scramble.reshape(-1, 4)).reshape(scramble.shape)
        shares.append(blurred_share(shuffled, rank, 4, pair=pair))
    mean, sd = float(np.mean(shares)), float(np.std(shares, ddof=1))
    assert abs(mean - white_share(32)) < max(4 * sd / math.sqrt(len(shares)), 0.1 * mean)


def test_one_pair_in_a_tuple_is_that_pair():
    rng = np.random.default_rng(1)
    scramble = rng.integers(0, 1 << 24, (1, 16, 16, 4), dtype=np.int32)
    rank = rng.integers(0, 4, (1, 16, 16, 2), dtype=np.int32)
    assert blurred_share(scramble, rank, 4, pair=(1,)) == blurred_share(scramble, rank, 4, pair=1)


@pytest.mark.parametrize("pair", [3, -1, (), (0, 0), (0, 1, 2)])
def test_pairs_outside_the_keys_are_refused(pair):
    scramble = np.zeros((1, 8, 8, 6), np.int32)
    with pytest.raises(ValueRangeError, match="pair"):
        blurred_share(scramble, np.zeros((1, 8, 8, 3), np.int32), 1, pair=pair)


def test_shapes_are_checked():
    with pytest.raises(ShapeError):
        blurred_share(np.zeros((8, 8, 2), np.int32), np.zeros((8, 8, 1), np.int32), 1)
