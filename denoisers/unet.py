"""A small U-Net denoiser in the spirit of Intel Open Image Denoise, trained here from scratch.

Architecture (after OIDN's ``UNet``, training/model.py of the OIDN repository; Ronneberger et al.
2015 for the U-Net): 3 x 3 convolutions with ReLU, 2 x 2 max-pooling down, nearest-neighbour
upsampling, skip connections concatenated, the last skip being the network input itself, and a
final 3 x 3 convolution without activation. The network predicts the denoised color itself (not
a filter kernel), as OIDN does, but as a correction added to its (log) input color: residual
learning (Zhang et al. 2017, "Beyond a Gaussian Denoiser", DnCNN). Measured here on the held-out
Cornell box at 64 x 64, 4 spp, after the same 1500 training steps: 0.49 times the noisy MSE with
the residual, 1.53 without (the plain network blurred the light).

Input, ``[9, H, W]``: transformed color, albedo, normal. The color transform is OIDN's recipe for
HDR input: scale by an auto-exposure (so that a dark and a bright scene look alike to the network),
then a log transform (``log1p``), which compresses fireflies. The network's output is mapped back
by the inverse transform. The inputs are first sanitized as OIDN sanitizes its own
(:func:`sanitized`: NaN to 0, color at least 0, albedo in [0, 1], normal in [-1, 1]): bnerr's
tracer never leaves those ranges, but a renderer's denoising albedo may (Cycles' exceeds 1 on a few
pixels of a glossy scene, up to 154), and the network, trained on [0, 1], then ran away.

Much smaller than OIDN's (0.37 M parameters instead of about 0.9 M at the default widths;
``MAX_PARAMETERS`` is the project's cap): it has to train in minutes on two CPU cores. It is a
baseline that shows what a learned denoiser does with white and blue-noise input, not a
replacement for OIDN.

Inference on the CPU runs :class:`FastUNet`, the same network rearranged for speed (upsampling
convolutions folded into transposed convolutions, fused ReLU and sums, channels-last layout, kept
buffers; outputs equal within float32 rounding);
training and other devices run :class:`UNet` itself.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

import torch
import torch.nn.functional as F
from torch import nn

from bnerr.color import LUMINANCE_WEIGHTS
from bnerr.errors import DtypeError, FileFormatError, ShapeError, ValueRangeError
from bnerr.frame import Frame
from bnerr.io import atomic_write
from denoisers.base import Denoiser, required

__all__ = [
    "BLUE_WEIGHTS",
    "DEFAULT_WEIGHTS",
    "FastUNet",
    "MAX_PARAMETERS",
    "UNet",
    "UNetBlueDenoiser",
    "UNetDenoiser",
    "WEIGHTS_FORMAT",
    "atomic_torch_save",
    "auto_exposure",
    "check_parameter_count",
    "conv_fused",
    "conv_into",
    "load_torch_file",
    "load_weights",
    "network_input",
    "parameter_count",
    "parameter_count_reference",
    "sanitized",
    "save_weights",
    "unet_denoise",
    "upsampled_transpose_kernel",
]

#: The shipped weights, produced by the command in ``denoisers/weights/README.md``.
DEFAULT_WEIGHTS = Path(__file__).with_name("weights") / "unet.pt"
#: The U-Net trained on white and blue-noise inputs (``bnerr train --mix white+blue``; the exact
#: command is in denoisers/weights/README.md).
BLUE_WEIGHTS = Path(__file__).with_name("weights") / "unet_blue.pt"
#: Format tag written into every weights file, checked on load.
WEIGHTS_FORMAT = "bnerr-unet-weights-v1"
#: The project's cap on the network's size (the issue: "at most about 0.5 M parameters").
MAX_PARAMETERS = 500_000
#: Default channel widths: full, 1/2, 1/4, 1/8 resolution (the bottleneck).
DEFAULT_WIDTHS = (32, 48, 64, 80)

_KEY = 0.18  # mid-grey: auto-exposure maps the image's log-average luminance to it
_BIN = 16  # auto-exposure averages luminance over 16 x 16 pixel bins first, as OIDN does
_LUMA = LUMINANCE_WEIGHTS


def auto_exposure(color: torch.Tensor) -> torch.Tensor:
    """Scalar exposure that maps ``color [3, H, W]``'s log-average luminance to 0.18.

    OIDN's autoexposure (core/autoexposure.h): average luminance over 16 x 16 bins, take the
    geometric mean over the bins that are not black, return ``key / mean``. Binning first makes it
    robust to the noise of a low-spp frame. Returns a 0-dim tensor (1 for a black image).
    """
    w = torch.tensor(_LUMA, device=color.device, dtype=color.dtype)
    lum = torch.einsum("chw,c->hw", color.clamp_min(0.0), w)[None, None]
    bins = F.avg_pool2d(lum, _BIN, ceil_mode=True)[0, 0]
    lit = bins > 1e-8
    if not bool(lit.any()):
        return torch.ones((), device=color.device, dtype=color.dtype)
    return _KEY / bins[lit].log().mean().exp()


def sanitized(
    color: torch.Tensor, albedo: torch.Tensor, normal: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """The inputs in the ranges OIDN's input stage gives them (NaN to 0; color at least 0,
    albedo in [0, 1], normal in [-1, 1]); new tensors, the arguments untouched.

    Negative color is something an unbiased estimator never produces, but a filter upstream
    might. A denoising albedo above 1 is what some renderers write where a glossy or emissive
    surface is hit (Cycles); OIDN clamps it the same way.
    """
    return (
        torch.nan_to_num(color, nan=0.0).clamp_min_(0.0),
        torch.nan_to_num(albedo, nan=0.0).clamp_(0.0, 1.0),
        torch.nan_to_num(normal, nan=0.0).clamp_(-1.0, 1.0),
    )


def network_input(
    color: torch.Tensor, albedo: torch.Tensor, normal: torch.Tensor, exposure: torch.Tensor
) -> torch.Tensor:
    """The ``[9, H, W]`` network input: ``log1p(exposure * color)``, albedo, normal, each
    :func:`sanitized` first."""
    color, albedo, normal = sanitized(color, albedo, normal)
    return torch.cat([torch.log1p(color * exposure), albedo, normal])


def _conv(cin: int, cout: int) -> nn.Conv2d:
    return nn.Conv2d(cin, cout, kernel_size=3, padding=1)


def _check_widths(widths: object) -> tuple[int, int, int, int]:
    """``widths`` as 4 positive Python ints; :class:`ValueRangeError` otherwise."""
    try:
        values = list(widths) if isinstance(widths, Iterable) else None
    except TypeError:
        values = None
    if (
        values is None
        or len(values) != 4
        or any(isinstance(c, bool) or not isinstance(c, int) or c < 1 for c in values)
    ):
        raise ValueRangeError(f"UNet: widths: expected 4 positive integers, got {widths!r:.80}")
    return tuple(values)


def _layer_shapes(widths: Sequence[int], in_channels: int = 9) -> list[tuple[int, int]]:
    """``(in, out)`` channels of every 3 x 3 convolution of :class:`UNet`, in its order."""
    c0, c1, c2, c3 = widths
    return [
        (in_channels, c0), (c0, c0), (c0, c1), (c1, c2), (c2, c3), (c3, c3),
        (c3 + c1, c2), (c2, c2), (c2 + c0, c1), (c1, c1), (c1 + in_channels, c1), (c1, c0), (c0, 3),
    ]  # fmt: skip


class UNet(nn.Module):
    """OIDN-style U-Net: ``[B, 9, H, W]`` -> ``[B, 3, H, W]`` in the transformed (log) domain.

    ``widths = (c0, c1, c2, c3)``: two convolutions at full resolution (c0), one per level at 1/2
    (c1) and 1/4 (c2), each followed by a max-pool, two in the 1/8 bottleneck (c3); the decoder
    mirrors it with two convolutions per level after each upsampling and concatenation (with the
    pooled encoder output of that level, and with the network input at full resolution). H and W
    need not be multiples of 8: the input is padded by replication and the output cropped.
    With ``residual`` the output is the last convolution plus the input's first 3 channels (the
    log color).
    """

    def __init__(
        self, widths: Sequence[int] = DEFAULT_WIDTHS, in_channels: int = 9, residual: bool = True
    ) -> None:
        super().__init__()
        self.residual = bool(residual)
        c0, c1, c2, c3 = _check_widths(widths)
        self.widths = tuple(widths)
        self.enc0 = _conv(in_channels, c0)
        self.enc1 = _conv(c0, c0)
        self.enc2 = _conv(c0, c1)
        self.enc3 = _conv(c1, c2)
        self.mid_a = _conv(c2, c3)
        self.mid_b = _conv(c3, c3)
        self.dec3_a = _conv(c3 + c1, c2)
        self.dec3_b = _conv(c2, c2)
        self.dec2_a = _conv(c2 + c0, c1)
        self.dec2_b = _conv(c1, c1)
        self.dec1_a = _conv(c1 + in_channels, c1)
        self.dec1_b = _conv(c1, c0)
        self.out = _conv(c0, 3)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h, w = x.shape[-2:]
        ph, pw = (-h) % 8, (-w) % 8
        x = F.pad(x, (0, pw, 0, ph), mode="replicate") if ph or pw else x
        relu = F.relu
        skip0 = x
        y = relu(self.enc1(relu(self.enc0(x))))
        skip1 = F.max_pool2d(y, 2)  # 1/2
        skip2 = F.max_pool2d(relu(self.enc2(skip1)), 2)  # 1/4
        y = F.max_pool2d(relu(self.enc3(skip2)), 2)  # 1/8
        y = relu(self.mid_b(relu(self.mid_a(y))))
        y = torch.cat([F.interpolate(y, scale_factor=2.0, mode="nearest"), skip2], 1)  # 1/4
        y = relu(self.dec3_b(relu(self.dec3_a(y))))
        y = torch.cat([F.interpolate(y, scale_factor=2.0, mode="nearest"), skip1], 1)  # 1/2
        y = relu(self.dec2_b(relu(self.dec2_a(y))))
        y = torch.cat([F.interpolate(y, scale_factor=2.0, mode="nearest"), skip0], 1)  # 1
        y = relu(self.dec1_b(relu(self.dec1_a(y))))
        y = self.out(y) + x[:, :3] if self.residual else self.out(y)
        return y[..., :h, :w]


# Inference-only fast path for the CPU (issues 16 and 27). These changes to the plain forward,
# none to the arithmetic it computes (only to the order of float32 sums):
# - A 3 x 3 convolution of a 2x nearest-upsampled input is, for each of the 4 output phases (row
#   and column parity), a 2 x 2 convolution of the low-resolution input with kernel taps summed
#   ("folded"): 4 instead of 9 taps, run at a quarter of the pixels. Each decoder convolution of
#   ``cat([up(y), skip])`` is split into that folded convolution of ``y`` plus a 3 x 3 convolution
#   of ``skip`` alone, so neither the upsampled tensor nor the concatenation is materialised
#   (the concatenation at full resolution was the largest single cost, 23 % of a 1080p forward).
#   The four phases' folded taps run as one stride-2 transposed convolution, which writes them
#   interleaved (:func:`upsampled_transpose_kernel`).
# - ReLU and the sums are fused into oneDNN's convolutions (its pointwise post-ops), instead of
#   separate passes over the activations in memory.
# - Every activation is channels-last, the layout oneDNN's convolutions run fastest on.
# - Activations go into buffers kept between calls (a new tensor's page faults cost about as much
#   as a pass over it), and the weights are packed in oneDNN's layout once per input size.
# - The full-resolution layers run in strips of rows with exact halos, so that their
#   intermediates stay in the cache and no full-resolution activation is allocated.
# The folded taps of all four phases as one stride-2 transposed convolution (padding 1, 4 x 4
# kernel): low row i reaches output rows 2 i - 1, 2 i, 2 i + 1, 2 i + 2 through kernel rows 0, 1,
# 2, 3, which take the 3 x 3 kernel's row 2, rows 1 + 2, rows 0 + 1, row 0 (row ``k`` of
# ``_TRANSPOSE``); columns alike. Measured at 1080p: 0.72 times the time of the earlier fast
# path, a 2 x 2 convolution to 4 cout phase channels followed by a copy interleaving them.
_TRANSPOSE = ((0.0, 0.0, 1.0), (0.0, 1.0, 1.0), (1.0, 1.0, 0.0), (1.0, 0.0, 0.0))


def upsampled_transpose_kernel(weight: torch.Tensor) -> torch.Tensor:
    """``[cout, cin, 3, 3]`` acting on a 2x nearest-upsampled input -> ``[cin, cout, 4, 4]``.

    ``conv_transpose2d(low, result, stride=2, padding=1)`` on the low-resolution ``[h, w]``
    input is ``conv2d(upsample(low), weight, padding=1)``, ``[2 h, 2 w]``: each output phase
    (row and column parity) sees the 3 x 3 taps summed onto 2 x 2 low-resolution taps, laid out
    so that one oneDNN call writes the interleaved phases itself (zero padding of the upsampled
    input is zero padding of the low-resolution one, so borders agree too).
    """
    rows = torch.tensor(_TRANSPOSE, dtype=weight.dtype, device=weight.device)
    kernel = torch.einsum("kr,lq,oirq->iokl", rows, rows, weight)
    return kernel.contiguous()


def _fused_op():
    """oneDNN's convolution with pointwise post-ops, or None where this torch lacks it."""
    return getattr(torch.ops.mkldnn, "_convolution_pointwise", None)


