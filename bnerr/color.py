"""Colour: the one home of luminance and of the preview tone map.

- :data:`LUMINANCE_WEIGHTS` and :func:`luminance`: Rec. 709 luminance of linear RGB, the sort key
  of the permutation op and the scalar every filter that needs one uses.
- :func:`tonemap`, :func:`srgb_encode` and :func:`preview_u8`: how a linear radiance image becomes
  an 8-bit sRGB preview (PNG files, crops in the benchmark's charts, animations). A preview is for
  looking at; no metric is ever computed on it.
"""

from __future__ import annotations

import numpy as np
import torch

from bnerr.errors import FLOAT_DTYPES, check_dtype, check_name, check_shape, check_tensor

__all__ = [
    "LUMINANCE_WEIGHTS",
    "TONEMAPS",
    "luminance",
    "preview_u8",
    "srgb_encode",
    "tonemap",
]

#: Rec. 709 / sRGB luminance weights of linear R, G, B (ITU-R BT.709-6, item 3.2).
LUMINANCE_WEIGHTS: tuple[float, float, float] = (0.2126, 0.7152, 0.0722)
#: Tone maps :func:`tonemap` knows.
TONEMAPS: tuple[str, ...] = ("aces", "reinhard", "clamp")


def luminance(
    values: torch.Tensor, *, keepdim: bool = False, dtype: torch.dtype | None = torch.float32
) -> torch.Tensor:
    """Rec. 709 luminance ``0.2126 R + 0.7152 G + 0.0722 B`` of linear RGB.

    Args:
        values: ``[3, H, W]`` linear RGB, ``[1, H, W]`` or ``[H, W]`` (already a scalar per pixel),
            any floating dtype.
        keepdim: return ``[1, H, W]`` (the filters stack it with other planes) instead of
            ``[H, W]`` (the sort key).
        dtype: the dtype to compute in and return; None keeps ``values``' own (the filters'
            float64 firefly switch).

    Returns:
        ``[H, W]`` (``[1, H, W]`` with ``keepdim``) on ``values``' device, computed as
        ``(w0 * R + w1 * G) + w2 * B`` in ``dtype`` (this operation order is part of the
        contract: the native sort and filter kernels repeat it bit for bit). NaN or infinite
        channels give NaN or infinite luminance.
    """
    check_tensor(values, "values")
    if values.ndim == 3 and values.shape[0] == 1:
        values = values[0]
    if values.ndim == 2:
        check_dtype(values, FLOAT_DTYPES, "values")
        lum = values if dtype is None else values.to(dtype)
    else:
        check_shape(values, "3 H W", "values")
        check_dtype(values, FLOAT_DTYPES, "values")
        rgb = values if dtype is None else values.to(dtype)
        w0, w1, w2 = LUMINANCE_WEIGHTS
        lum = w0 * rgb[0] + w1 * rgb[1] + w2 * rgb[2]
    return lum[None] if keepdim else lum


def tonemap(x: torch.Tensor, name: str = "reinhard") -> torch.Tensor:
    """A global tone map of exposed linear radiance into [0, 1].

    ``aces``: Narkowicz 2015's fit of the ACES RRT + ODT, applied as is (without the blog post's
    0.6 pre-scale); ``reinhard``: Reinhard et al. 2002's global operator ``L / (1 + L)`` per
    channel; ``clamp``: clip to [0, 1].
    """
    check_name(name, TONEMAPS, "tonemap")
    x = x.clamp_min(0.0)
    if name == "aces":
        return (x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0, 1)
    if name == "reinhard":
        return x / (1 + x)
    return x.clamp(0, 1)


def srgb_encode(x: torch.Tensor) -> torch.Tensor:
    """IEC 61966-2-1 sRGB encoding (the OETF) of linear values in [0, 1]."""
    curve = 1.055 * x.clamp(min=0.0031308) ** (1 / 2.4) - 0.055
    return torch.where(x <= 0.0031308, 12.92 * x, curve)


def preview_u8(color: torch.Tensor, exposure: float = 0.0, name: str = "reinhard") -> np.ndarray:
    """``[3, H, W]`` linear radiance -> ``[H, W, 3]`` uint8 sRGB: ``srgb(tonemap(c * 2^exposure))``.

    NaN becomes 0. Computed in float32 on the CPU, rounded to nearest.
    """
    check_shape(check_tensor(color, "color"), "3 H W", "color")
    linear = color.detach().to("cpu", torch.float32).nan_to_num(0.0) * 2.0**exposure
    encoded = srgb_encode(tonemap(linear, name).clamp(0, 1))
    return (encoded.permute(1, 2, 0).numpy() * 255.0 + 0.5).astype(np.uint8)
