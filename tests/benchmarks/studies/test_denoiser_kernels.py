"""Tests of benchmarks.studies.denoiser_kernels: a Gaussian denoiser's measured kernel is its
analytic Gaussian, and the width, noise width, radial profile and autocorrelation say what they
should."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from benchmarks.studies.denoiser_kernels import (
    autocorrelation,
    impulse_kernel,
    kernel_width,
    noise_width,
    radial_profile,
)
from bnerr.errors import ValueRangeError
from bnerr.frame import Frame
from denoisers.filters import Gaussian


def _gauss(half: int, sigma: float) -> np.ndarray:
    d = np.arange(-half, half + 1)
    g = np.exp(-(d[:, None] ** 2 + d[None, :] ** 2) / (2 * sigma * sigma))
    return g / g.sum()


def test_a_gaussian_denoisers_kernel_is_its_gaussian():
    gen = torch.Generator().manual_seed(0)
    frame = Frame(color=torch.rand(3, 48, 48, generator=gen) + 0.5)
    kernel = impulse_kernel(Gaussian(sigma=1.0).denoise, frame, half=5, spacing=12, patterns=2)
    assert kernel.shape == (11, 11)
    assert np.abs(kernel - _gauss(5, 1.0)).max() < 0.005  # kornia truncates at its window
    assert kernel_width(kernel) == pytest.approx(1.0, abs=0.05)
    assert noise_width(kernel) == pytest.approx(1.0, abs=0.05)
    profile = radial_profile(kernel)
    assert len(profile) == 6 and all(a > b for a, b in zip(profile[:4], profile[1:4]))
    # the autocorrelation of a Gaussian of sigma s is a Gaussian of sigma s sqrt(2)
    auto = autocorrelation(_gauss(8, 1.0))
    assert auto.shape == (33, 33) and auto[16, 16] == auto.max()
    assert kernel_width(auto / auto.sum()) == pytest.approx(np.sqrt(2), abs=0.02)


def test_bad_windows_are_refused():
    frame = Frame(color=torch.ones(3, 8, 8))
    with pytest.raises(ValueRangeError, match="spacing"):
        impulse_kernel(Gaussian().denoise, frame, half=3, spacing=5)
    with pytest.raises(ValueRangeError, match="pixels a side"):
        impulse_kernel(Gaussian().denoise, frame, half=5, spacing=11)
    assert np.isnan(kernel_width(np.array([[0, -1, 0], [-1, 5, -1], [0, -1, 0]], float)))
