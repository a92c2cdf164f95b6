"""Classic image filters as denoisers: kornia's five, and the edge-avoiding a-trous filter of SVGF.

Each filter is a pure function over tensors (``color [3, H, W]`` plus the guides it reads, all on
one device, float32) and a thin :class:`~denoisers.base.Denoiser` class that stores its parameters
and reads the buffers from a Frame.

Parameters are not chosen here: :mod:`denoisers.tuning` picks them per scene and spp on
white-noise renders, and the benchmark then uses them unchanged for every strategy. The defaults
below are only reasonable starting points for a 4 spp frame.

Borders are padded by replication everywhere, so every filter works on any image size (a
reflection pad must be narrower than the image).

Native kernels: this module owns their dispatch and checks, as :mod:`bnerr.permute` owns its
kernel's. CPU float32 inputs of the a-trous, (joint) bilateral and guided filters go to the C
kernels of :mod:`denoisers.native` once each kernel has matched its torch path here
(:func:`atrous_torch`, :func:`bilateral_torch`, :func:`guided_torch`) on a self-check, run once
per loaded library; CUDA, float64, a missing compiler or ``BNERR_NATIVE=0`` run the torch paths.

What these filters are not: production denoisers. They are the range of classical behaviours the
benchmark needs, from a linear low-pass (which removes most of a blue-noise error and little of a
white one) to feature-guided filters (which may not care how the error is distributed).
"""

from __future__ import annotations

import math

import kornia.filters as KF
import torch
import torch.nn.functional as F

from bnerr.color import LUMINANCE_WEIGHTS, luminance
from bnerr.errors import (
    ValueRangeError,
    check_memory,
    check_positive_int,
    check_range,
    check_shape,
)
from bnerr.frame import Frame
from bnerr.native import SelfCheckedKernels
from denoisers import native
from denoisers.base import Denoiser

__all__ = [
    "ATrous",
    "Bilateral",
    "Gaussian",
    "Guided",
    "JointBilateral",
    "Median",
    "atrous_filter",
    "atrous_native",
    "atrous_planes",
    "atrous_torch",
    "bilateral_filter",
    "bilateral_torch",
    "gaussian_filter",
    "guided_bytes",
    "guided_filter",
    "guided_torch",
    "joint_bilateral_filter",
    "median_bytes",
    "median_filter",
]

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


# ----------------------------------------------------------------------------------------------
# Pure functions. Inputs are [C, H, W] tensors on one device; no checks (the classes check).
# ----------------------------------------------------------------------------------------------


def gaussian_filter(color: torch.Tensor, sigma: float) -> torch.Tensor:
    """Isotropic Gaussian blur of ``color [3, H, W]``, truncated at 3 sigma.

    The linear low-pass the project's claim is about: it removes the high frequencies where a
    blue-noise error lives. Blurs across edges, so it also biases the image.
    """
    k = _odd(3.0 * sigma)
    return KF.gaussian_blur2d(color[None], (k, k), (sigma, sigma), border_type=_BORDER)[0]


def bilateral_filter(color: torch.Tensor, sigma_color: float, sigma_space: float) -> torch.Tensor:
    """Bilateral filter of ``color [3, H, W]`` with its own color as the range guide.

    Tomasi & Manduchi 1998. ``sigma_color`` is relative to the frame's mean color (mean over
    pixels and channels), so that one value means the same on a dark and on a bright scene; the
    spatial kernel is a Gaussian of ``sigma_space`` pixels truncated at 2 sigma. The range kernel
    uses the L2 distance between RGB values.

    Not for HDR fireflies: a pixel far brighter than its neighbours finds no similar neighbour
    and is kept as it is. That is the textbook behaviour, kept on purpose.

    Computed as kornia's ``bilateral_blur``; on CPU float32 tensors by the native kernel of
    :mod:`denoisers.native.filters`, which agrees with kornia within float32 rounding (about 10
    times faster at 1080p).
    """
    k = _odd(2.0 * sigma_space)
    # Filtering color / mean and multiplying back equals a range sigma of sigma_color * mean.
    scale = color.mean().clamp_min(1e-6)
    return _bilateral(color / scale, None, k, sigma_color, sigma_space) * scale


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
    args = ((kernel_size, kernel_size), sigma_color, (sigma_space, sigma_space))
    options = {"border_type": _BORDER, "color_distance_type": "l2"}
    if guide is None:
        return KF.bilateral_blur(image[None], *args, **options)[0]
    return KF.joint_bilateral_blur(image[None], guide[None], *args, **options)[0]


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