def conv_fused(
    x: torch.Tensor,
    weight: torch.Tensor,
    bias: torch.Tensor | None,
    relu: bool,
    add: torch.Tensor | None = None,
    padding: int | tuple[int, int] = 1,
) -> torch.Tensor:
    """``relu?(conv2d(x, weight, bias, padding) + add?)`` in one oneDNN call on the CPU (channels-
    last ``x`` and ``add``; ``padding``: both sides, or rows and columns); separate torch ops
    where the fused op is missing or disabled."""
    op = _fused_op() if torch.backends.mkldnn.is_available() else None
    pad, one = list(padding) if isinstance(padding, tuple) else [padding, padding], [1, 1]
    if op is None:
        y = F.conv2d(x, weight, bias, padding=padding)
        y = y.add_(add) if add is not None else y
        return y.relu_() if relu else y
    if add is None:
        return op(x, weight, bias, pad, one, one, 1, "relu" if relu else "none", [None], "")
    unary = "relu" if relu else None
    return op.binary(x, add, weight, bias, pad, one, one, 1, "add", None, unary, [None], "")


def conv_into(
    out: torch.Tensor, x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor | None, relu: bool
) -> torch.Tensor:
    """``out = relu?(conv2d(x, weight, bias, padding=1) + out)`` in place, in one oneDNN call on
    the CPU (channels-last ``x`` and ``out``); returns ``out``.

    Writing into a tensor that already exists spares the allocation of a new output, whose first
    touch (a page fault per 4 KiB page) costs as much as a pass over memory: at 1080p, 183 ms to
    allocate and fill 400 MB against 24 ms to fill it again. Separate torch ops where the fused op
    is missing or disabled (same sums in the same order).
    """
    op = _fused_op() if torch.backends.mkldnn.is_available() else None
    if op is None:
        out.add_(F.conv2d(x, weight, bias, padding=1))
        return out.relu_() if relu else out
    one = [1, 1]
    unary = "relu" if relu else None
    torch.ops.mkldnn._convolution_pointwise_.binary(
        out, x, weight, bias, one, one, one, 1, "add", None, unary, [None], ""
    )
    return out


