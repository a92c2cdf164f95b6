"""The edge-avoiding a-trous wavelet filter (the spatial part of SVGF): :func:`atrous_filter`,
its planes and torch twin, the native kernel's dispatch and self-check, and its class.

:mod:`denoisers.temporal` runs :func:`atrous_filter` with SVGF's temporal variance. Not for: the
kernel itself (:mod:`denoisers.native.filters` binds the C code), or temporal accumulation.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import ClassVar

import torch
import torch.nn.functional as F

from bnerr.color import LUMINANCE_WEIGHTS, luminance
from bnerr.errors import ValueRangeError, check_positive_int, check_range, check_shape
from bnerr.frame import Frame
from bnerr.native import SelfCheckedKernels
from denoisers import native
from denoisers.base import Denoiser, required
from denoisers.filters.common import _BORDER, _needs_float64, _number

__all__ = ["ATrous", "atrous_filter", "atrous_native", "atrous_planes", "atrous_torch"]


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
    grid: ClassVar[Mapping[str, Sequence[object]]] = {
        "iterations": (1, 2, 3, 5),
        "sigma_color": (1.0, 4.0, 16.0, 64.0),
    }
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
            required(frame, "normal"),
            required(frame, "depth"),
            self.iterations,
            self.sigma_color,
            self.sigma_normal,
            self.sigma_depth,
        )

    def params(self) -> dict[str, float | int | str]:
        return {
            "iterations": self.iterations,
            "sigma_color": self.sigma_color,
            "sigma_normal": self.sigma_normal,
            "sigma_depth": self.sigma_depth,
        }