def _relative(color: torch.Tensor) -> torch.Tensor:
    """``color / mean(color)``: the color in units of the frame's mean (scale-free range terms)."""
    return color / color.mean().clamp_min(1e-6)


def joint_bilateral_filter(
    color: torch.Tensor,
    albedo: torch.Tensor,
    normal: torch.Tensor,
    sigma_space: float,
    sigma_feature: float,
    sigma_color: float,
) -> torch.Tensor:
    """Cross bilateral filter of ``color [3, H, W]`` guided by ``albedo``, ``normal`` and color.

    The cross (joint) bilateral filter of Eisemann & Durand 2004 and Petschnigg et al. 2004 with
    the range terms Monte Carlo denoisers use (Li, Wu & Chuang 2012, "SURE-based Optimization for
    Adaptive Sampling and Reconstruction", section 5): the weight of neighbour q is
    ``exp(-|p - q|^2 / 2 sigma_space^2 - |f_p - f_q|^2 / 2 sigma_feature^2
    - |c_p - c_q|^2 / 2 sigma_color^2)`` with f the 6 albedo and normal channels (nearly
    noise-free) and c the noisy color in units of the frame's mean color (as in
    :func:`bilateral_filter`).

    Why the color term: the feature buffers alone cannot tell a directly visible light from the
    surface around it (the Cornell box's light has the ceiling's albedo and normal), and
    blurring a light of radiance 17 into a ceiling of 0.5 costs more squared error than all the
    noise it removes. Shadow edges are also only in the color. A log domain for c was tried and
    measured worse on the Cornell box (1.04 times the noisy MSE at 64 x 64, 4 spp, against 0.98
    linear): it brings a partly covered light pixel close to a fully covered one.

    Implemented as kornia's ``joint_bilateral_blur`` with the guide channels divided by their
    sigmas and a unit range sigma (one L2 range kernel equals the product of the three); on CPU
    float32 tensors by the native kernel of :mod:`denoisers.native.filters` (the same weights,
    within float32 rounding, about 13 times faster at 1080p).
    """
    guide = torch.cat(
        [albedo / sigma_feature, normal / sigma_feature, _relative(color) / sigma_color]
    )
    return _bilateral(color, guide, _odd(2.0 * sigma_space), 1.0, sigma_space)


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


def _check_guided_case(kernels: native.GuidedKernels, h: int, w: int, radius: int, seed: int):
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


def median_filter(color: torch.Tensor, kernel_size: int) -> torch.Tensor:
    """Per-channel median over a ``kernel_size`` square window of ``color [3, H, W]``.

    Removes isolated fireflies well; on skewed Monte Carlo noise the median of a window is below
    its mean, so it darkens (biases) the image. That trade-off is what the tuning measures.
    """
    return KF.median_blur(color[None], (kernel_size, kernel_size), border_type=_BORDER)[0]


# B3-spline a-trous taps (Dammertz et al. 2010; SVGF uses the same 5 x 5 kernel).
_ATROUS_TAPS = (1.0 / 16.0, 1.0 / 4.0, 3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0)
# 3 x 3 Gaussian that SVGF applies to the variance before using it in the luminance weight.
_VARIANCE_BLUR = ((1 / 16, 1 / 8, 1 / 16), (1 / 8, 1 / 4, 1 / 8), (1 / 16, 1 / 8, 1 / 16))
# Window of the spatial variance estimate (SVGF uses 7 x 7 when a pixel has no temporal history).
_VARIANCE_WINDOW = 7


