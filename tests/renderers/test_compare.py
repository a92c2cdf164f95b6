"""Tests for renderers.compare: calibrated on synthetic Gaussian images, sensitive to real bias."""

import math

import pytest
import torch

from bnerr.errors import ShapeError, ValueRangeError
from renderers.compare import _binomial_quantile, compare_images


def noisy(truth: torch.Tensor, sigma: torch.Tensor, g: torch.Generator) -> torch.Tensor:
    return truth + sigma * torch.randn(truth.shape, generator=g)


def test_false_alarm_rate_is_bounded():
    g = torch.Generator().manual_seed(0)
    truth = torch.rand(3, 12, 12, generator=g)
    sigma = 0.01 + 0.05 * torch.rand(3, 12, 12, generator=g)
    alpha = 0.02
    fails = sum(
        not compare_images(
            noisy(truth, sigma, g), sigma**2, noisy(truth, sigma, g), sigma**2, alpha
        ).passed
        for _ in range(300)
    )
    # At most 3 alpha per comparison; 300 trials: allow the binomial 99.9% upper bound of 3 alpha.
    mean, sd = 300 * 3 * alpha, math.sqrt(300 * 3 * alpha * (1 - 3 * alpha))
    assert fails <= mean + 3.1 * sd


def test_detects_bias_and_outliers():
    g = torch.Generator().manual_seed(1)
    truth = 0.5 + torch.rand(3, 24, 24, generator=g)
    sigma = torch.full_like(truth, 0.02)
    a, b = noisy(truth, sigma, g), noisy(truth, sigma, g)
    assert compare_images(a, sigma**2, b, sigma**2).passed
    biased = compare_images(a * 1.01, sigma**2, b, sigma**2)  # 1 % bias, half a sigma per pixel
    assert (
        not biased.passed and biased.max_abs_z < biased.z_max
    )  # caught by the mean / count checks
    spike = b.clone()
    spike[1, 3, 4] += 0.5
    result = compare_images(a, sigma**2, spike, sigma**2)
    assert not result.passed and result.max_abs_z > 10
    assert "FAIL" in result.summary()


def test_zero_variance_pixels():
    zero = torch.zeros(3, 2, 2)
    assert compare_images(zero, zero, zero, zero).passed
    other = zero.clone()
    other[0, 0, 0] = 1e-6
    assert not compare_images(zero, zero, other, zero).passed


def test_binomial_quantile_matches_brute_force():
    n, p, alpha = 40, 0.05, 0.01
    k = _binomial_quantile(n, p, alpha)
    tail = lambda k: sum(math.comb(n, j) * p**j * (1 - p) ** (n - j) for j in range(k + 1, n + 1))  # noqa: E731
    assert tail(k) <= alpha < tail(k - 1)


def test_bad_input():
    a = torch.zeros(3, 4, 4)
    with pytest.raises(ShapeError, match="var_b: expected shape \\[3, 4, 4\\] like mean_a"):
        compare_images(a, a, a, torch.zeros(3, 4, 5))
    with pytest.raises(ShapeError, match="mean_a: expected 3 dimensions"):
        compare_images(a[0], a, a, a)
    with pytest.raises(ValueRangeError, match="alpha: expected a value in"):
        compare_images(a, a, a, a, alpha=0.9)
