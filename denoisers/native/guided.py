"""The guided filter's native CPU kernel (``bnerr/native/guided.c``) and its dispatch.

:func:`denoisers.filters.guided_filter` asks :func:`native_guided` first; None means "use the
torch path". The kernel is used for CPU float32 inputs only, when the library builds and loads
(:mod:`bnerr.native`: system C compiler, per-user cache, ``BNERR_NATIVE=0`` turns it off) and
once it has matched kornia's guided filter on a self-check (odd sizes, several tiles, radii up
to larger than the image, a flat guide region).

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
from dataclasses import dataclass

import kornia.filters as KF
import torch

from bnerr import native
from bnerr.color import LUMINANCE_WEIGHTS
from denoisers import native as filter_kernels

__all__ = ["Kernels", "load", "native_guided", "status"]

#: What the torch path costs instead, quoted in the warnings. Measured at 1920 x 1080, radius 2,
#: 2 threads, on a shared 2-core machine: 7.7 s of CPU time against 0.22 s.
TORCH_PATH_COST = "the guided filter runs about 30x slower on the CPU at 1080p"
_SYMBOLS = ("bnerr_guided",)
# Self-check tolerance, relative to the largest output value. Measured on the check's inputs:
# below 3e-7; the systems there (eps 1e-2 to 1) have condition numbers below 1e3, so a few
# roundings of 6e-8 in the window sums move the output by at most about 1e-5 (the bound of the
# tests against kornia). A wrong kernel errs by the size of the values.
_CHECK_TOLERANCE = 1e-5


@dataclass(frozen=True)
class Kernels:
    """The bound C function of one loaded library (``why`` says where it came from)."""

    guided: ctypes._CFuncPtr
    why: str


def _bind(library: ctypes.CDLL, why: str) -> Kernels:
    """Bind ``bnerr_guided``; AttributeError if the library lacks it."""
    p, i64, f32 = ctypes.c_void_p, ctypes.c_int64, ctypes.c_float
    guided = library.bnerr_guided
    guided.argtypes = [p, p, p, p, i64, i64, i64, *[f32] * 7, ctypes.c_int]
    guided.restype = ctypes.c_int
    return Kernels(guided, why)


_LIBRARY = native.library("guided.c", _bind, _SYMBOLS, TORCH_PATH_COST)


def load() -> Kernels | None:
    """The bound kernel, building it on first use; None when unavailable (see :func:`status`)."""
    return _LIBRARY.load()


def status() -> str:
    """Where the kernel's library came from, or why it is not used."""
    return _LIBRARY.status()


def run_kernel(
    kernels: Kernels,
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

    The guide's luminance channel is computed in C from ``color / scale`` with the scale of
    :func:`denoisers.filters._relative` (the mean color, at least 1e-6). The scalars are
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


def _reference(color, albedo, normal, radius: int, eps: float) -> torch.Tensor:
    """kornia's guided filter with the same guide and border: the check's slow, independent
    twin (``denoisers.filters`` imports this module, so its torch path cannot be the twin)."""
    scale = color.mean().clamp_min(1e-6)
    w = torch.tensor(LUMINANCE_WEIGHTS, dtype=color.dtype)
    lum = torch.einsum("chw,c->hw", color / scale, w)[None]
    guide = torch.cat([albedo, normal, lum])[None]
    k = 2 * radius + 1
    return KF.guided_blur(guide, color[None], (k, k), eps, border_type="replicate")[0]


def _check_case(kernels: Kernels, h: int, w: int, radius: int, seed: int) -> bool:
    """One self-check case: random inputs with a firefly and a flat guide region."""
    g = torch.Generator().manual_seed(seed)
    color = torch.rand(3, h, w, generator=g).square() * 4.0
    color[0, h // 2, w // 3] = 60.0
    albedo = torch.rand(3, h, w, generator=g)
    albedo[:, :, : w // 4] = 0.5
    normal = torch.nn.functional.normalize(torch.randn(3, h, w, generator=g), dim=0)
    eps = (1e-2, 1.0, 0.1)[seed % 3]
    want = _reference(color, albedo, normal, radius, eps)
    for threads in (1, 3):
        got = run_kernel(kernels, color, albedo, normal, radius, eps, threads)
        tolerance = _CHECK_TOLERANCE * float(want.abs().amax())
        if got is None or not bool(((got - want).abs() <= tolerance).all()):
            return False
    return True


def _self_check(kernels: Kernels) -> bool:
    """Compare the kernel with kornia's guided filter: odd sizes, two tiles (of 256 columns), a
    radius larger than the image. True if they agree (see :data:`_CHECK_TOLERANCE`). Two small
    cases, so that the twin's per-pixel solves stay cheap."""
    cases = ((9, 300, 2, 0), (5, 6, 4, 2))
    return all(_check_case(kernels, *case) for case in cases)


#: The kernel if it loads and passes :func:`_self_check` (run once per library).
_checked = native.SelfCheckedKernels(
    _self_check, "denoisers.guided_native: the guided filter kernel", source=_LIBRARY
)


def native_guided(
    color: torch.Tensor, albedo: torch.Tensor, normal: torch.Tensor, radius: int, eps: float
) -> torch.Tensor | None:
    """The guided filter by the native kernel, or None where the torch path must run instead:
    a tensor not on the CPU or not float32, the kernel unavailable or failing its self-check,
    refusing the sizes, or a value above 1e18 (float64). Inputs as :func:`run_kernel`'s."""
    tensors = (color, albedo, normal)
    if not filter_kernels.eligible(*tensors):
        return None
    kernels = _checked()
    if kernels is None:
        return None
    _, h, w = color.shape
    threads = filter_kernels.threads_for(h * w)
    return run_kernel(kernels, color, albedo, normal, radius, eps, threads)