def _unit_normals(normal: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Normalized normals ``[3, H, W]`` and the mask ``[1, H, W]`` of pixels that hit a surface."""
    # The square root of the sum of squares, not normal.norm(dim=0): the same value within an
    # ulp, 50 times faster on the CPU (norm over the outer dimension took 0.3 s at 1080p).
    length = normal.square().sum(0, keepdim=True).sqrt()
    hit = length > 0.5  # pixel-averaged normals of a hit are close to unit length; escaped are 0
    return torch.where(hit, normal / length.clamp_min(1e-12), torch.zeros_like(normal)), hit


def _spatial_variance(lum: torch.Tensor) -> torch.Tensor:
    """Variance ``[1, H, W]`` of ``lum`` in a 7 x 7 box window (SVGF's estimate without history).

    The box sums of ``lum`` and its square are 6 + 6 in-place sums of shifted views of one
    replicate-padded copy: kornia's ``box_blur`` (two single-channel 1 x 7 and 7 x 1
    convolutions each) took 0.35 s of a 1.0 s a-trous filter at 1080p, these about a third of
    that. Same values within a few float32 ulps (another order of the same sums)."""
    r, (h, w) = _VARIANCE_WINDOW // 2, lum.shape[1:]
    padded = F.pad(torch.cat([lum, lum.square()])[None], (r, r, r, r), mode=_BORDER)[0]
    rows = padded[:, :, 0:w].clone()
    for i in range(1, _VARIANCE_WINDOW):
        rows += padded[:, :, i : i + w]
    box = rows[:, 0:h].clone()
    for i in range(1, _VARIANCE_WINDOW):
        box += rows[:, i : i + h]
    box *= 1.0 / _VARIANCE_WINDOW**2
    return (box[1:2] - box[0:1].square()).clamp_min_(0.0)


# Edge-stopping weights below exp(-80) are set to exp(-80) (1.8e-35, a normal float32): exp and log
# of values that would give subnormals or -inf run 10-30 times slower on x86, and a weight that
# small changes no output value (the centre tap's weight is at least 9/64).
_ATROUS_MIN_LOG_WEIGHT = -80.0
# Rows per strip of one a-trous pass: the per-tap buffers of a strip stay in the CPU's caches.
_ATROUS_ROWS = 128


# The luminance weights and the 3 x 3 variance blur, as the native a-trous kernel takes them.
_ATROUS_CONSTANTS = (LUMINANCE_WEIGHTS, _VARIANCE_BLUR)


def _normal_floor(sigma_normal: float) -> float:
    """The smallest cosine whose log the normal weight takes: cos^sigma_normal below exp(-80) is
    clamped there anyway, and the floor keeps log away from 0 (sigma_normal 0: SVGF's 0^0 = 1
    between surfaces, 0 between surface and sky, computed without a log)."""
    return max(math.exp(_ATROUS_MIN_LOG_WEIGHT / sigma_normal), 1e-37) if sigma_normal else 0.0


def _atrous_taps(step: int) -> list[tuple[int, int, float]]:
    """``(dy, dx, kernel weight)`` of the 25 taps of a pass with hole spacing ``step``."""
    return [
        ((iy - 2) * step, (ix - 2) * step, hy * hx)
        for iy, hy in enumerate(_ATROUS_TAPS)
        for ix, hx in enumerate(_ATROUS_TAPS)
    ]


def _atrous_step(
    color: torch.Tensor,
    variance: torch.Tensor,
    normal4: torch.Tensor,
    depth: torch.Tensor,
    depth_width: torch.Tensor,
    step: int,
    sigmas: tuple[float, float, float],
) -> tuple[torch.Tensor, torch.Tensor]:
    """One edge-avoiding a-trous pass with hole spacing ``step``; returns (color, variance).

    ``normal4 [4, H, W]``: the unit normal and a 4th channel, 1.0 where the ray escaped (normal
    0) and 0.0 on a surface, so that ``normal4_p . normal4_q`` is the cosine between two surfaces,
    1 between two escaped pixels and 0 between one of each: one dot product gives SVGF's normal
    weight and keeps the background apart. ``sigmas``: (color, normal, depth).
    """
    _, h, w = color.shape
    sigma_color, sigma_normal, sigma_depth = sigmas
    kernel = torch.tensor(_VARIANCE_BLUR, device=color.device, dtype=color.dtype)
    var_blur = F.conv2d(F.pad(variance[None], (1, 1, 1, 1), mode=_BORDER), kernel[None, None])[0]
    lum = luminance(color, keepdim=True, dtype=None)
    inv_lum = (sigma_color * var_blur.sqrt() + 1e-6).reciprocal_()
    phi_depth = sigma_depth * depth_width
    # One padded copy of everything the taps read; each tap is then a view (a slice), not a copy.
    r = 2 * step
    stacked = torch.cat([color, lum, variance, normal4, depth])[None]
    padded = F.pad(stacked, (r, r, r, r), mode=_BORDER)[0]
    out_color, out_var = torch.empty_like(color), torch.empty_like(variance)
    for y0 in range(0, h, _ATROUS_ROWS):
        rows = slice(y0, min(h, y0 + _ATROUS_ROWS))
        inputs = (lum[:, rows], depth[:, rows], normal4[:, rows], inv_lum[:, rows])
        views = padded[:, y0 : rows.stop + 2 * r]
        out_color[:, rows], out_var[:, rows] = _atrous_strip(
            views, inputs, phi_depth[:, rows], step, w, sigma_normal
        )
    return out_color, out_var


def _atrous_strip(
    padded: torch.Tensor,
    inputs: tuple[torch.Tensor, ...],
    phi_depth: torch.Tensor,
    step: int,
    w: int,
    sigma_normal: float,
) -> tuple[torch.Tensor, torch.Tensor]:
    """The 25 taps of one pass over one strip of rows, accumulated in place.

    ``padded [10, rows + 4 step, W + 4 step]``: color, luminance, variance, normal4, depth of the
    strip and its border; ``inputs``: the strip's own luminance, depth, normal4 and
    ``1 / phi_luminance``. Per tap the weight is one exp:
    ``h * exp(sigma_normal * log(n_p . n_q) - |l_p - l_q| / phi_l - |z_p - z_q| / phi_z)``.
    """
    lum, depth, normal4, inv_lum = inputs
    r = 2 * step
    sum_c = torch.zeros((3, *lum.shape[1:]), device=lum.device, dtype=lum.dtype)
    sum_v, sum_w = torch.zeros_like(lum), torch.zeros_like(lum)
    e, t, wt = torch.empty_like(lum), torch.empty_like(lum), torch.empty_like(lum)
    floor = _normal_floor(sigma_normal)
    inv_depth: dict[float, torch.Tensor] = {}
    for dy, dx, hw in _atrous_taps(step):
        q = padded[:, r + dy : r + dy + lum.shape[1], r + dx : r + dx + w]
        # SVGF's shader scales the depth tolerance by the tap distance in units of the hole
        # spacing and by the step, i.e. by the distance in pixels.
        dist = math.hypot(dy, dx)
        if dist not in inv_depth:
            inv_depth[dist] = (phi_depth * dist + 1e-6).reciprocal_()
        torch.sub(q[3:4], lum, out=e).abs_().mul_(inv_lum)
        e.addcmul_(torch.sub(q[9:10], depth, out=t).abs_(), inv_depth[dist])
        if sigma_normal:
            torch.mul(q[5:6], normal4[0:1], out=wt)
            for k in (1, 2, 3):
                wt.addcmul_(q[5 + k : 6 + k], normal4[k : k + 1])
            wt.clamp_min_(floor).log_().mul_(sigma_normal).sub_(e)
        else:
            torch.sub(q[8:9], normal4[3:4], out=wt).abs_().mul_(_ATROUS_MIN_LOG_WEIGHT).sub_(e)
        wt.clamp_min_(_ATROUS_MIN_LOG_WEIGHT).exp_().mul_(hw)
        sum_w += wt
        sum_c.addcmul_(wt, q[0:3])
        sum_v.addcmul_(wt.square_(), q[4:5])
    # The center tap has weight 3/8 * 3/8 * 1 * 1 (or more), so sum_w is never 0.
    return sum_c.div_(sum_w), sum_v.div_(sum_w.square_())


def atrous_filter(
    color: torch.Tensor,
    normal: torch.Tensor,
    depth: torch.Tensor,
    iterations: int = 5,
    sigma_color: float = 4.0,
    sigma_normal: float = 128.0,
    sigma_depth: float = 1.0,
    variance: torch.Tensor | None = None,
) -> torch.Tensor:
    """Edge-avoiding a-trous wavelet filter: the spatial part of SVGF.

    Dammertz, Sewtz, Hanika & Lensch 2010, "Edge-Avoiding A-Trous Wavelet Transform for fast
    Global Illumination Filtering" (HPG), with the edge-stopping functions of Schied et al. 2017,
    "Spatiotemporal Variance-Guided Filtering" (HPG), section 4.4:

    - ``iterations`` passes of the 5 x 5 B3-spline kernel with hole spacing 1, 2, 4, ...;
    - weights ``w_n = max(0, n_p . n_q)^sigma_normal``,
      ``w_z = exp(-|z_p - z_q| / (sigma_depth |grad z| |p - q|))``,
      ``w_l = exp(-|l_p - l_q| / (sigma_color sqrt(g3x3(Var l_p))))``;
    - the luminance variance is filtered along with the color (squared weights).

    Shapes: ``color``, ``normal`` ``[3, H, W]``, ``depth [1, H, W]``, ``variance [H, W]`` or
    None -> ``[3, H, W]``.

    ``variance`` is the initial luminance variance per pixel, e.g. SVGF's temporal estimate from
    accumulated moments (:class:`denoisers.temporal.SVGF`); its NaN entries, and all pixels when
    it is None, take the spatial estimate SVGF falls back on for pixels without history (here a
    plain 7 x 7 box window, not SVGF's bilateral one). With None the filter sees one frame alone.

    What differs from SVGF besides: the depth gradient is the larger of the central differences
    in x and y. And no albedo demodulation:
    SVGF filters ``color / albedo`` and multiplies back, which needs the directly visible emission
    in a buffer of its own and an albedo that describes the whole pixel. Our frames have neither:
    emitters, pixels that straddle an edge and pixels seen through a medium carry radiance that
    their (first-surface, pixel-averaged) albedo does not modulate, and dividing by it spread
    that radiance, amplified, into the neighbours (measured: 130 times the noisy MSE on the
    ``medium`` scene, against 0.5 without demodulation).

    Values a renderer legitimately writes: ``+inf`` depth is background, and a firefly above
    1e18 switches to float64 (see :class:`ATrous`). CPU float32 tensors run the native kernel of
    :mod:`denoisers.native.filters` (the same within float32 rounding, 6-15 times faster at 1080p).

    Raises:
        ShapeError: ``variance`` is not ``[H, W]``.
        ValueRangeError: ``variance`` holds a negative or infinite entry (NaN is allowed).
    """
    if variance is not None:
        _check_variance(variance, color)
    depth = torch.where(torch.isposinf(depth), torch.zeros_like(depth), depth)
    sigmas = (sigma_color, sigma_normal, sigma_depth)
    if _needs_float64(color, depth):
        wide_var = None if variance is None else variance.double()
        wide = _atrous(
            color.double(), normal.double(), depth.double(), iterations, *sigmas, wide_var
        )
        return wide.to(color.dtype)
    return _atrous(color, normal, depth, iterations, *sigmas, variance)


def _check_variance(variance: torch.Tensor, color: torch.Tensor) -> None:
    """Refuse an initial variance that is not ``[H, W]`` of ``color``, or negative, or infinite."""
    check_shape(variance, f"{color.shape[1]} {color.shape[2]}", "atrous_filter: variance")
    bad = ~(torch.isnan(variance) | ((variance >= 0) & torch.isfinite(variance)))
    if bool(bad.any()):
        first = [int(i) for i in bad.nonzero()[0]]
        raise ValueRangeError(
            f"atrous_filter: variance: expected values >= 0 and finite (or NaN: spatial "
            f"estimate), got {int(bad.sum())} others, first {float(variance[tuple(first)])} at "
            f"pixel (y, x) = ({first[0]}, {first[1]})"
        )


def _atrous(
    color: torch.Tensor,
    normal: torch.Tensor,
    depth: torch.Tensor,
    iterations: int,
    sigma_color: float,
    sigma_normal: float,
    sigma_depth: float,
    initial: torch.Tensor | None = None,
) -> torch.Tensor:
    """:func:`atrous_filter` on finite inputs whose squares fit their dtype: the native kernel on
    CPU float32 tensors once it passed :func:`_check_atrous`, else :func:`atrous_torch`."""
    sigmas = (sigma_color, sigma_normal, sigma_depth)
    kernels = _native_atrous() if native.eligible(color, normal, depth) else None
    planes = atrous_planes(color, normal, depth, initial, kernels)
    if kernels is not None:
        threads = native.threads_for(color.shape[1] * color.shape[2])
        out = atrous_native(kernels, planes, iterations, sigmas, threads)
        if out is not None:
            return out
    return atrous_torch(planes, iterations, sigmas)


def atrous_planes(
    color: torch.Tensor,
    normal: torch.Tensor,
    depth: torch.Tensor,
    initial: torch.Tensor | None,
    kernels: native.FilterKernels | None = None,
) -> tuple[torch.Tensor, ...]:
    """What every pass of the a-trous filter reads, from ``color``, ``normal [3, H, W]``, finite
    ``depth [1, H, W]`` and the initial variance ``[H, W]`` or None: ``(color, variance [1, H, W],
    normal4 [4, H, W], depth, depth_width [1, H, W])`` (see :func:`_atrous_step`); the input of
    both :func:`atrous_torch` and :func:`atrous_native`. With ``kernels`` (CPU float32 inputs)
    the spatial variance is the native kernel's (within a few ulps of :func:`_spatial_variance`,
    a third of the torch path's time)."""
    unit, hit = _unit_normals(normal)
    normal4 = torch.cat([unit, (~hit).to(color.dtype)])
    padded = F.pad(depth[None], (1, 1, 1, 1), mode=_BORDER)[0]
    gy = (padded[:, 2:, 1:-1] - padded[:, :-2, 1:-1]).abs() * 0.5
    gx = (padded[:, 1:-1, 2:] - padded[:, 1:-1, :-2]).abs() * 0.5
    depth_width = torch.maximum(gx, gy)
    variance = None
    if kernels is not None:
        threads = native.threads_for(color.shape[1] * color.shape[2])
        radius = _VARIANCE_WINDOW // 2
        variance = native.native_luminance_variance(
            kernels, color, radius, LUMINANCE_WEIGHTS, threads
        )
    if variance is None:
        variance = _spatial_variance(luminance(color, keepdim=True, dtype=None))
    if initial is not None:
        variance = torch.where(torch.isnan(initial), variance, initial.to(variance.dtype))
    return color, variance, normal4, depth, depth_width


def atrous_torch(
    planes: tuple[torch.Tensor, ...], iterations: int, sigmas: tuple[float, float, float]
) -> torch.Tensor:
    """The torch path of the a-trous filter, the native kernel's twin: ``iterations`` calls of
    :func:`_atrous_step` on :func:`atrous_planes`' output; ``sigmas``: (color, normal, depth).
    Returns the filtered color ``[3, H, W]``."""
    color, variance, normal4, depth, depth_width = planes
    for i in range(iterations):
        color, variance = _atrous_step(color, variance, normal4, depth, depth_width, 2**i, sigmas)
    return color


def atrous_native(
    kernels: native.FilterKernels,
    planes: tuple[torch.Tensor, ...],
    iterations: int,
    sigmas: tuple[float, float, float],
    threads: int,
) -> torch.Tensor | None:
    """:func:`atrous_torch` by the native kernel (``native.FILTERS.load()``) with this module's
    constants (the luminance weights, the variance blur, the normal weight's floor); CPU float32
    planes only. None when the kernel refuses the sizes."""
    floor = _normal_floor(sigmas[1])
    return native.native_atrous(
        kernels, planes, iterations, sigmas, floor, _ATROUS_CONSTANTS, threads
    )


def _check_atrous(kernels: native.FilterKernels) -> bool:
    """Compare the native a-trous kernel with the torch path on a small odd-sized frame (a
    firefly, escaped pixels, a given variance; normal weights on and off), and its spatial
    variance estimate with :func:`_spatial_variance`: True if they agree within float32
    rounding."""
    gen = torch.Generator().manual_seed(16)
    color = torch.rand(3, 37, 29, generator=gen).square() * 4.0
    color[1, 9, 11] = 40.0
    normal = F.normalize(
        torch.randn(3, 37, 29, generator=gen) + torch.tensor([[[0.0]], [[0]], [[2]]]), dim=0
    )
    depth = torch.rand(1, 37, 29, generator=gen) + 1.0
    normal[:, :9, :7], depth[:, :9, :7] = 0.0, 0.0
    initial = torch.where(torch.rand(37, 29, generator=gen) < 0.5, float("nan"), 0.1)
    planes = atrous_planes(color, normal, depth, initial)
    for sigmas in ((4.0, 128.0, 1.0), (16.0, 0.0, 0.1)):
        want = atrous_torch(planes, 3, sigmas)
        got = atrous_native(kernels, planes, 3, sigmas, 2)
        if got is None or not torch.allclose(got, want, rtol=1e-4, atol=1e-5):
            return False
    spatial = native.native_luminance_variance(kernels, color, 3, LUMINANCE_WEIGHTS, 2)
    want_spatial = _spatial_variance(luminance(color, keepdim=True, dtype=None))
    return spatial is not None and torch.allclose(spatial, want_spatial, rtol=1e-4, atol=1e-6)


#: The native a-trous kernel if it loads and passes :func:`_check_atrous` (once per library).
_native_atrous = SelfCheckedKernels(
    _check_atrous, "denoisers.filters: the native a-trous filter", source=native.FILTERS
)


def median_bytes(height: int, width: int, kernel_size: int) -> int:
    """Rough peak memory of :func:`median_filter` (float32): kornia unfolds every window, ``k^2``
    values per pixel and channel, and sorts them (a second copy)."""
    return 4 * 3 * 2 * kernel_size * kernel_size * height * width


def guided_bytes(height: int, width: int, radius: int) -> int:
    """Rough peak memory of :func:`guided_filter` (float32): about 130 values per pixel of the
    image padded by ``r`` (7 guide channels: 28 guide covariances and 21 guide-color products
    and their window means, the means, the Cholesky factor and solution, box temporaries)."""
    return 4 * 130 * (height + 2 * radius) * (width + 2 * radius)


# ----------------------------------------------------------------------------------------------
# Thin classes: store and check parameters, read buffers from the frame.
# ----------------------------------------------------------------------------------------------


def _number(value: object, name: str, lo: float, hi: float) -> float:
    return float(check_range(value, name, lo, hi))


class Gaussian(Denoiser):
    """Gaussian blur of ``sigma`` pixels; see :func:`gaussian_filter`. Reads color only."""

    name = "gaussian"

    def __init__(self, sigma: float = 1.0) -> None:
        self.sigma = _number(sigma, "gaussian: sigma", 0.1, 16.0)

    def denoise(self, frame: Frame) -> torch.Tensor:
        return gaussian_filter(frame.color, self.sigma)

    def params(self) -> dict[str, float]:
        return {"sigma": self.sigma}


class Bilateral(Denoiser):
    """Bilateral filter; see :func:`bilateral_filter`. Reads color only."""

    name = "bilateral"

    def __init__(self, sigma_color: float = 1.0, sigma_space: float = 1.5) -> None:
        self.sigma_color = _number(sigma_color, "bilateral: sigma_color", 1e-3, 1e3)
        self.sigma_space = _number(sigma_space, "bilateral: sigma_space", 0.1, 16.0)

    def denoise(self, frame: Frame) -> torch.Tensor:
        return bilateral_filter(frame.color, self.sigma_color, self.sigma_space)

    def params(self) -> dict[str, float]:
        return {"sigma_color": self.sigma_color, "sigma_space": self.sigma_space}


class JointBilateral(Denoiser):
    """Cross bilateral filter guided by albedo, normal and color: :func:`joint_bilateral_filter`."""

    name = "joint_bilateral"
    requires = frozenset({"albedo", "normal"})

    def __init__(
        self, sigma_space: float = 2.0, sigma_feature: float = 0.3, sigma_color: float = 4.0
    ) -> None:
        self.sigma_space = _number(sigma_space, "joint_bilateral: sigma_space", 0.1, 16.0)
        self.sigma_feature = _number(sigma_feature, "joint_bilateral: sigma_feature", 1e-3, 1e3)
        self.sigma_color = _number(sigma_color, "joint_bilateral: sigma_color", 1e-3, 1e3)

    def denoise(self, frame: Frame) -> torch.Tensor:
        return joint_bilateral_filter(
            frame.color,
            frame.albedo,
            frame.normal,
            self.sigma_space,
            self.sigma_feature,
            self.sigma_color,
        )

    def params(self) -> dict[str, float]:
        return {
            "sigma_space": self.sigma_space,
            "sigma_feature": self.sigma_feature,
            "sigma_color": self.sigma_color,
        }


class Guided(Denoiser):
    """Guided filter with the guide ``[albedo; normal; luminance]``; see :func:`guided_filter`."""

    name = "guided"
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
        return guided_filter(frame.color, frame.albedo, frame.normal, self.radius, self.eps)

    def params(self) -> dict[str, float | int]:
        return {"radius": self.radius, "eps": self.eps}


class Median(Denoiser):
    """Per-channel median filter; see :func:`median_filter`. Reads color only."""

    name = "median"

    def __init__(self, kernel_size: int = 3) -> None:
        check_positive_int(kernel_size, "median: kernel_size", minimum=3)
        if kernel_size % 2 == 0:
            raise ValueRangeError(
                f"median: kernel_size: expected an odd integer, got {kernel_size}"
            )
        self.kernel_size = kernel_size

    def denoise(self, frame: Frame) -> torch.Tensor:
        check_memory(
            median_bytes(frame.height, frame.width, self.kernel_size),
            f"median: kernel_size {self.kernel_size} on {frame.width}x{frame.height}",
            frame.color.device,
        )
        return median_filter(frame.color, self.kernel_size)

    def params(self) -> dict[str, int]:
        return {"kernel_size": self.kernel_size}


class ATrous(Denoiser):
    """Edge-avoiding a-trous filter (spatial SVGF); see :func:`atrous_filter`.

    Values a renderer legitimately writes: a depth of ``+inf`` (how some renderers mark an
    escaped ray) is read as 0, the background depth our tracer writes; such pixels have no
    normal either, so they average only among themselves. A firefly above about 1e18 (a finite
    1e20 made the whole image NaN: its squared luminance overflows float32 in the variance)
    switches the filter to float64, whose output is returned in the input's dtype. NaN and
    ``-inf`` in color, normal or depth are refused with :class:`~bnerr.errors.NonFiniteError`.
    """

    name = "atrous"
    requires = frozenset({"depth", "normal"})
    infinite_ok = frozenset({"depth"})  # +inf depth = escaped ray; see atrous_filter

    def __init__(
        self,
        iterations: int = 5,
        sigma_color: float = 4.0,
        sigma_normal: float = 128.0,
        sigma_depth: float = 1.0,
    ) -> None:
        self.iterations = check_positive_int(iterations, "atrous: iterations")
        check_range(iterations, "atrous: iterations", 1, 10)
        self.sigma_color = _number(sigma_color, "atrous: sigma_color", 1e-3, 1e4)
        self.sigma_normal = _number(sigma_normal, "atrous: sigma_normal", 0.0, 1e4)
        self.sigma_depth = _number(sigma_depth, "atrous: sigma_depth", 1e-3, 1e4)

    def denoise(self, frame: Frame) -> torch.Tensor:
        return atrous_filter(
            frame.color,
            frame.normal,
            frame.depth,
            self.iterations,
            self.sigma_color,
            self.sigma_normal,
            self.sigma_depth,
        )

    def params(self) -> dict[str, float | int]:
        return {
            "iterations": self.iterations,
            "sigma_color": self.sigma_color,
            "sigma_normal": self.sigma_normal,
            "sigma_depth": self.sigma_depth,
        }
