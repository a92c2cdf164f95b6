"""The guided filter (He, Sun & Tang 2010) with a feature guide: :func:`guided_filter`, its torch
twin :func:`guided_torch`, the native kernel's dispatch and self-check, its memory estimate and
its class.

Not for: the kernel itself (:mod:`denoisers.native.guided` binds the C code), or a guide other
than ``[albedo; normal; luminance]``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import ClassVar

import torch
import torch.nn.functional as F

from bnerr.color import luminance
from bnerr.errors import check_memory, check_positive_int
from bnerr.frame import Frame
from bnerr.native import SelfCheckedKernels
from denoisers import native
from denoisers.base import Denoiser, required
from denoisers.filters.common import _BORDER, _needs_float64, _number, _relative

__all__ = ["Guided", "guided_bytes", "guided_filter", "guided_torch"]


def guided_filter(
    color: torch.Tensor,
    albedo: torch.Tensor,
    normal: torch.Tensor,
    radius: int,
    eps: float,
) -> torch.Tensor:
    """Guided filter (He, Sun & Tang 2010) of ``color [3, H, W]``, guide ``[albedo; normal; lum]``.

    In each ``(2 radius + 1)^2`` window the output is an affine function of the 7-channel guide
    fitted to the noisy color by ridge regression (``eps`` regularises, in squared guide units).
    With albedo in the guide, a texture multiplied by smooth lighting is reproduced instead of
    blurred; this is the feature-guided filtering of Bauszat, Eisemann & Magnor 2011 ("Guided
    Image Filtering for Interactive High-quality Global Illumination"). The seventh channel, the
    luminance of the noisy color in units of the frame's mean, lets the fit follow what the
    features do not show (lights seen directly, shadow edges); where it varies only by noise, its
    variance is below ``eps`` and the ridge term keeps its coefficient small.

    Computed as kornia's ``guided_blur`` (replicate border) computes it, but with separable box
    sums over shifted views, the 28 distinct guide covariances (not 49) and a Cholesky solve of
    the 7 x 7 system per pixel written as tensor ops over all pixels at once (a batched
    ``linalg.solve`` spends microseconds per pixel). Outputs agree within float32 rounding.

    Fireflies: the window statistics multiply color by the guide, which overflows float32 for
    a pixel above about 1e18 (the output was NaN); such a frame is filtered in float64 and
    returned in the input's dtype.

    On the CPU in float32 a C kernel computes the same statistics and solve (within 3e-7 of the
    largest output value: another summation order, no fused multiply-add) about 30 times faster
    (:mod:`denoisers.native.guided`, once it passed :func:`_check_guided`); elsewhere, or without
    a C compiler, the torch path (:func:`guided_torch`) runs.
    """
    out = _guided_native(color, albedo, normal, radius, eps)
    if out is not None:
        return out
    if _needs_float64(color, albedo, normal):
        wide = guided_filter(color.double(), albedo.double(), normal.double(), radius, eps)
        return wide.to(color.dtype)
    return guided_torch(color, albedo, normal, radius, eps)


def guided_torch(
    color: torch.Tensor, albedo: torch.Tensor, normal: torch.Tensor, radius: int, eps: float
) -> torch.Tensor:
    """The torch path of :func:`guided_filter`, the native kernel's twin (no float64 switch): the
    same arguments and result."""
    lum = luminance(_relative(color), keepdim=True, dtype=None)
    guide = torch.cat([albedo, normal, lum])
    n = guide.shape[0]
    iu = torch.triu_indices(n, n, device=color.device)
    products = torch.cat([guide[iu[0]] * guide[iu[1]], (guide[:, None] * color).flatten(0, 1)])
    mean_i, mean_p = _box_mean(guide, radius), _box_mean(color, radius)
    corr_ii, corr_ip = _box_mean(products, radius).split((iu.shape[1], 3 * n))
    var = corr_ii.addcmul_(mean_i[iu[0]], mean_i[iu[1]], value=-1)
    var[iu[0] == iu[1]] += eps
    cov = corr_ip.unflatten(0, (n, 3)).addcmul_(mean_i[:, None], mean_p, value=-1)
    # var + eps I is at least eps I in exact arithmetic: every Cholesky pivot is >= eps.
    a = _solve_spd(var, cov, n, 0.5 * eps)
    b = mean_p - (a * mean_i[:, None]).sum(0)
    mean_a, mean_b = _box_mean(torch.cat([a.flatten(0, 1), b]), radius).split((3 * n, 3))
    return (mean_a.unflatten(0, (n, 3)) * guide[:, None]).sum(0) + mean_b


# Channels box-filtered at once by _box_mean: bounds its temporaries to a few planes.
_BOX_CHANNELS = 8


def _box_mean(x: torch.Tensor, radius: int) -> torch.Tensor:
    """Mean of ``x [C, H, W]`` over a ``(2 radius + 1)^2`` window, replicate border (separable)."""
    k = 2 * radius + 1
    h, w = x.shape[1:]
    out = torch.empty_like(x)
    for c0 in range(0, x.shape[0], _BOX_CHANNELS):
        chunk = x[c0 : c0 + _BOX_CHANNELS]
        padded = F.pad(chunk[None], (radius, radius, radius, radius), mode=_BORDER)[0]
        rows = padded[:, :h].clone()
        for d in range(1, k):
            rows += padded[:, d : d + h]
        cols = out[c0 : c0 + _BOX_CHANNELS]
        cols.copy_(rows[:, :, :w])
        for d in range(1, k):
            cols += rows[:, :, d : d + w]
    return out.mul_(1.0 / (k * k))


def _solve_spd(packed: torch.Tensor, rhs: torch.Tensor, n: int, floor: float) -> torch.Tensor:
    """Solve ``A x = rhs`` per pixel by Cholesky, ``A`` symmetric positive definite ``n x n``.

    ``packed [n (n + 1) / 2, H, W]``: the upper triangle of ``A`` row by row (the order of
    ``torch.triu_indices``); ``rhs [n, m, H, W]`` -> ``x [n, m, H, W]``. Pivots below ``floor``
    (rounding of a matrix whose exact pivots are larger) are raised to it.
    """
    index = {}
    for slot, (i, j) in enumerate(zip(*torch.triu_indices(n, n).tolist())):
        index[i, j] = index[j, i] = slot
    low: dict[tuple[int, int], torch.Tensor] = {}
    inv_diag = []
    for j in range(n):
        pivot = packed[index[j, j]].clone()
        for k in range(j):
            pivot.addcmul_(low[j, k], low[j, k], value=-1)
        inv_diag.append(pivot.clamp_min_(floor).rsqrt_())
        for i in range(j + 1, n):
            entry = packed[index[i, j]].clone()
            for k in range(j):
                entry.addcmul_(low[i, k], low[j, k], value=-1)
            low[i, j] = entry.mul_(inv_diag[j])
    x = rhs.clone()
    for i in range(n):  # L y = rhs
        for k in range(i):
            x[i].addcmul_(low[i, k], x[k], value=-1)
        x[i].mul_(inv_diag[i])
    for i in reversed(range(n)):  # L^T x = y
        for k in range(i + 1, n):
            x[i].addcmul_(low[k, i], x[k], value=-1)
        x[i].mul_(inv_diag[i])
    return x


# Self-check tolerance of the guided kernel, relative to the largest output value. Measured on the
# check's inputs: below 3e-7; the systems there (eps 1e-2 to 1) have condition numbers below 1e3,
# so a few roundings of 6e-8 in the window sums move the output by at most about 1e-5. A wrong
# kernel errs by the size of the values.
_GUIDED_CHECK_TOLERANCE = 1e-5


def _check_guided_case(
    kernels: native.GuidedKernels, h: int, w: int, radius: int, seed: int
) -> bool:
    """One case of :func:`_check_guided`: random inputs with a firefly and a flat guide region."""
    g = torch.Generator().manual_seed(seed)
    color = torch.rand(3, h, w, generator=g).square() * 4.0
    color[0, h // 2, w // 3] = 60.0
    albedo = torch.rand(3, h, w, generator=g)
    albedo[:, :, : w // 4] = 0.5
    normal = F.normalize(torch.randn(3, h, w, generator=g), dim=0)
    eps = (1e-2, 1.0, 0.1)[seed % 3]
    want = guided_torch(color, albedo, normal, radius, eps)
    tolerance = _GUIDED_CHECK_TOLERANCE * float(want.abs().amax())
    for threads in (1, 3):
        got = native.native_guided(kernels, color, albedo, normal, radius, eps, threads)
        if got is None or not bool(((got - want).abs() <= tolerance).all()):
            return False
    return True


def _check_guided(kernels: native.GuidedKernels) -> bool:
    """Compare the native guided kernel with :func:`guided_torch`: odd sizes, two tiles (of 256
    columns), a radius larger than the image. True if they agree within
    :data:`_GUIDED_CHECK_TOLERANCE`."""
    cases = ((9, 300, 2, 0), (5, 6, 4, 2))
    return all(_check_guided_case(kernels, *case) for case in cases)


#: The native guided kernel if it loads and passes :func:`_check_guided` (once per library).
_native_guided = SelfCheckedKernels(
    _check_guided, "denoisers.filters: the native guided filter", source=native.GUIDED
)


def _guided_native(
    color: torch.Tensor, albedo: torch.Tensor, normal: torch.Tensor, radius: int, eps: float
) -> torch.Tensor | None:
    """The guided filter by the native kernel, or None where the torch path must run instead:
    a tensor not on the CPU or not float32, the kernel unavailable or failing its self-check,
    refusing the sizes, or a value above 1e18 (the float64 switch)."""
    kernels = _native_guided() if native.eligible(color, albedo, normal) else None
    if kernels is None:
        return None
    threads = native.threads_for(color.shape[1] * color.shape[2])
    return native.native_guided(kernels, color, albedo, normal, radius, eps, threads)


def guided_bytes(height: int, width: int, radius: int) -> int:
    """Rough peak memory of :func:`guided_filter` (float32): about 130 values per pixel of the
    image padded by ``r`` (7 guide channels: 28 guide covariances and 21 guide-color products
    and their window means, the means, the Cholesky factor and solution, box temporaries)."""
    return 4 * 130 * (height + 2 * radius) * (width + 2 * radius)


class Guided(Denoiser):
    """Guided filter with the guide ``[albedo; normal; luminance]``; see :func:`guided_filter`."""

    name = "guided"
    grid: ClassVar[Mapping[str, Sequence[object]]] = {
        "eps": (1e-2, 1e-1, 1.0, 10.0),
        "radius": (1, 2, 3, 5),
    }
    requires = frozenset({"albedo", "normal"})

    def __init__(self, radius: int = 2, eps: float = 1.0) -> None:
        self.radius = check_positive_int(radius, "guided: radius")
        self.eps = _number(eps, "guided: eps", 1e-8, 1e3)

    def denoise(self, frame: Frame) -> torch.Tensor:
        check_memory(
            guided_bytes(frame.height, frame.width, self.radius),
            f"guided: radius {self.radius} on {frame.width}x{frame.height}",
            frame.color.device,
        )
        return guided_filter(
            frame.color, required(frame, "albedo"), required(frame, "normal"), self.radius, self.eps
        )

    def params(self) -> dict[str, float | int | str]:
        return {"radius": self.radius, "eps": self.eps}
