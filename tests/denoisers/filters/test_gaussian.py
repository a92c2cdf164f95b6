"""Tests of denoisers/filters/gaussian.py: the linear blur removes white noise as theory says."""

import math

import torch

from denoisers.filters import gaussian_filter


def test_gaussian_removes_white_noise_variance_as_theory_says():
    # A unit-sum kernel k turns white noise of variance v into variance v * sum(k^2); for a
    # sampled Gaussian of sigma s that is close to 1 / (4 pi s^2).
    noise = torch.randn(3, 256, 256, generator=torch.Generator().manual_seed(2))
    sigma = 2.0
    out = gaussian_filter(noise, sigma)[:, 16:-16, 16:-16]
    expected = 1.0 / (4 * math.pi * sigma**2)
    # The estimate of the variance of ~ 3 * 224^2 / (4 pi s^2 * 4) independent values has a relative
    # standard error of about sqrt(2 / N_eff) = 1.5 %; allow 4 standard errors.
    assert abs(float(out.var()) / expected - 1) < 0.06