def _max_pool_into(out: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """``max_pool2d(y, 2)`` (channels-last, even height and width) written into ``out``
    (channels-last, dense): the max of the four 2 x 2 phases, exact; no int64 indices (which
    F.max_pool2d writes on the CPU, twice the output's bytes), no new tensor."""
    n, c, h, w = y.shape
    phases = y.permute(0, 2, 3, 1).view(n, h // 2, 2, w // 2, 2, c)
    o = out.permute(0, 2, 3, 1)
    torch.maximum(phases[:, :, 0, :, 0], phases[:, :, 0, :, 1], out=o)
    torch.maximum(o, phases[:, :, 1, :, 0], out=o)
    torch.maximum(o, phases[:, :, 1, :, 1], out=o)
    return out


class FastUNet:
    """Inference-only CPU float32 twin of a :class:`UNet` (same outputs within float32
    rounding): folded upsampling convolutions, fused ReLU and sums, channels-last activations.

    Built from a network's weights once (a copy: later changes to ``model`` are not seen); called
    like the network on ``[B, 9, H, W]``. Other devices or dtypes, or a call with gradients
    enabled, run the plain network ``model`` instead, so training and CUDA are unaffected.
    The full-resolution layers run in strips of :attr:`strip_rows` rows (outputs equal to the
    untiled network's). It keeps its lower-resolution activation buffers for the last input
    size between calls (0.33 GB at 1080p: new ones would cost a page fault per 4 KiB on every
    call), and its weights packed in oneDNN's layout for that size; calls from several
    threads take turns. The returned tensor is always new.
    """

    #: Output rows per strip of the full-resolution layers (64 rows of 48 channels at 1920
    #: columns: 24 MB, within the 32 MB L3). Measured 1080p unet_denoise (tail in strips): 1.84 s
    #: at 64 rows, 1.85 s at 32, 1.99 s at 16, 2.02 s at 128, 2.93 s as one strip.
    strip_rows = 64

    def __init__(self, model: UNet) -> None:
        self.model = model
        self.residual = model.residual
        self.widths = model.widths
        self._w = {k: v.detach().clone() for k, v in model.state_dict().items()}
        self._split = {}
        self._buffers: dict[str, torch.Tensor] = {}
        self._lock = threading.Lock()
        self._packs: dict[tuple[object, ...], torch.Tensor] = {}
        self._packed_for: torch.Size | None = None
        self._height = 0  # rows of the full-resolution layers of the current call
        low = {"dec3_a": model.widths[3], "dec2_a": model.widths[2], "dec1_a": model.widths[1]}
        for name, c_up in low.items():
            weight = self._w.pop(f"{name}.weight")
            self._split[name] = (
                upsampled_transpose_kernel(weight[:, :c_up]),
                weight[:, c_up:].contiguous(),
                self._w.pop(f"{name}.bias"),
            )

    def _up_cat_conv(self, low: torch.Tensor, skip: torch.Tensor, name: str) -> torch.Tensor:
        """``relu(conv(cat([up(low), skip])))`` without building the upsampled tensor or the
        concatenation."""
        _, skip_weight, bias = self._split[name]
        up = self._upsampled(low, name)
        return conv_into(up, skip, self._pack(f"{name}.skip", skip_weight, skip), bias, True)

    def _upsampled(self, low: torch.Tensor, name: str) -> torch.Tensor:
        """``conv(up(low))`` with the upsampled part of ``name``'s kernel, ``[2 h, 2 w]``."""
        kernel = self._split[name][0]
        if _fused_op() is None or not torch.backends.mkldnn.is_available():
            return F.conv_transpose2d(low, kernel, stride=2, padding=1)
        # The same oneDNN deconvolution, with the kernel in its blocked layout already.
        one, packed = [1, 1], self._pack(f"{name}.up", kernel, low, transpose=True)
        return torch.ops.mkldnn._convolution_transpose_pointwise(
            low, packed, None, one, [0, 0], [2, 2], one, 1, "none", [None], ""
        )

    def _pack(
        self,
        name: str,
        weight: torch.Tensor,
        x: torch.Tensor,
        transpose: bool = False,
        padding: tuple[int, int] = (1, 1),
    ) -> torch.Tensor:
        """``weight`` reordered once into the blocked layout oneDNN picks for input ``x``'s shape
        (cached per shape), instead of on every call; ``weight`` itself without oneDNN."""
        if _fused_op() is None or not torch.backends.mkldnn.is_available():
            return weight
        key = (name, *x.shape, *padding)
        if key not in self._packs:
            one, shape = [1, 1], list(x.shape)
            if transpose:
                reorder = torch.ops.mkldnn._reorder_convolution_transpose_weight
                self._packs[key] = reorder(weight, one, [0, 0], [2, 2], one, 1, shape)
            else:
                reorder = torch.ops.mkldnn._reorder_convolution_weight
                self._packs[key] = reorder(weight, list(padding), one, one, 1, shape)
        return self._packs[key]

    def _conv_rows(
        self, src: torch.Tensor, first: int, rows: tuple[int, int], name: str, relu: bool,
        add: Callable[[int, int], torch.Tensor] | None = None,
    ) -> torch.Tensor:  # fmt: skip
        """Rows ``rows = (a, b)`` of ``relu?(conv(layer) + add?)``, where ``src [1, C, n, W]``
        holds rows ``first ..`` of the ``self._height``-row layer and ``add(o0, o1)`` gives rows
        ``o0 .. o1`` of the sum. Only rows ``a - 1 .. b + 1`` are read: inside the image the
        halo rows come from ``src`` (no row padding); at its top or bottom the convolution pads
        both ends with zeros and the extra row it computes at the other end is dropped."""
        a, b = rows
        lo, hi = max(a - 1, 0), min(b + 1, self._height)
        pad_rows = 1 if lo == a or hi == b else 0
        o0, o1 = (lo, hi) if pad_rows else (a, b)
        x = src[:, :, lo - first : hi - first]
        weight, bias = self._weights(name)
        weight = self._pack(name, weight, x, padding=(pad_rows, 1))
        y = conv_fused(x, weight, bias, relu, add(o0, o1) if add else None, (pad_rows, 1))
        return y[:, :, a - o0 : b - o0]

    def _weights(self, name: str) -> tuple[torch.Tensor, torch.Tensor]:
        """Weight and bias of layer ``name`` (``dec1_a.skip``: the skip part of ``dec1_a``)."""
        if name.endswith(".skip"):
            _, weight, bias = self._split[name.removesuffix(".skip")]
            return weight, bias
        return self._w[f"{name}.weight"], self._w[f"{name}.bias"]

    def _up_rows(self, low: torch.Tensor, rows: tuple[int, int]) -> torch.Tensor:
        """Rows ``rows`` of ``dec1_a``'s upsampled convolution of ``low [1, C, h, w]``: from
        low rows ``(a - 1) // 2 .. b // 2`` (the transposed convolution's first and last rows
        miss a low row inside the image and are dropped)."""
        a, b = rows
        l0, l1 = max((a - 1) // 2, 0), min(b // 2 + 1, low.shape[2])
        z = self._upsampled(low[:, :, l0:l1], "dec1_a")
        return z[:, :, a - 2 * l0 : b - 2 * l0]

    def _strip(
        self, x: torch.Tensor, low: torch.Tensor, color: torch.Tensor, rows: tuple[int, int]
    ) -> torch.Tensor:
        """Output rows ``rows`` of the network for batch item ``x [1, 9, H, W]`` (the padded
        input), ``low`` (its ``dec2_b`` output) and ``color`` (its log color, the residual)."""
        height = self._height
        b_rows = (max(rows[0] - 1, 0), min(rows[1] + 1, height))  # dec1_b's rows it needs
        a_rows = (max(b_rows[0] - 1, 0), min(b_rows[1] + 1, height))  # dec1_a's rows
        y = self._conv_rows(
            x, 0, a_rows, "dec1_a.skip", True, lambda o0, o1: self._up_rows(low, (o0, o1))
        )
        y = self._conv_rows(y, a_rows[0], b_rows, "dec1_b", True)
        residual = (lambda o0, o1: color[:, :, o0:o1]) if self.residual else None
        return self._conv_rows(y, b_rows[0], rows, "out", False, residual)

    def _tail(self, low: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
        """The full-resolution layers (``dec1_a``, ``dec1_b``, ``out``) in strips of
        :attr:`strip_rows` output rows, each computed from its halo of inputs so that its
        intermediates stay in cache; ``low``: ``dec2_b``'s output, ``x``: the padded input."""
        n, _, height, width = x.shape
        self._height, step = height, max(int(self.strip_rows), 1)
        out = torch.empty((n, 3, height, width), memory_format=torch.channels_last)
        for i in range(n):
            xi, lowi = x[i : i + 1], low[i : i + 1]
            color = xi[:, :3].contiguous(memory_format=torch.channels_last)
            for r0 in range(0, height, step):
                rows = (r0, min(r0 + step, height))
                out[i : i + 1, :, rows[0] : rows[1]].copy_(self._strip(xi, lowi, color, rows))
        return out

    def _buffer(self, slot: str, shape: tuple[int, int, int, int]) -> torch.Tensor:
        """The kept channels-last buffer ``slot`` of ``shape`` (a new one if the last call's
        differs). Its contents are whatever was last written there."""
        buffer = self._buffers.get(slot)
        if buffer is None or buffer.shape != shape:
            self._buffers.pop(slot, None)  # free the old one first
            buffer = torch.empty(shape, memory_format=torch.channels_last)
            self._buffers[slot] = buffer
        return buffer

    def _conv_kept(self, x: torch.Tensor, name: str, slot: str) -> torch.Tensor:
        """``relu(conv(x))`` written into the kept buffer ``slot`` (zeroed first: a fill of
        memory already mapped is cheaper than faulting in a new tensor)."""
        weight = self._w[f"{name}.weight"]
        n, _, h, w = x.shape
        out = self._buffer(slot, (n, weight.shape[0], h, w)).zero_()
        return conv_into(out, x, self._pack(name, weight, x), self._w[f"{name}.bias"], True)

    def _pool_kept(self, y: torch.Tensor, slot: str) -> torch.Tensor:
        """``max_pool2d(y, 2)`` (even height and width) written into the kept buffer ``slot``."""
        n, c, h, w = y.shape
        return _max_pool_into(self._buffer(slot, (n, c, h // 2, w // 2)), y)

    def _head(self, x: torch.Tensor) -> torch.Tensor:
        """``max_pool2d(enc1(enc0(x)), 2)`` (``skip1``, kept) in strips of :attr:`strip_rows`
        rows (rounded up to even), like :meth:`_tail`: no full-resolution activation is kept."""
        n, _, height, width = x.shape
        self._height, step = height, max(int(self.strip_rows), 1)
        step += step % 2
        skip1 = self._buffer("skip1", (n, self.widths[0], height // 2, width // 2))
        for i in range(n):
            xi = x[i : i + 1]
            for r0 in range(0, height, step):
                rows = (r0, min(r0 + step, height))
                e_rows = (max(r0 - 1, 0), min(rows[1] + 1, height))  # enc0's rows it needs
                y = self._conv_rows(xi, 0, e_rows, "enc0", True)
                y = self._conv_rows(y, e_rows[0], rows, "enc1", True)
                _max_pool_into(skip1[i : i + 1, :, r0 // 2 : rows[1] // 2], y)
        return skip1

    def _padded_input(self, parts: Sequence[torch.Tensor]) -> torch.Tensor:
        """``torch.cat(parts, 1)`` padded by replication to multiples of 8, channels-last, in the
        kept buffer (each part copied straight into its channels: no concatenation)."""
        n, _, h, w = parts[0].shape
        c = sum(part.shape[1] for part in parts)
        shape = (n, c, h + (-h) % 8, w + (-w) % 8)
        out = self._buffer("input", shape)
        first = 0
        for part in parts:
            out[:, first : first + part.shape[1], :h, :w].copy_(part)
            first += part.shape[1]
        out[:, :, :h, w:].copy_(out[:, :, :h, w - 1 : w].expand(n, c, h, shape[3] - w))
        out[:, :, h:, :].copy_(out[:, :, h - 1 : h, :].expand(n, c, shape[2] - h, shape[3]))
        return out

    def __call__(self, x: torch.Tensor) -> torch.Tensor:
        return self.call_parts([x])

    def call_parts(self, parts: Sequence[torch.Tensor]) -> torch.Tensor:
        """The network on ``torch.cat(parts, 1)`` (``[B, c_i, H, W]`` each), without building
        the concatenation on the fast path; the plain network (on the concatenation) where
        :class:`FastUNet` defers to it."""
        fast = all(p.device.type == "cpu" and p.dtype == torch.float32 for p in parts)
        if not fast or torch.is_grad_enabled():
            return self.model(torch.cat(list(parts), 1))
        shapes = [tuple(part.shape) for part in parts]
        if not shapes or any(len(s) != 4 or s[0:1] + s[2:] != shapes[0][0:1] + shapes[0][2:]
                             for s in shapes):  # fmt: skip
            raise ShapeError(f"FastUNet: expected [B, C, H, W] parts of one B, H, W, got {shapes}")
        with self._lock:  # the kept buffers serve one call at a time
            return self._forward(parts)

    def _forward(self, parts: Sequence[torch.Tensor]) -> torch.Tensor:
        h, w = parts[0].shape[-2:]
        x = self._padded_input(parts)
        if self._packed_for != x.shape:
            self._packs.clear()  # the packed weights of the last input size only
            self._packed_for = x.shape
        skip1 = self._head(x)  # 1/2
        skip2 = self._pool_kept(self._conv_kept(skip1, "enc2", "half"), "skip2")  # 1/4
        y = self._pool_kept(self._conv_kept(skip2, "enc3", "quarter"), "eighth0")  # 1/8
        y = self._conv_kept(self._conv_kept(y, "mid_a", "eighth1"), "mid_b", "eighth2")
        y = self._conv_kept(self._up_cat_conv(y, skip2, "dec3_a"), "dec3_b", "quarter")  # 1/4
        y = self._conv_kept(self._up_cat_conv(y, skip1, "dec2_a"), "dec2_b", "half")  # 1/2
        return self._tail(y, x)[..., :h, :w]  # 1


def unet_denoise(
    model: UNet | FastUNet, color: torch.Tensor, albedo: torch.Tensor, normal: torch.Tensor
) -> torch.Tensor:
    """Denoise ``color [3, H, W]`` with ``model``, guided by ``albedo`` and ``normal [3, H, W]``.

    Sanitizes the inputs (:func:`sanitized`), applies the input transform, runs the network
    without gradients, and inverts the transform; the result is clamped at 0 (radiance is never
    negative). ``model`` must already be on the color's device. Returns ``[3, H, W]`` float32.
    """
    color, albedo, normal = sanitized(color, albedo, normal)
    exposure = auto_exposure(color)
    # network_input's arithmetic, in place on the sanitized copy; the FastUNet copies the three
    # parts into its padded input buffer without a concatenation.
    log_color = color.mul_(exposure).log1p_()
    with torch.no_grad():
        if isinstance(model, FastUNet):
            y = model.call_parts([log_color[None], albedo[None], normal[None]])[0]
        else:
            y = model(torch.cat([log_color, albedo, normal])[None])[0]
    return y.clamp_min(0.0).expm1_().div_(exposure)


def atomic_torch_save(obj: object, path: Path) -> None:
    """``torch.save`` through :func:`bnerr.io.atomic_write` (creating ``path``'s folder).

    A crash mid-write leaves the previous file intact, never a truncated one.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(path) as tmp:
        torch.save(obj, tmp)


def save_weights(model: UNet, path: str | Path, meta: dict | None = None) -> None:
    """Write ``model``'s weights (and its widths, and ``meta``) to ``path`` atomically."""
    payload = {
        "format": WEIGHTS_FORMAT,
        "widths": list(model.widths),
        "residual": model.residual,
        "state_dict": model.state_dict(),
        "meta": dict(meta or {}),
    }
    atomic_torch_save(payload, Path(path))


def load_torch_file(path: Path, what: str, fmt: str) -> dict:
    """Read a dict saved with ``torch.save`` whose ``"format"`` entry is ``fmt`` (on the CPU).

    Raises:
        FileFormatError: naming ``path`` and ``what`` was expected, if the file is missing,
            unreadable, corrupt, or of another format.
    """
    try:
        payload = torch.load(path, map_location="cpu", weights_only=True)
    except FileNotFoundError:
        raise FileFormatError(f"{path}: expected {what}, got no such file") from None
    except Exception as err:  # torch raises many types on a damaged file
        raise FileFormatError(f"{path}: expected {what}, got an unreadable file ({err})") from None
    if not isinstance(payload, dict) or payload.get("format") != fmt:
        got = payload.get("format") if isinstance(payload, dict) else type(payload).__name__
        raise FileFormatError(f"{path}: expected format {fmt!r}, got {got!r}")
    return payload


def load_weights(path: str | Path) -> UNet:
    """Build a :class:`UNet` from a weights file written by :func:`save_weights` (on the CPU).

    Raises:
        FileFormatError: the file is missing, unreadable, corrupt, or not a bnerr U-Net file,
            or its widths make a network over :data:`MAX_PARAMETERS` (refused before building).
    """
    path = Path(path)
    payload = load_torch_file(path, "a U-Net weights file", WEIGHTS_FORMAT)
    try:
        # The size comes from the file: check it before building (a 1.4 KB file asking for
        # widths [8192] * 4 would otherwise allocate a 31 GB network).
        check_parameter_count(payload.get("widths"), f"{path}: widths")
    except ValueRangeError as err:
        raise FileFormatError(str(err)) from None
    try:
        model = UNet(tuple(payload["widths"]), residual=bool(payload["residual"]))
        model.load_state_dict(payload["state_dict"])
    except (RuntimeError, KeyError, TypeError, ValueError) as err:
        raise FileFormatError(
            f"{path}: expected U-Net widths, residual flag and weights, got {err!r}"
        ) from None
    return model.eval()


class UNetDenoiser(Denoiser):
    """The trained U-Net behind the :class:`~denoisers.base.Denoiser` interface.

    ``weights``: a file written by :func:`save_weights` (default: the shipped weights,
    :data:`DEFAULT_WEIGHTS`). The model is moved to each frame's device on first use there.
    """

    name = "unet"
    kind = "learned"
    requires = frozenset({"albedo", "normal"})

    def __init__(self, weights: str | Path | None = None) -> None:
        if weights is not None and not isinstance(weights, (str, Path)):
            raise DtypeError(f"unet: weights: expected a path, got {type(weights).__name__}")
        self.weights = Path(weights) if weights is not None else DEFAULT_WEIGHTS
        self._model = load_weights(self.weights)
        #: Inference copies by ``("fast", device)``, made on first use there.
        self._models: dict[tuple[str, str], UNet | FastUNet] = {}

    @property
    def model(self) -> UNet:
        """The network on the CPU."""
        return self._model

    def denoise(self, frame: Frame) -> torch.Tensor:
        device = frame.color.device
        key = ("fast", str(device))
        if key not in self._models:
            self._models[key] = self._inference_model(device)
        return unet_denoise(
            self._models[key], frame.color, required(frame, "albedo"), required(frame, "normal")
        )

    def _inference_model(self, device: torch.device) -> UNet | FastUNet:
        """The network for inference on ``device``: :class:`FastUNet` on the CPU, elsewhere a
        channels-last copy (the layout cuDNN's convolutions prefer too)."""
        if device.type == "cpu":
            return FastUNet(self.model)
        fast = UNet(self.model.widths, residual=self.model.residual)
        fast.load_state_dict(self.model.state_dict())
        return fast.eval().to(device).to(memory_format=torch.channels_last)

    def params(self) -> dict[str, float | int | str]:
        return {"weights": str(self.weights)}


def parameter_count(widths: Sequence[int] = DEFAULT_WIDTHS) -> int:
    """Number of trainable parameters of a :class:`UNet` with these widths, computed from the
    widths alone (nothing is allocated: a weights file's config is checked with it before the
    network is built). Each 3 x 3 convolution has ``9 cin cout + cout`` parameters.

    Raises:
        ValueRangeError: ``widths`` are not 4 positive integers.
    """
    return sum(9 * cin * cout + cout for cin, cout in _layer_shapes(_check_widths(widths)))


def parameter_count_reference(widths: Sequence[int] = DEFAULT_WIDTHS) -> int:
    """The slow twin of :func:`parameter_count`: build the network and count."""
    return sum(p.numel() for p in UNet(widths).parameters())


def check_parameter_count(widths: object, name: str) -> int:
    """Raise :class:`ValueRangeError` if a U-Net of ``widths`` exceeds :data:`MAX_PARAMETERS`, or
    if ``widths`` (which may come from a file) are not 4 positive integers."""
    checked = _check_widths(widths)
    count = parameter_count(checked)
    if count > MAX_PARAMETERS:
        raise ValueRangeError(
            f"{name}: expected at most {MAX_PARAMETERS} parameters, got widths "
            f"{list(checked)} with {count}"
        )
    return count


class UNetBlueDenoiser(UNetDenoiser):
    """``unet_blue``: the same network trained on a mix of white-noise inputs and inputs made by
    the benchmark's blue-noise strategies (temporal, zsobol, cycles_blue), same targets; weights
    :data:`BLUE_WEIGHTS` unless ``weights`` names another file."""

    name = "unet_blue"

    def __init__(self, weights: str | Path | None = None) -> None:
        super().__init__(BLUE_WEIGHTS if weights is None else weights)
