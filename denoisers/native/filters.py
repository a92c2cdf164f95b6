"""Bindings of ``filters.c``: the a-trous and (joint) bilateral kernels of :mod:`denoisers.filters`.

The C source ``filters.c`` (package data of this package) is built, cached and loaded by
:func:`bnerr.native.library`, with the same compiler search, hash check and single warning as the
permutation kernels. This module binds its two functions and wraps them for tensors:

- :func:`native_atrous`: every pass of the edge-avoiding a-trous filter in one call (luminance,
  the 3 x 3 variance blur, the 25 weighted taps of color and variance), rows split over threads.
- :func:`native_bilateral`: kornia's ``bilateral_blur`` / ``joint_bilateral_blur`` with an L2
  color distance and a replicate border, for any image and guide channel counts.

Why C: the torch paths spend their time on one full-image temporary per operation and tap (25
taps of about 15 operations per a-trous pass, 81 taps of 9-channel distances for the joint
bilateral). The C loops keep a block of 256 pixels of one row in the CPU's first-level cache and
compute each weight with a polynomial exp (and log) in SIMD registers.

What stays with the caller (:mod:`denoisers.filters`): which inputs go native, the constants of
the a-trous filter, the self-check of each kernel against its torch path and the fallback.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import torch

from bnerr import native

__all__ = [
    "LIBRARY",
    "TORCH_PATH_COST",
    "FilterKernels",
    "native_atrous",
    "native_bilateral",
    "native_luminance_variance",
]

#: What the torch path costs instead, quoted in the warnings. Measured at 1920x1080 on 2 threads
#: of a shared 2-core machine, old and new side by side (more under heavier load): the torch
#: a-trous filter took 6-15 times, the kornia joint bilateral 13 times and the kornia bilateral
#: 6-9 times as long.
TORCH_PATH_COST = (
    "at 1080p the a-trous filter runs about 6-15x, the joint bilateral about 13x and the "
    "bilateral about 6-9x slower on the CPU"
)
_SYMBOLS = ("bnerr_atrous", "bnerr_bilateral", "bnerr_luminance_variance")


@dataclass(frozen=True)
class FilterKernels:
    """The bound C functions of one loaded library (``why`` says where it came from)."""

    atrous: Callable[..., int]
    bilateral: Callable[..., int]
    variance: Callable[..., int]
    why: str


def _bind(library: ctypes.CDLL, why: str) -> FilterKernels:
    """Bind the expected functions; AttributeError if the library lacks one."""
    p, i64, f32, c_int = ctypes.c_void_p, ctypes.c_int64, ctypes.c_float, ctypes.c_int
    atrous = library.bnerr_atrous
    atrous.argtypes = [p, p, p, p, p, p, i64, i64, c_int, f32, f32, f32, f32, p, p, c_int]
    atrous.restype = c_int
    bilateral = library.bnerr_bilateral
    bilateral.argtypes = [p, i64, p, i64, p, i64, i64, f32, p, i64, i64, c_int]
    bilateral.restype = c_int
    variance = library.bnerr_luminance_variance
    variance.argtypes = [p, p, i64, i64, i64, p, c_int]
    variance.restype = c_int
    return FilterKernels(atrous, bilateral, variance, why)


#: The library of ``filters.c``: ``LIBRARY.load()`` gives the bound :class:`FilterKernels`
#: (building them on first use) or None, ``LIBRARY.status()`` says where they came from or why not.
LIBRARY = native.library(__package__, "filters.c", _bind, _SYMBOLS, TORCH_PATH_COST)


def _floats(values: Sequence[float] | Sequence[Sequence[float]]) -> torch.Tensor:
    return torch.tensor(values, dtype=torch.float32).flatten().contiguous()


def native_atrous(
    kernels: FilterKernels,
    planes: tuple[torch.Tensor, ...],
    iterations: int,
    sigmas: tuple[float, float, float],
    floor: float,
    constants: tuple[tuple[float, ...], tuple[tuple[float, ...], ...]],
    threads: int,
) -> torch.Tensor | None:
    """All passes of the a-trous filter in C (the rule of :func:`denoisers.filters.atrous_torch`).

    Args:
        kernels: from ``LIBRARY.load()``.
        planes: ``(color [3, H, W], variance [1, H, W], normal4 [4, H, W], depth [1, H, W],
            depth_width [1, H, W])``, float32 CPU tensors.
        iterations: passes, hole spacing ``2^i`` in pass ``i``.
        sigmas: (color, normal, depth).
        floor: the smallest cosine whose log the normal weight takes.
        constants: the luminance weights (3) and the 3 x 3 variance blur.
        threads: worker threads (split by rows; the result does not depend on it).

    Returns:
        The filtered color ``[3, H, W]``, or None when the kernel refuses the sizes.
    """
    color, variance, normal4, depth, depth_width = (t.contiguous() for t in planes)
    weights, blur = _floats(constants[0]), _floats(constants[1])
    h, w = color.shape[1:]
    out = torch.empty_like(color)
    code = kernels.atrous(
        color.data_ptr(), variance.data_ptr(), normal4.data_ptr(), depth.data_ptr(),
        depth_width.data_ptr(), out.data_ptr(), h, w, iterations, *sigmas, floor,
        weights.data_ptr(), blur.data_ptr(), threads,
    )  # fmt: skip
    return out if code == 0 else None


def native_luminance_variance(
    kernels: FilterKernels,
    color: torch.Tensor,
    radius: int,
    weights: tuple[float, float, float],
    threads: int,
) -> torch.Tensor | None:
    """The a-trous filter's spatial variance estimate in C: the variance ``[1, H, W]`` of the
    luminance ``(w0 R + w1 G) + w2 B`` of ``color [3, H, W]`` (float32, CPU) in a
    ``2 radius + 1`` square window with a replicate border, at least 0. None when the kernel
    refuses the sizes (``radius`` above 64)."""
    color = color.contiguous()
    h, w = color.shape[1:]
    out = torch.empty((1, h, w), dtype=torch.float32)
    lum_weights = _floats(weights)
    code = kernels.variance(
        color.data_ptr(), out.data_ptr(), h, w, radius, lum_weights.data_ptr(), threads
    )
    return out if code == 0 else None


def native_bilateral(
    kernels: FilterKernels,
    image: torch.Tensor,
    guide: torch.Tensor | None,
    kernel_size: int,
    sigma_color: float,
    sigma_space: float,
    threads: int,
) -> torch.Tensor | None:
    """kornia's bilateral filter in C: ``bilateral_blur`` (``guide`` None: the image guides
    itself) or ``joint_bilateral_blur``, square ``kernel_size``, L2 color distance, replicate
    border.

    Args:
        kernels: from ``LIBRARY.load()``.
        image: ``[C, H, W]`` float32 CPU tensor, C <= 16.
        guide: ``[G, H, W]`` float32 CPU tensor or None.
        kernel_size: odd window width.
        sigma_color, sigma_space: as kornia's (the spatial kernel is kornia's, normalized).
        threads: worker threads (split by rows; the result does not depend on it).

    Returns:
        ``[C, H, W]``, or None when the kernel refuses the sizes.
    """
    import kornia.filters as KF  # 0.8 s (all of kornia): only where one runs

    image = image.contiguous()
    guide = image if guide is None else guide.contiguous()
    k = (kernel_size, kernel_size)
    space = KF.get_gaussian_kernel2d(k, (sigma_space, sigma_space), dtype=torch.float32)
    space = space.flatten().contiguous()
    out = torch.empty_like(image)
    c, h, w = image.shape
    code = kernels.bilateral(
        image.data_ptr(), c, guide.data_ptr(), guide.shape[0], space.data_ptr(), *k,
        -0.5 / sigma_color**2, out.data_ptr(), h, w, threads,
    )  # fmt: skip
    return out if code == 0 else None
