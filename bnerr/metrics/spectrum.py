"""Radially averaged power spectra of images, and the low-frequency energy fraction.

This is how the project tells blue noise from white noise (docs/METHODS.md, section 6,
"Spectrum"): an image (a blue-noise mask, or the error image of a render) is cut into ``T x T``
tiles, the mean of each tile is removed, and the periodogram ``|FFT(tile)|^2 / (T_h T_w)`` is
averaged over tiles and channels. Normalised this way, white noise of variance ``s^2`` has a flat
spectrum of height ``s^2`` and the periodogram sums over frequencies to the tile's energy
(Parseval). Its sums run in a fixed order (:mod:`bnerr.reduce`): the result is the same whatever
the thread count.

The fraction of energy below a radial frequency of 0.125 cycles/pixel is the project's one-number
summary: for white noise it is the share of frequencies inside that disc, about
``pi * 0.125^2 ~= 0.049`` (exactly ``count(0 < |f| < cutoff) / (T_h T_w - 1)`` in expectation,
the lattice count of the disc; 0.0469 for 64x64 tiles); a good blue-noise mask measures close to 0.

Not for: spectral estimation with windowing or overlap (Welch). Tiles are taken as they are,
which is right for masks that tile toroidally and for error images, whose structure we want to see
at the tile scale; a non-periodic image with strong gradients leaks energy across the tile edges.
"""

from __future__ import annotations

import math

import torch

from bnerr.errors import (
    FLOAT_DTYPES,
    ShapeError,
    check_dtype,
    check_finite,
    check_positive_int,
    check_range,
    check_tensor,
)
from bnerr.reduce import fixed_sum

__all__ = ["low_frequency_fraction", "radial_power_spectrum"]


def _check_image(image: object, tile: object) -> torch.Tensor:
    """Validate ``image`` ([H, W] or [C, H, W], floating, finite) and ``tile``; return [C, H, W]."""
    image = check_tensor(image, "image")
    if image.ndim not in (2, 3):
        raise ShapeError(
            f"image: expected 2 dimensions [H, W] or 3 [C, H, W], got {image.ndim} "
            f"with shape {list(image.shape)}"
        )
    if image.numel() == 0:
        raise ShapeError(f"image: expected a non-empty image, got shape {list(image.shape)}")
    check_dtype(image, FLOAT_DTYPES, "image")
    check_finite(image, "image")
    check_positive_int(tile, "tile", minimum=2)
    return image if image.ndim == 3 else image.unsqueeze(0)


def _periodogram(image: torch.Tensor, tile: int) -> torch.Tensor:
    """Mean periodogram over tiles and channels of ``image [C, H, W]``: ``[th, tw]`` float64.

    Tiles are ``min(tile, H) x min(tile, W)``: an image smaller than the tile is one tile. Rows and
    columns beyond the last whole tile are dropped.
    """
    th, tw = min(tile, image.shape[-2]), min(tile, image.shape[-1])
    ny, nx = image.shape[-2] // th, image.shape[-1] // tw
    x = image[:, : ny * th, : nx * tw].to(torch.float64)
    # [C, ny, th, nx, tw] -> [C * ny * nx, th, tw]
    tiles = x.reshape(x.shape[0], ny, th, nx, tw).permute(0, 1, 3, 2, 4).reshape(-1, th, tw)
    # Sums in a fixed order (bnerr.reduce), so that the result does not depend on the threads.
    means = fixed_sum(tiles.reshape(tiles.shape[0], -1), dim=1) / (th * tw)
    tiles = tiles - means[:, None, None]
    spectrum = torch.fft.fft2(tiles)
    power = spectrum.real.square() + spectrum.imag.square()
    return fixed_sum(power, dim=0) / power.shape[0] / (th * tw)


def _radial_frequency(th: int, tw: int, device: torch.device) -> torch.Tensor:
    """Radial frequency ``|f|`` in cycles/pixel of every bin of a ``th x tw`` FFT: ``[th, tw]``."""
    fy = torch.fft.fftfreq(th, dtype=torch.float64, device=device)
    fx = torch.fft.fftfreq(tw, dtype=torch.float64, device=device)
    return torch.sqrt(fy[:, None].square() + fx[None, :].square())


def radial_power_spectrum(image: torch.Tensor, tile: int = 64) -> tuple[torch.Tensor, torch.Tensor]:
    """Radially averaged power spectrum of ``image`` over ``tile x tile`` tiles.

    Args:
        image: ``[H, W]`` or ``[C, H, W]`` floating-point, finite.
        tile: tile size T (>= 2). The image is cut into ``floor(H / T) x floor(W / T)`` tiles and
            the remainder rows and columns are dropped; an image smaller than T along an axis is
            one tile along that axis (``min(T, H) x min(T, W)`` tiles).

    Returns:
        ``(freq [K], power [K])`` in the image's dtype and on its device. ``freq`` is the radial
        frequency in cycles/pixel of each ring (bin centres ``k / max(T_h, T_w)`` for the rings
        that hold at least one FFT bin, from 0 up to the corner ``sqrt(2) / 2``); ``power`` is the
        mean over the ring's FFT bins of the tile-mean-removed periodogram, averaged over tiles and
        channels. White noise of variance ``s^2`` gives ``power ~= s^2`` at every ``freq > 0``;
        ``power[0]`` (DC) is 0 since each tile's mean is removed.
    """
    x = _check_image(image, tile)
    power2d = _periodogram(x, tile)
    th, tw = power2d.shape
    step = 1.0 / max(th, tw)
    ring = torch.round(_radial_frequency(th, tw, power2d.device) / step).to(torch.int64).flatten()
    count = torch.bincount(ring)
    total = torch.bincount(ring, weights=power2d.flatten())
    used = count > 0
    freq = torch.arange(count.numel(), dtype=torch.float64, device=power2d.device)[used] * step
    power = total[used] / count[used]
    return freq.to(image.dtype), power.to(image.dtype)


def low_frequency_fraction(image: torch.Tensor, tile: int = 64, cutoff: float = 0.125) -> float:
    """Fraction of the tile-mean-removed energy at radial frequency below ``cutoff``.

    Computed on the 2D periodogram (not on the rings of :func:`radial_power_spectrum`): the sum of
    the mean periodogram over FFT bins with ``0 < |f| < cutoff`` divided by its sum over all bins.

    Args:
        image: ``[H, W]`` or ``[C, H, W]`` floating-point, finite; tiled as in
            :func:`radial_power_spectrum`.
        tile: tile size T (>= 2).
        cutoff: radial frequency in cycles/pixel, in ``[0, sqrt(2) / 2]``.

    Returns:
        A float in [0, 1]: about ``pi * cutoff^2`` (0.049 at 0.125) for white noise, near 0 for
        blue noise. An image whose tiles are all constant has no energy; it returns 0.0.
    """
    x = _check_image(image, tile)
    check_range(cutoff, "cutoff", 0.0, math.sqrt(0.5))
    power2d = _periodogram(x, tile)
    total = float(fixed_sum(power2d))
    if total == 0.0:
        return 0.0
    th, tw = power2d.shape
    radius = _radial_frequency(th, tw, device=power2d.device)
    return float(fixed_sum(power2d[radius < cutoff])) / total
