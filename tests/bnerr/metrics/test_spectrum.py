"""Tests of bnerr.metrics.spectrum: periodograms, sinusoids, checks."""

from __future__ import annotations

import math

import pytest
import torch

from bnerr.errors import DtypeError, NonFiniteError, ShapeError, ValueRangeError
from bnerr.metrics.spectrum import low_frequency_fraction, radial_power_spectrum


def _white(seed: int, *shape: int) -> torch.Tensor:
    return torch.randn(*shape, generator=torch.Generator().manual_seed(seed))


def _disc_count(tile: int, cutoff: float) -> int:
    """Number of FFT bins of a tile x tile periodogram with 0 < |f| < cutoff."""
    f = torch.fft.fftfreq(tile, dtype=torch.float64)
    r = torch.sqrt(f[:, None] ** 2 + f[None, :] ** 2)
    return int(((r > 0) & (r < cutoff)).sum())


def test_white_noise_fraction_matches_its_expectation():
    # For Gaussian white noise the mean-removed tile is uniform on a sphere, so the low-frequency
    # share is Beta-distributed with mean (bins in the disc) / (bins - 1). Compare the average over
    # fixed-seed images with it, within 4 standard errors measured from the same images.
    tile, cutoff = 64, 0.125
    fractions = torch.tensor(
        [low_frequency_fraction(_white(s, 64, 64), tile, cutoff) for s in range(24)]
    )
    expected = _disc_count(tile, cutoff) / (tile * tile - 1)
    stderr = float(fractions.std()) / math.sqrt(fractions.numel())
    assert abs(float(fractions.mean()) - expected) < 4 * stderr
    # ... and the lattice count is pi * cutoff^2 up to the disc's boundary cells: every unit cell
    # centred on a counted bin lies within radius r + sqrt(2)/2, and the disc of radius
    # r - sqrt(2)/2 is covered by cells of counted bins (or the DC bin).
    r = cutoff * tile
    count = _disc_count(tile, cutoff)
    assert math.pi * (r - 0.5**0.5) ** 2 - 1 <= count <= math.pi * (r + 0.5**0.5) ** 2
    assert abs(expected - math.pi * cutoff**2) < 0.005


def test_white_noise_spectrum_is_flat_at_its_variance():
    image = 3.0 * _white(1, 256, 256)  # variance 9, 16 tiles
    freq, power = radial_power_spectrum(image, tile=64)
    assert freq[0] == 0 and power[0] == 0  # each tile's mean is removed
    assert torch.allclose(freq[1:5], torch.tensor([1, 2, 3, 4]) / 64.0)
    # Parseval: the periodogram sums to the tiles' energy, so its mean over bins is the variance.
    # Ring means scatter (few bins at low radius), their bin-weighted mean does not.
    inner = power[1:33]  # rings up to Nyquist, each holding many bins
    assert abs(float(inner.mean()) - 9.0) < 9.0 * 0.1


def test_parseval_total_energy():
    image = _white(2, 64, 64)
    centred = image - image.mean()
    freq, power = radial_power_spectrum(image, tile=64)
    # The ring means weighted by their bin counts sum to the tile energy.
    f = torch.fft.fftfreq(64, dtype=torch.float64)
    ring = torch.round(torch.sqrt(f[:, None] ** 2 + f[None, :] ** 2) * 64).long().flatten()
    counts = torch.bincount(ring)
    counts = counts[counts > 0]
    total = float((power.double() * counts).sum())
    assert total == pytest.approx(float(centred.square().sum()), rel=1e-5)


def test_sinusoids_land_at_their_frequency():
    y, x = torch.meshgrid(torch.arange(64.0), torch.arange(64.0), indexing="ij")
    low = torch.cos(2 * math.pi * 4 * x / 64)  # 0.0625 cycles/pixel
    high = torch.cos(2 * math.pi * 16 * y / 64)  # 0.25 cycles/pixel
    assert low_frequency_fraction(low) == pytest.approx(1.0, abs=1e-9)
    assert low_frequency_fraction(high) == pytest.approx(0.0, abs=1e-9)
    freq, power = radial_power_spectrum(high)
    assert float(freq[int(power.argmax())]) == pytest.approx(0.25)


def test_channels_are_averaged():
    a, b = _white(3, 64, 128), 2 * _white(4, 64, 128)
    _, pa = radial_power_spectrum(a)
    _, pb = radial_power_spectrum(b)
    _, pab = radial_power_spectrum(torch.stack([a, b]))
    assert torch.allclose(pab, (pa + pb) / 2, rtol=1e-5)


def test_constant_image_has_no_energy():
    image = torch.full((64, 64), 0.5)
    assert low_frequency_fraction(image) == 0.0
    _, power = radial_power_spectrum(image)
    assert bool((power == 0).all())


def test_image_smaller_than_tile_is_one_tile():
    image = _white(5, 40, 50)
    freq, power = radial_power_spectrum(image, tile=64)
    assert float(freq[1]) == pytest.approx(1 / 50)
    # equals tiling with exactly its own size along each axis
    assert 0.0 < low_frequency_fraction(image, tile=64) < 1.0


def test_dtype_and_device_follow_input():
    image = _white(6, 64, 64).double()
    freq, power = radial_power_spectrum(image)
    assert freq.dtype == power.dtype == torch.float64
    assert freq.device == image.device
    assert radial_power_spectrum(image.float())[1].dtype == torch.float32


def test_deterministic():
    image = _white(7, 3, 96, 96)
    assert torch.equal(radial_power_spectrum(image)[1], radial_power_spectrum(image)[1])
    assert low_frequency_fraction(image) == low_frequency_fraction(image)


def test_bad_input():
    with pytest.raises(ShapeError, match=r"image: expected 2 dimensions \[H, W\] or 3"):
        radial_power_spectrum(torch.zeros(1, 1, 8, 8))
    with pytest.raises(ShapeError, match="image: expected a non-empty image"):
        low_frequency_fraction(torch.zeros(0, 8))
    with pytest.raises(DtypeError, match="image: expected dtype .*float32.*, got int64"):
        radial_power_spectrum(torch.zeros(8, 8, dtype=torch.int64))
    with pytest.raises(DtypeError, match="image: expected a torch.Tensor, got list"):
        low_frequency_fraction([[0.0]])
    with pytest.raises(NonFiniteError, match="image: expected finite values, got 1 NaN"):
        low_frequency_fraction(torch.tensor([[0.0, float("nan")], [0.0, 0.0]]))
    with pytest.raises(ValueRangeError, match="tile: expected an integer >= 2, got 1"):
        radial_power_spectrum(torch.zeros(8, 8), tile=1)
    with pytest.raises(ValueRangeError, match=r"cutoff: expected a value in \[0.0, 0.707"):
        low_frequency_fraction(torch.zeros(8, 8), cutoff=0.9)
