"""Slow, obviously correct twins shared by several test modules (not a test module itself)."""

import math

import kornia.filters as KF
import torch
import torch.nn.functional as F

M32 = (1 << 32) - 1


def lowbias32(x: int) -> int:
    """Wellons' lowbias32 on a Python int's low 32 bits, written from its published listing."""
    x &= M32
    x ^= x >> 16
    x = (x * 0x7FEB352D) & M32
    x ^= x >> 15
    x = (x * 0x846CA68B) & M32
    return x ^ (x >> 16)


M64 = (1 << 64) - 1


def mix_bits(v: int) -> int:
    """pbrt-v4's ``MixBits`` on a 64-bit word."""
    v ^= v >> 31
    v = (v * 0x7FB5D329728EA185) & M64
    v ^= v >> 27
    v = (v * 0x81DADEF4BC2DD44D) & M64
    return v ^ (v >> 33)


def pbrt_hash(e: int, seed: int) -> int:
    """pbrt-v4's ``Hash(e, seed)`` of two 32-bit words: MurmurHash64A over their 8 bytes."""
    m = 0xC6A4A7935BD1E995
    k = ((seed & M32) << 32) | (e & M32)
    k = (k * m) & M64
    k ^= k >> 47
    k = (k * m) & M64
    h = (0 ^ (8 * m)) & M64
    h = ((h ^ k) * m) & M64
    h ^= h >> 47
    h = (h * m) & M64
    return h ^ (h >> 47)


def rev32(x: int) -> int:
    """The low 32 bits of ``x`` in reverse order."""
    return int(format(x & M32, "032b")[::-1], 2)


def pbrt_sobol(a: int, dim: int) -> int:
    """pbrt-v4's 32-bit Sobol value of index ``a`` (52 bits) in dimension 0 (bit reversal) or 1
    (the Pascal-matrix dimension), as in its ZSobol sampler."""
    v = 0
    for j in range(52):
        if (a >> j) & 1:
            if dim == 0:
                v ^= (1 << (31 - j)) if j < 32 else 0
            else:
                v ^= sum(1 << (31 - i) for i in range(32) if (i & j) == i)
    return v


# -- the denoisers' filters: every constant written out from its published definition ----------
#
# These twins import nothing from denoisers.filters or bnerr.color, so that a wrong tap, window,
# weight or scale in the code under test makes the two disagree instead of passing both.

#: ITU-R BT.709-6, item 3.2: luminance of linear R, G, B.
REC709 = (0.2126, 0.7152, 0.0722)
#: The B3-spline a-trous kernel (Dammertz et al. 2010, eq. 3; SVGF's 5 x 5 filter is its outer
#: product): 1/16 [1 4 6 4 1].
B3_SPLINE = (1 / 16, 4 / 16, 6 / 16, 4 / 16, 1 / 16)
#: SVGF (Schied et al. 2017, section 4.4): the variance is prefiltered with a 3 x 3 Gaussian,
#: the binomial 1/16 [1 2 1] x [1 2 1].
GAUSS_3X3 = ((1 / 16, 2 / 16, 1 / 16), (2 / 16, 4 / 16, 2 / 16), (1 / 16, 2 / 16, 1 / 16))
#: SVGF, section 4.3: without temporal history the variance is estimated in a 7 x 7 window.
SPATIAL_WINDOW = 7
#: A pixel-averaged normal of a surface hit is close to unit length; an escaped ray's is 0.
HIT_LENGTH = 0.5


def rec709_luminance(rgb: torch.Tensor) -> torch.Tensor:
    """``[3, H, W]`` -> ``[1, H, W]``, in ``rgb``'s dtype."""
    return (REC709[0] * rgb[0] + REC709[1] * rgb[1] + REC709[2] * rgb[2])[None]


def _replicate(x: torch.Tensor, r: int) -> torch.Tensor:
    return F.pad(x[None], (r, r, r, r), mode="replicate")[0]


def spatial_variance(lum: torch.Tensor) -> torch.Tensor:
    """Variance ``[1, H, W]`` of ``lum [1, H, W]`` in a box window, replicate border."""
    r = SPATIAL_WINDOW // 2
    mean = F.avg_pool2d(_replicate(lum, r)[None], SPATIAL_WINDOW, stride=1)[0]
    mean_sq = F.avg_pool2d(_replicate(lum.square(), r)[None], SPATIAL_WINDOW, stride=1)[0]
    return (mean_sq - mean.square()).clamp_min(0.0)


