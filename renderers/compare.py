"""Do two Monte Carlo images estimate the same expected image? A per-pixel z-test with its maths.

Given two independent estimates ``a`` and ``b`` of the same image, each with the variance of its
pixel means (``Frame.variance``: per-pixel sample variance / spp), each value
``z = (a - b) / sqrt(var_a + var_b)`` is approximately standard normal when both converge to the
same image (central limit theorem at the spp used; the variances are estimated, with spp - 1
degrees of freedom each, which at a few hundred spp changes the tails negligibly). With
``m = C * H * W`` values, :func:`compare_images` checks three things, each at false-alarm
probability ``alpha``, so a correct pair fails with probability at most ``3 alpha``:

1. **Largest deviation**: ``max |z| <= z_max``, with ``z_max = max(4, Phi^-1(1 - alpha / (2 m)))``
   (Bonferroni: ``P(max |z| > z_max) <= m * 2 (1 - Phi(z_max)) <= alpha``, whatever the
   correlation between channels). A single pixel beyond 4 standard errors is what the issue
   calls a mismatch; with m values a correct renderer crosses 4 somewhere with probability up to
   ``m * 6.3e-5`` (11 % at 24 x 24 x 3), hence the Bonferroni threshold, about 5 there, and never
   below 4.
2. **How many pixels deviate moderately**: the number of pixels with some channel beyond 3
   standard errors must not exceed the ``1 - alpha`` quantile of ``Binomial(H W, p3)``,
   ``p3 = C * 2 (1 - Phi(3))`` (union bound over the C channels: exact for independent channels'
   upper bound, conservative for correlated ones; pixels are independent because their seeds are).
   This catches a bias spread over many pixels that never reaches z_max.
3. **Global bias**: per channel, the mean of z over the H W independent pixels is
   ``N(0, 1 / (H W))``; it must stay within ``Phi^-1(1 - alpha / (2 C)) / sqrt(H W)``. This catches
   a small, uniform bias (one percent of the image at the spp of the cross-check).

A pixel where both variances are zero (for example black background in both) passes only if the
two values are equal.

Not for: images whose errors are not independent between pixels (a denoised image, or blue-noise
sequences whose errors are anti-correlated by design: the pixel-mean check then is conservative,
the others are not calibrated).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

import torch

from bnerr.errors import ShapeError, check_range, check_shape

__all__ = ["Comparison", "compare_images"]


@dataclass(frozen=True)
class Comparison:
    """Result of :func:`compare_images`.

    Attributes:
        z: ``[C, H, W]`` per-value z scores.
        max_abs_z, z_max: the largest |z| and its threshold.
        pixels_beyond_3, allowed_beyond_3: pixels with a channel beyond 3 standard errors, and
            the most that pass.
        mean_z: per-channel mean z over pixels; mean_z_max: its threshold.
        passed: all three checks hold.
    """

    z: torch.Tensor
    max_abs_z: float
    z_max: float
    pixels_beyond_3: int
    allowed_beyond_3: int
    mean_z: tuple[float, ...]
    mean_z_max: float
    passed: bool

    def summary(self) -> str:
        means = ", ".join(f"{m:+.3f}" for m in self.mean_z)
        return (
            f"max |z| {self.max_abs_z:.2f} (limit {self.z_max:.2f}); pixels beyond 3 sigma "
            f"{self.pixels_beyond_3} (limit {self.allowed_beyond_3}); mean z per channel [{means}] "
            f"(limit {self.mean_z_max:.3f}): {'pass' if self.passed else 'FAIL'}"
        )


def _binomial_quantile(n: int, p: float, alpha: float) -> int:
    """Smallest k with P(Binomial(n, p) > k) <= alpha."""
    pmf = (1.0 - p) ** n
    cdf = pmf
    k = 0
    while 1.0 - cdf > alpha and k < n:
        pmf *= (n - k) / (k + 1) * p / (1.0 - p)
        k += 1
        cdf += pmf
    return k


def compare_images(
    mean_a: torch.Tensor,
    var_a: torch.Tensor,
    mean_b: torch.Tensor,
    var_b: torch.Tensor,
    alpha: float = 1e-3,
) -> Comparison:
    """Test whether two independent Monte Carlo images have the same expectation.

    Args:
        mean_a, mean_b: ``[C, H, W]`` pixel means.
        var_a, var_b: ``[C, H, W]`` variances of those means (sample variance / spp).
        alpha: false-alarm probability of each of the three checks (module docstring).

    Returns:
        A :class:`Comparison`.

    Raises:
        ShapeError: the four tensors do not share one ``[C, H, W]`` shape.
        ValueRangeError: ``alpha`` not in (0, 0.5].
    """
    size = check_shape(mean_a, "C H W", "mean_a")
    for x, name in ((var_a, "var_a"), (mean_b, "mean_b"), (var_b, "var_b")):
        check_shape(x, "C H W", name)
        if x.shape != mean_a.shape:
            raise ShapeError(
                f"{name}: expected shape {list(mean_a.shape)} like mean_a, got {list(x.shape)}"
            )
    check_range(alpha, "alpha", 1e-12, 0.5)
    channels, pixels = size["C"], size["H"] * size["W"]
    diff = mean_a.double() - mean_b.double()
    scale = (var_a.double() + var_b.double()).clamp_min(0.0).sqrt()
    z = torch.where(
        scale > 0, diff / torch.where(scale > 0, scale, 1.0), torch.where(diff == 0, 0.0, torch.inf)
    )
    normal = NormalDist()
    m = z.numel()
    z_max = max(4.0, normal.inv_cdf(1.0 - alpha / (2 * m)))
    p3 = min(1.0, channels * 2.0 * (1.0 - normal.cdf(3.0)))
    allowed = _binomial_quantile(pixels, p3, alpha)
    beyond = int((z.abs() > 3).any(dim=0).sum())
    mean_z = tuple(float(v) for v in z.mean(dim=(1, 2)))
    mean_limit = normal.inv_cdf(1.0 - alpha / (2 * channels)) / math.sqrt(pixels)
    max_abs = float(z.abs().max())
    passed = max_abs <= z_max and beyond <= allowed and all(abs(v) <= mean_limit for v in mean_z)
    return Comparison(z.float(), max_abs, z_max, beyond, allowed, mean_z, mean_limit, passed)
