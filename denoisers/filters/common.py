"""What the filters of :mod:`denoisers.filters` share: the border rule, the float64 switch, the
parameter check of their classes, and the bilateral dispatch of the two bilateral filters.

The bilateral dispatch (:func:`bilateral_torch`, the native kernel's self-check and its choice
between the two) lives here because :mod:`~denoisers.filters.bilateral` and
:mod:`~denoisers.filters.joint_bilateral` both run it; each other filter keeps its own kernel,
dispatch and self-check in its own file.

Not for: a filter of its own (one file per filter), or anything a caller outside
:mod:`denoisers.filters` should import (the package's ``__init__`` is its public face).
"""

from __future__ import annotations

import math

import torch

from bnerr.errors import check_range
from bnerr.native import SelfCheckedKernels
from denoisers import native

__all__ = ["bilateral_torch"]

_BORDER = "replicate"

# Above this magnitude a float32 square (variances, covariances) overflows to infinity and the
# filters that square their input would return NaN: they then compute in float64 (a finite
# float32 value squared is at most 1.2e77 there) and return float32. Below it nothing changes.
_FLOAT32_SAFE = 1e18


def _needs_float64(*tensors: torch.Tensor) -> bool:
    """Whether a float32 filter over these tensors would square a value past float32's range."""
    return any(t.dtype == torch.float32 and bool(t.abs().amax() > _FLOAT32_SAFE) for t in tensors)


def _odd(radius: float) -> int:
    """The odd kernel width ``2 * ceil(radius) + 1``."""
    return 2 * math.ceil(radius) + 1


def _relative(color: torch.Tensor) -> torch.Tensor:
    """``color / mean(color)``: the color in units of the frame's mean (scale-free range terms)."""
    return color / color.mean().clamp_min(1e-6)


def _number(value: object, name: str, lo: float, hi: float) -> float:
    return float(check_range(value, name, lo, hi))


def _bilateral(
    image: torch.Tensor,
    guide: torch.Tensor | None,
    kernel_size: int,
    sigma_color: float,
    sigma_space: float,
) -> torch.Tensor:
    """kornia's ``bilateral_blur`` (``guide`` None) or ``joint_bilateral_blur`` of ``image
    [C, H, W]``: L2 color distance, replicate border; the native kernel on CPU float32 tensors
    once it passed :func:`_check_bilateral` (:func:`bilateral_torch` where it refuses)."""
    tensors = (image,) if guide is None else (image, guide)
    kernels = _native_bilateral() if native.eligible(*tensors) else None
    if kernels is not None:
        threads = native.threads_for(image.shape[1] * image.shape[2])
        out = native.native_bilateral(
            kernels, image, guide, kernel_size, sigma_color, sigma_space, threads
        )
        if out is not None:
            return out
    return bilateral_torch(image, guide, kernel_size, sigma_color, sigma_space)


def bilateral_torch(
    image: torch.Tensor,
    guide: torch.Tensor | None,
    kernel_size: int,
    sigma_color: float,
    sigma_space: float,
) -> torch.Tensor:
    """The torch path of the bilateral filters, the native kernel's twin (kornia's own functions):
    ``image [C, H, W]``, ``guide [G, H, W]`` or None (the image guides itself), a square window
    of ``kernel_size`` -> ``[C, H, W]``. No scaling and no float64 switch (the callers')."""
    import kornia.filters as KF  # 0.8 s (all of kornia): only where one runs

    size, space = (kernel_size, kernel_size), (sigma_space, sigma_space)
    if guide is None:
        return KF.bilateral_blur(
            image[None], size, sigma_color, space, border_type=_BORDER, color_distance_type="l2"
        )[0]
    return KF.joint_bilateral_blur(
        image[None],
        guide[None],
        size,
        sigma_color,
        space,
        border_type=_BORDER,
        color_distance_type="l2",
    )[0]


def _check_bilateral(kernels: native.FilterKernels) -> bool:
    """Compare the native bilateral kernel with kornia on small odd-sized images (a firefly, a
    flat region, 3 and 9 guide channels): True if they agree within float32 rounding."""
    gen = torch.Generator().manual_seed(16)
    image = torch.rand(3, 23, 31, generator=gen).square() * 4.0
    image[1, 5, 7], image[:, 10:, :6] = 60.0, 0.5
    for guide, k, sigma_color in ((None, 5, 1.0), (torch.rand(9, 23, 31, generator=gen), 9, 0.3)):
        want = bilateral_torch(image, guide, k, sigma_color, k / 4)
        got = native.native_bilateral(kernels, image, guide, k, sigma_color, k / 4, 2)
        if got is None or not torch.allclose(got, want, rtol=1e-4, atol=1e-5 * 60.0):
            return False
    return True


#: The native bilateral kernel if it loads and passes :func:`_check_bilateral` (once per library).
_native_bilateral = SelfCheckedKernels(
    _check_bilateral, "denoisers.filters: the native bilateral", source=native.FILTERS
)