def _atrous_pass(color, variance, normal, hit, depth, depth_width, step, sigmas):
    """One edge-avoiding a-trous pass (SVGF, section 4.4) with hole spacing ``step``, written one
    tensor op per quantity and tap; returns (color, variance)."""
    sigma_color, sigma_normal, sigma_depth = sigmas
    _, h, w = color.shape
    blur = torch.tensor(GAUSS_3X3, dtype=color.dtype)[None, None]
    var_blur = F.conv2d(_replicate(variance, 1)[None], blur)[0]
    lum = rec709_luminance(color)
    phi_lum = sigma_color * var_blur.sqrt() + 1e-6
    r = 2 * step
    padded = _replicate(torch.cat([color, lum, variance, normal, hit, depth]), r)
    sum_c, sum_v, sum_w = torch.zeros_like(color), torch.zeros_like(lum), torch.zeros_like(lum)
    for iy, hy in enumerate(B3_SPLINE):
        for ix, hx in enumerate(B3_SPLINE):
            dy, dx = (iy - 2) * step, (ix - 2) * step
            q = padded[:, r + dy : r + dy + h, r + dx : r + dx + w]
            q_color, q_lum, q_var, q_normal, q_hit, q_depth = q.split((3, 1, 1, 3, 1, 1))
            cos = (normal * q_normal).sum(0, keepdim=True).clamp_min(0.0)
            # Escaped pixels (no normal) average only among themselves, with weight 1.
            same = (hit == q_hit).to(cos.dtype)
            w_normal = torch.where((hit * q_hit) > 0, cos.pow(sigma_normal), same)
            # The depth tolerance grows with the tap's distance in pixels.
            dist = math.hypot(dy, dx)
            w_depth = (q_depth - depth).abs() / (sigma_depth * depth_width * dist + 1e-6)
            w_lum = (q_lum - lum).abs() / phi_lum
            weight = (hy * hx) * torch.exp(-w_lum - w_depth) * w_normal
            sum_c += weight * q_color
            sum_v += weight.square() * q_var
            sum_w += weight
    return sum_c / sum_w, sum_v / sum_w.square()


def atrous_reference(color, normal, depth, iterations, *sigmas, initial=None) -> torch.Tensor:
    """The edge-avoiding a-trous filter (Dammertz et al. 2010 with SVGF's edge-stopping
    functions) as first written (commit 2101139): ``color``, ``normal [3, H, W]``, finite
    ``depth [1, H, W]``, ``sigmas`` (color, normal, depth), ``initial [H, W]`` variance or None
    (NaN: the spatial estimate) -> ``[3, H, W]``."""
    length = normal.norm(dim=0, keepdim=True)
    hit = length > HIT_LENGTH
    unit = torch.where(hit, normal / length.clamp_min(1e-12), torch.zeros_like(normal))
    padded = _replicate(depth, 1)
    gy = (padded[:, 2:, 1:-1] - padded[:, :-2, 1:-1]).abs() * 0.5
    gx = (padded[:, 1:-1, 2:] - padded[:, 1:-1, :-2]).abs() * 0.5
    depth_width = torch.maximum(gx, gy)
    variance = spatial_variance(rec709_luminance(color))
    if initial is not None:
        variance = torch.where(torch.isnan(initial), variance, initial.to(variance.dtype))
    hit = hit.to(color.dtype)
    for i in range(iterations):
        color, variance = _atrous_pass(color, variance, unit, hit, depth, depth_width, 2**i, sigmas)
    return color


def guided_reference(color, albedo, normal, radius: int, eps: float) -> torch.Tensor:
    """The guided filter (He, Sun & Tang 2010) as first written: kornia's ``guided_blur`` with
    the guide ``[albedo; normal; luminance of color / max(mean color, 1e-6)]``, a
    ``(2 radius + 1)^2`` window and a replicate border; ``[3, H, W]`` each -> ``[3, H, W]``."""
    relative = color / color.mean().clamp_min(1e-6)
    guide = torch.cat([albedo, normal, rec709_luminance(relative)])[None]
    k = 2 * radius + 1
    return KF.guided_blur(guide, color[None], (k, k), eps, border_type="replicate")[0]
