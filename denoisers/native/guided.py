"""Bindings of ``guided.c``: the guided filter's kernel of :func:`denoisers.filters.guided_filter`.

The C source ``guided.c`` (package data of this package) is built, cached and loaded by
:func:`bnerr.native.library`; :func:`native_guided` runs it on tensors. Which inputs go native,
the self-check against the torch path and the fallback stay with :mod:`denoisers.filters`.

Why a C kernel: the torch path makes about 60 full-frame planes of window statistics and runs
the per-pixel 7 x 7 Cholesky solve as a few hundred full-frame tensor ops, so its cost is memory
traffic (about 3 s per 1920 x 1080 frame on two threads). The kernel computes the same values
in the same order, band by band and tile by tile (256 columns), two rows at a time, with the last
``2 radius + 2`` input rows and their products, the window statistics of two rows and the last
``2 radius + 2`` coefficient rows in the CPU's caches, 8 pixels per SIMD vector. It also computes
the guide's luminance and the float64 switch's test for values above 1e18 as it reads the
inputs (the torch test alone cost about as much as the whole kernel).

Precision: every window sum is recomputed from its 2 radius + 1 terms (no running sums, which
drift in float32 and, after a 1e18 firefly leaves the window, lose every digit).

Agreement: the kernel does the torch path's operations in its order, without fused
multiply-adds; torch's own kernels fuse some (``addcmul``) and sum seven planes in another order,
and neither computes ``1 / sqrt`` exactly, so the two differ by a few float32 roundings (measured
below 3e-7 of the largest output value, eps 1e-8 to 10). Results do not depend on the thread
count: each value is computed by the same operations whatever band it falls in.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable
from dataclasses import dataclass

import torch

from bnerr import native
from bnerr.color import LUMINANCE_WEIGHTS

__all__ = ["LIBRARY", "TORCH_PATH_COST", "GuidedKernels", "native_guided"]

#: What the torch path costs instead, quoted in the warnings. Measured at 1920 x 1080, radius 2,
#: 2 threads, on a shared 2-core machine: 7.7 s of CPU time against 0.22 s.
TORCH_PATH_COST = "the guided filter runs about 30x slower on the CPU at 1080p"
_SYMBOLS = ("bnerr_guided",)


@dataclass(frozen=True)
class GuidedKernels:
    """The bound C function of one loaded library (``why`` says where it came from)."""

    guided: Callable[..., int]
    why: str


def _bind(library: ctypes.CDLL, why: str) -> GuidedKernels:
    """Bind ``bnerr_guided``; AttributeError if the library lacks it."""
    p, i64, f32 = ctypes.c_void_p, ctypes.c_int64, ctypes.c_float
    guided = library.bnerr_guided
    guided.argtypes = [p, p, p, p, i64, i64, i64, *[f32] * 7, ctypes.c_int]
    guided.restype = ctypes.c_int
    return GuidedKernels(guided, why)


#: The library of ``guided.c``: ``LIBRARY.load()`` gives the bound :class:`GuidedKernels`
#: (building them on first use) or None, ``LIBRARY.status()`` says where they came from or why not.
LIBRARY = native.library(__package__, "guided.c", _bind, _SYMBOLS, TORCH_PATH_COST)


def native_guided(
    kernels: GuidedKernels,
    color: torch.Tensor,
    albedo: torch.Tensor,
    normal: torch.Tensor,
    radius: int,
    eps: float,
    threads: int = 1,
) -> torch.Tensor | None:
    """The guided filter in C on CPU float32 ``[3, H, W]`` color, albedo and normal; None when
    the kernel refuses (sizes, memory) or finds a value above 1e18 (the float64 switch of
    :func:`denoisers.filters.guided_filter` applies).

    The guide's luminance channel is computed in C from ``color / scale``, ``scale`` the frame's
    mean color (at least 1e-6), as :func:`bnerr.color.luminance` computes it. The scalars are
    rounded to float32 as torch rounds a Python number applied to a float32 tensor: ``eps``,
    the pivot floor ``eps / 2``, ``1 / (2 radius + 1)^2`` and the luminance weights.
    """
    planes = [t.contiguous() for t in (albedo, normal, color)]
    scale = float(planes[2].mean().clamp_min(1e-6))
    _, h, w = color.shape
    out = torch.empty((3, h, w), dtype=torch.float32)
    k = 2 * radius + 1
    code = kernels.guided(
        *(t.data_ptr() for t in planes), out.data_ptr(), h, w, radius,
        eps, 0.5 * eps, 1.0 / (k * k), scale, *LUMINANCE_WEIGHTS, max(1, min(64, int(threads))),
    )  # fmt: skip
    return out if code == 0 else None
