"""Image error metrics against a reference: per-image functions and the metrics' update halves.

What the benchmark measures (docs/METHODS.md, section 6): for a rendered (or denoised) image
``pred`` and the converged reference ``ref`` of the same frame, both ``[C, H, W]`` linear radiance,

- ``mse``: ``mean(e^2)`` with ``e = pred - ref``;
- ``relmse``: ``mean(e^2 / (ref^2 + 0.01))``, the relative MSE of pbrt/Mitsuba papers, which keeps
  dark pixels from vanishing and bright ones from dominating;
- ``psnr``: ``10 log10(peak^2 / mse)`` with ``peak = ref.max() - ref.min()`` (torchmetrics' default
  data range: the target's range);
- ``ssim``: scikit-image's ``structural_similarity`` (Wang et al. 2004, 7x7 uniform window) with
  ``data_range`` taken from the reference, channels averaged; computed here with scipy's
  ``uniform_filter`` exactly as scikit-image computes it (bit-identical,
  tests/test_metrics_image.py), so that the reference's local statistics are computed once per
  reference (:class:`PreparedReference`);
- ``mse_blur1``, ``mse_blur2``: the MSE of the *error* after a Gaussian blur of sigma 1 and 2
  pixels, the halftoning model of the eye (Heitz & Belcour 2019, section 6; Georgiev & Fajardo
  2016). A blue-noise error loses most of its energy under the blur, a white one keeps
  ``1 / (4 pi sigma^2)`` of it. Kernel size ``2 * ceil(3 sigma) + 1`` (7 and 13 taps), kornia's
  ``gaussian_blur2d`` with ``"reflect"`` border, which mirrors *without* repeating the edge pixel
  (numpy's ``"reflect"``, scipy's ``"mirror"``), so that the border adds no spurious correlation
  to the error;
- ``flip``: mean HDR-FLIP (Andersson et al. 2021, "Visualizing Errors in Rendered High Dynamic Range
  Images"), through the optional package ``flip-evaluator``;
- ``lowfreq``: the fraction of the error's power below 0.125 cycles/pixel
  (:func:`bnerr.metrics.spectrum.low_frequency_fraction`): about 0.05 for white noise, near 0 for
  blue.

Every metric may be restricted to a boolean pixel ``mask [H, W]`` (for example the pixels near
object edges, :func:`edge_mask`): the blur is applied to the whole error image first, and only the
masked pixels are averaged.

**Update halves.** :class:`ImagePair` reduces one image to each metric's pair ``(numerator,
denominator)`` (``(sum e^2, pixel count)`` for the MSE family, ``(value, 1)`` for per-image scores
such as PSNR and SSIM): the update half of the update/compute split
(:mod:`bnerr.metrics.frames`). Each per-image function here is one update followed by the compute
step, :func:`bnerr.metrics.stats.pooled_mean`.

**Determinism.** Every sum over pixels and tiles runs in a fixed order
(:func:`bnerr.reduce.fixed_sum`), so every value here is bit-identical whatever torch's thread
count (tests/test_metrics_frames.py checks 1 against 2 threads); SSIM runs in scipy and FLIP in
its own package, both single-threaded numpy. Across machines, float64 additions and
kornia's blur are IEEE-exact operations in a fixed order, but the FFT library may differ.

Not for: training losses (nothing here is differentiable on purpose: SSIM and FLIP leave torch),
or perceptual claims beyond what FLIP and the blurred MSE model.
"""

from __future__ import annotations

import functools
import importlib.util
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import torch

from bnerr.color import luminance
from bnerr.errors import (
    FLOAT_DTYPES,
    MissingExtraError,
    ShapeError,
    ValueRangeError,
    check_dtype,
    check_finite,
    check_positive_int,
    check_range,
    check_shape,
    check_tensor,
)
from bnerr.metrics.spectrum import low_frequency_fraction
from bnerr.metrics.stats import pooled_mean
from bnerr.reduce import fixed_sum

__all__ = [
    "ImagePair",
    "PreparedReference",
    "blurred_mse",
    "edge_mask",
    "flip",
    "flip_available",
    "DISPLAY_WHITE_OVER_MEAN",
    "highlight_mask",
    "light_mask",
    "lowfreq",
    "masked_sum",
    "mse",
    "psnr",
    "relmse",
    "require_flip",
    "ssim",
    "temporal_correlation",
]

_RELMSE_EPS = 0.01


# --------------------------------------------------------------------------------------------------
# Input checks (public boundary)


def _check_pair(
    pred: object, ref: object, mask: object = None, prepared: object = None
) -> dict[str, int]:
    """Check ``pred``, ``ref`` ([C, H, W], same shape, floating, finite), ``mask`` ([H, W] bool);
    a ``prepared`` reference's own checks were done when it was prepared."""
    pred = check_tensor(pred, "pred")
    ref = check_tensor(ref, "ref")
    size = check_shape(pred, "C H W", "pred")
    if prepared is None:
        check_shape(ref, "C H W", "ref")
    if pred.shape != ref.shape:
        raise ShapeError(
            f"pred: expected the shape of ref {list(ref.shape)}, got {list(pred.shape)}"
        )
    check_dtype(pred, FLOAT_DTYPES, "pred")
    if prepared is None:
        check_dtype(ref, FLOAT_DTYPES, "ref")
    check_finite(pred, "pred")
    if prepared is None:
        check_finite(ref, "ref")
    _check_mask(mask, size)
    return size


def _check_mask(mask: object, size: dict[str, int]) -> None:
    """Check an optional ``mask``: ``[H, W]`` of the image's size, bool, one pixel selected."""
    if mask is not None:
        mask = check_tensor(mask, "mask")
        check_shape(mask, f"{size['H']} {size['W']}", "mask")
        check_dtype(mask, torch.bool, "mask")
        if not bool(mask.any()):
            raise ValueRangeError("mask: expected at least one selected pixel, got none")


def _check_blur_size(size: dict[str, int], sigma: float) -> int:
    """Kernel size ``2 ceil(3 sigma) + 1``; the reflect border needs H and W > half of it."""
    check_range(sigma, "sigma", 1e-3, 64.0)
    kernel = 2 * math.ceil(3 * sigma) + 1
    if min(size["H"], size["W"]) <= kernel // 2:
        raise ShapeError(
            f"pred: expected H and W > {kernel // 2} for a sigma {sigma} blur "
            f"({kernel}-tap kernel, reflect border), got {size['H']} x {size['W']}"
        )
    return kernel


# --------------------------------------------------------------------------------------------------
# Updates: one frame -> (numerator, denominator), float64 on the input's device


def masked_sum(values: torch.Tensor, mask: torch.Tensor | None) -> torch.Tensor:
    """``(sum, count)`` of ``values [C, H, W]`` over all or the masked pixels: ``[2]`` float64."""
    values = values.to(torch.float64)
    if mask is not None:
        values = values[:, mask]
    # A fixed-order sum: torch.sum's rounding depends on the thread count (bnerr.reduce).
    return torch.stack([fixed_sum(values), values.new_tensor(float(values.numel()))])


def _mse_update(
    pred: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor | None = None
) -> torch.Tensor:
    return masked_sum((pred.to(torch.float64) - ref).square(), mask)


def _relmse_update(
    pred: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor | None = None
) -> torch.Tensor:
    ref64 = ref.to(torch.float64)
    return masked_sum(
        (pred.to(torch.float64) - ref64).square() / (ref64.square() + _RELMSE_EPS), mask
    )


def _blurred_mse_update(
    pred: torch.Tensor,
    ref: torch.Tensor,
    sigma: float,
    kernel: int,
    mask: torch.Tensor | None = None,
) -> torch.Tensor:
    # Blur the error, not the two images: the metric asks how much error survives a low-pass
    # filter, which is linear, so blur(pred) - blur(ref) would be the same up to rounding.
    err = pred.to(torch.float64) - ref.to(torch.float64)
    return _blurred_err_sum(err, sigma, kernel, mask)


def _blurred_err_sum(
    err: torch.Tensor, sigma: float, kernel: int, mask: torch.Tensor | None
) -> torch.Tensor:
    """``(sum, count)`` of the squared blur of the float64 error ``err [C, H, W]``."""
    return masked_sum(_gaussian_blur(err, sigma, kernel).square(), mask)


# kornia blurs an image of at least this many pixels with shifted slices instead of convolutions
_KORNIA_SLICES_FROM = 256 * 256


@functools.lru_cache(maxsize=16)
def _gaussian_taps(kernel: int, sigma: float) -> torch.Tensor:
    """kornia's float64 Gaussian taps ``[1, kernel]`` for ``sigma`` (what its blur builds)."""
    from kornia.filters import get_gaussian_kernel1d

    return get_gaussian_kernel1d(kernel, torch.tensor([[sigma]], dtype=torch.float64))


def _gaussian_blur(err: torch.Tensor, sigma: float, kernel: int) -> torch.Tensor:
    """kornia's ``gaussian_blur2d(err[None], (k, k), (sigma, sigma), "reflect")[0]``.

    A float64 CPU image under kornia's slice threshold takes kornia's own separable path
    (reflect pad and a depthwise row convolution, then the same for the columns) with the taps
    built once per sigma and the column pass run as a row pass on the transposed image: the
    same taps times the same values in the same order, bit-identical to kornia
    (tests/test_metrics_image.py) and 2-3 times faster at 128x128, where kornia's checks, tap
    construction and column convolution dominate. Anything else is kornia's call.
    """
    channels, height, width = err.shape
    if (
        err.device.type != "cpu"
        or err.dtype != torch.float64
        or (height * width >= _KORNIA_SLICES_FROM)
    ):
        from kornia.filters import gaussian_blur2d

        return gaussian_blur2d(
            err.unsqueeze(0), (kernel, kernel), (sigma, sigma), border_type="reflect"
        )[0]
    taps = _gaussian_taps(kernel, sigma).reshape(1, 1, 1, kernel).expand(channels, 1, 1, kernel)
    r = kernel // 2
    x = torch.nn.functional.pad(err.unsqueeze(0), (r, r, 0, 0), mode="reflect")
    x = torch.nn.functional.conv2d(x, taps, groups=channels)
    x = torch.nn.functional.pad(x.transpose(-1, -2).contiguous(), (r, r, 0, 0), mode="reflect")
    return torch.nn.functional.conv2d(x, taps, groups=channels).transpose(-1, -2)[0]


def _value_update(value: float, device: torch.device) -> torch.Tensor:
    """A per-image score as the pair ``(value, 1)``, so that compute averages it over frames."""
    return torch.tensor([value, 1.0], dtype=torch.float64, device=device)


def _psnr_value(mse_stats: torch.Tensor, ref: torch.Tensor, data_range: float | None) -> float:
    peak = float(ref.max() - ref.min()) if data_range is None else data_range
    if peak <= 0.0:
        raise ValueRangeError(
            f"ref: expected a non-constant reference for the PSNR peak, got range {peak}"
        )
    err = float(pooled_mean(mse_stats))
    return math.inf if err == 0.0 else 10.0 * math.log10(peak * peak / err)


_SSIM_WIN = 7  # scikit-image's default uniform window
_SSIM_K1, _SSIM_K2 = 0.01, 0.03


def _ssim_peak(ref: torch.Tensor) -> float:
    size = min(ref.shape[-2:])
    if size < _SSIM_WIN:
        raise ShapeError(
            f"pred: expected H and W >= 7 for SSIM's 7x7 window, got {list(ref.shape[-2:])}"
        )
    peak = float(ref.max() - ref.min())
    if peak <= 0.0:
        raise ValueRangeError(
            f"ref: expected a non-constant reference for SSIM's data range, got {peak}"
        )
    return peak


def _uniform(x: np.ndarray) -> np.ndarray:
    """scikit-image's 7x7 ``uniform_filter`` of every channel of ``x [C, H, W]`` (the channel
    axis has size 1, which scipy skips: each channel is filtered as scikit-image filters it)."""
    from scipy.ndimage import uniform_filter

    return uniform_filter(x, size=(1, _SSIM_WIN, _SSIM_WIN))


class _SSIMReference:
    """The reference's half of scikit-image's ``structural_similarity(ref, pred, data_range=peak,
    channel_axis=0)``: its local means and variances, computed once for every image compared
    with it. The arithmetic is scikit-image's, operation for operation (same numpy calls on the
    same values, in the same order), so :meth:`map` is bit-identical to its ``full=True`` map."""

    def __init__(self, ref: torch.Tensor) -> None:
        self.peak = _ssim_peak(ref)
        x = ref.detach().to("cpu", torch.float64).numpy()
        np_ = _SSIM_WIN**2
        self.cov_norm = np_ / (np_ - 1)  # sample covariance, scikit-image's default
        self.c1 = (_SSIM_K1 * self.peak) ** 2
        self.c2 = (_SSIM_K2 * self.peak) ** 2
        self.x = x
        self.ux = _uniform(x)
        self.vx = self.cov_norm * (_uniform(x * x) - self.ux * self.ux)
        self.two_ux = 2 * self.ux
        self.ux2 = self.ux**2

    def map(self, pred: torch.Tensor) -> np.ndarray:
        """The SSIM map ``[C, H, W]`` float64 of ``pred`` against the reference."""
        y = pred.detach().to("cpu", torch.float64).numpy()
        uy = _uniform(y)
        vy = self.cov_norm * (_uniform(y * y) - uy * uy)
        vxy = self.cov_norm * (_uniform(self.x * y) - self.ux * uy)
        a1 = self.two_ux * uy + self.c1
        a2 = 2 * vxy + self.c2
        b1 = self.ux2 + uy**2 + self.c1
        b2 = self.vx + vy + self.c2
        return (a1 * a2) / (b1 * b2)

    def value(self, pred: torch.Tensor, mask: torch.Tensor | None) -> float:
        """Mean SSIM of ``pred`` (:meth:`mean` of its :meth:`map`)."""
        return self.mean(self.map(pred), mask)

    @staticmethod
    def mean(smap: np.ndarray, mask: torch.Tensor | None) -> float:
        """Mean of an SSIM map: per channel over the map less a 3-pixel border, then over
        channels (as scikit-image); with a mask, over the masked pixels away from that border."""
        pad = (_SSIM_WIN - 1) // 2
        if mask is None:
            per_channel = [c[pad:-pad, pad:-pad].mean(dtype=np.float64) for c in smap]
            return float(np.array(per_channel, dtype=np.float64).mean())
        keep = mask.detach().cpu().numpy().copy()
        keep[:pad, :] = keep[-pad:, :] = keep[:, :pad] = keep[:, -pad:] = False
        if not keep.any():
            raise ValueRangeError(
                "mask: expected a selected pixel at least 3 pixels from the border for SSIM"
            )
        return float(smap[:, keep].mean())


def _ssim_value(pred: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor | None) -> float:
    return _SSIMReference(ref).value(pred, mask)


def require_flip() -> None:
    """Raise :class:`~bnerr.errors.MissingExtraError` (an ``ImportError``) naming the extra and
    its install command unless ``flip-evaluator`` is installed."""
    if not flip_available():
        raise MissingExtraError(
            "flip", "reference", "flip-evaluator==1.7", "no module named 'flip_evaluator'"
        )


def _flip_value(pred: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor | None) -> float:
    require_flip()
    import flip_evaluator

    # HDR-FLIP reads HxWxC linear RGB with non-negative values; a denoiser may undershoot below 0.
    def hwc(x: torch.Tensor) -> np.ndarray:
        return (
            x.detach().to("cpu", torch.float32).clamp_min(0.0).permute(1, 2, 0).contiguous().numpy()
        )

    if ref.shape[0] != 3:
        raise ShapeError(f"pred: expected 3 channels (RGB) for FLIP, got {ref.shape[0]}")
    error_map, mean_error, _ = flip_evaluator.evaluate(hwc(ref), hwc(pred), "HDR", applyMagma=False)
    if mask is None:
        return float(mean_error)
    return float(error_map[..., 0][mask.detach().cpu().numpy()].mean())


class PreparedReference:
    """A reference ``[C, H, W]`` checked once and prepared for every frame compared with it.

    :class:`ImagePair` (and so :meth:`bnerr.metrics.FrameMetrics.update`) takes one in place of
    the reference tensor when several images (the raw frame and each denoiser's output, in each
    pixel region) are measured against the same reference: its float64 copy, the relative MSE's
    denominator, the PSNR and SSIM peak and the reference's half of SSIM are then computed once
    instead of once per image. The values are the same bit for bit (the same operations on the
    same numbers).
    """

    def __init__(self, ref: torch.Tensor) -> None:
        check_shape(check_tensor(ref, "ref"), "C H W", "ref")
        check_dtype(ref, FLOAT_DTYPES, "ref")
        check_finite(ref, "ref")
        self.color = ref

    @functools.cached_property
    def ref64(self) -> torch.Tensor:
        return self.color.to(torch.float64)

    @functools.cached_property
    def relmse_denominator(self) -> torch.Tensor:
        return self.ref64.square() + _RELMSE_EPS

    @functools.cached_property
    def ssim(self) -> _SSIMReference:
        return _SSIMReference(self.color)


class ImagePair:
    """One image against its reference, as the metrics' updates see it.

    Checks the inputs once (as :func:`mse` does) and computes the float64 error and the MSE pair at
    most once for all the metrics of one frame. Each update method reduces the image to that
    metric's pair ``(numerator, denominator)``: ``[2]`` float64 on ``pred``'s device. The
    per-image value is :func:`bnerr.metrics.stats.pooled_mean` of the pair;
    :class:`bnerr.metrics.FrameMetrics` keeps the pairs of many frames, and its table
    (:data:`bnerr.metrics.METRIC_TABLE`) names the update of each metric.

    The maps a metric computes over the whole image before it reduces them over the region (the
    error, its square and relative square, its blurs, the SSIM map, the low-frequency fraction,
    which reads no mask) are kept for the pairs :meth:`in_region` makes of the same image, so
    that an image measured in several pixel regions computes them once: the same operations on
    the same values, so the same pairs bit for bit as separate pairs would give.

    Args:
        pred: ``[C, H, W]`` floating, finite, as in :func:`mse`.
        ref: its reference ``[C, H, W]``, or a :class:`PreparedReference` of it (the same values,
            computed faster when several images are measured against one reference).
        mask: optional ``[H, W]`` bool restricting every update except :meth:`lowfreq`.
        tile: tile size of :meth:`lowfreq`'s spectrum (>= 2; clamped to the image by the spectrum).

    Attributes:
        pred, mask, tile: as given. ref: the :class:`PreparedReference`.
        size: ``{"C": C, "H": H, "W": W}``.
    """

    def __init__(
        self,
        pred: torch.Tensor,
        ref: torch.Tensor | PreparedReference,
        mask: torch.Tensor | None = None,
        *,
        tile: int = 64,
    ) -> None:
        prepared = ref if isinstance(ref, PreparedReference) else None
        self.size = _check_pair(pred, ref if prepared is None else prepared.color, mask, prepared)
        self.tile = check_positive_int(tile, "tile", minimum=2)
        if prepared is None:
            assert isinstance(ref, torch.Tensor)  # _check_pair checked it
            prepared = PreparedReference(ref)
        self.pred, self.ref, self.mask = pred, prepared, mask
        self._maps: dict[object, Any] = {}

    def in_region(self, mask: torch.Tensor | None) -> ImagePair:
        """This image against the same reference over the pixels of ``mask`` (``[H, W]`` bool;
        None: every pixel), sharing this pair's whole-image maps (computed at most once for
        every region's pair).

        Raises:
            ShapeError, DtypeError, ValueRangeError: as the constructor's mask checks.
        """
        _check_mask(mask, self.size)
        return self._sharing(mask, self._maps)

    def error_only(self) -> ImagePair:
        """This pair keeping only its error among the maps (what a later frame's temporal
        metrics read from it), so that a window of past frames holds no other map."""
        return self._sharing(self.mask, {"err": self.err})

    def bare(self) -> ImagePair:
        """This pair holding none of its maps (what a sequence metric keeps of each frame until
        the sequence is scored: the image, reference and mask only)."""
        return self._sharing(self.mask, {})

    def _sharing(self, mask: torch.Tensor | None, maps: dict[object, Any]) -> ImagePair:
        """A pair of this image and reference over ``mask`` (checked) holding ``maps``."""
        pair = object.__new__(ImagePair)
        pair.size, pair.tile, pair.pred, pair.ref = self.size, self.tile, self.pred, self.ref
        pair.mask, pair._maps = mask, maps
        return pair

    def _map(self, key: object, compute: Callable[[], Any]) -> Any:
        """The whole-image map ``key``, computed by ``compute`` the first time it is asked for."""
        if key not in self._maps:
            self._maps[key] = compute()
        return self._maps[key]

    @property
    def err(self) -> torch.Tensor:
        """``pred - ref`` in float64, ``[C, H, W]``."""
        return self._map("err", lambda: self.pred.to(torch.float64) - self.ref.ref64)

    @functools.cached_property
    def _mse(self) -> torch.Tensor:
        return masked_sum(self._map("err^2", self.err.square), self.mask)

    def score(self, value: float) -> torch.Tensor:
        """A per-image score as the pair ``(value, 1)``, so that compute averages it over frames."""
        return _value_update(value, self.pred.device)

    def mse(self) -> torch.Tensor:
        """``(sum e^2, pixel count)`` over the (masked) pixels and channels."""
        return self._mse

    def relmse(self) -> torch.Tensor:
        """``(sum e^2 / (ref^2 + 0.01), pixel count)``."""
        relative = self._map(
            "err^2/den",
            lambda: self._map("err^2", self.err.square) / self.ref.relmse_denominator,
        )
        return masked_sum(relative, self.mask)

    def blurred(self, sigma: float) -> torch.Tensor:
        """``(sum (G_sigma * e)^2, pixel count)``: the error blurred over the whole image first."""
        kernel = _check_blur_size(self.size, sigma)
        blurred = self._map(
            ("blur^2", sigma), lambda: _gaussian_blur(self.err, sigma, kernel).square()
        )
        return masked_sum(blurred, self.mask)

    def psnr(self) -> torch.Tensor:
        """The PSNR (peak: the reference's range) as a score."""
        return self.score(_psnr_value(self._mse, self.ref.color, None))

    def ssim(self) -> torch.Tensor:
        """The mean SSIM (the reference's half prepared once) as a score."""
        smap = self._map("ssim", lambda: self.ref.ssim.map(self.pred))
        return self.score(_SSIMReference.mean(smap, self.mask))

    def flip(self) -> torch.Tensor:
        """The mean HDR-FLIP error as a score (needs ``flip-evaluator``)."""
        return self.score(_flip_value(self.pred, self.ref.color, self.mask))

    def lowfreq(self) -> torch.Tensor:
        """The error's low-frequency fraction on ``tile x tile`` tiles as a score (no mask)."""
        fraction = self._map("lowfreq", lambda: low_frequency_fraction(self.err, tile=self.tile))
        return self.score(fraction)


# --------------------------------------------------------------------------------------------------
# Per-image metrics (pure functions)


def mse(pred: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
    """Mean squared error ``mean((pred - ref)^2)`` over channels and (masked) pixels.

    Args:
        pred: ``[C, H, W]`` floating, finite (a :class:`~bnerr.errors.NonFiniteError` otherwise).
        ref: ``[C, H, W]`` reference of the same shape.
        mask: optional ``[H, W]`` bool; only the selected pixels count.

    Returns:
        A 0-dim float64 tensor on the inputs' device (accumulated in float64).
    """
    _check_pair(pred, ref, mask)
    return pooled_mean(_mse_update(pred, ref, mask))


def relmse(pred: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
    """Relative MSE ``mean((pred - ref)^2 / (ref^2 + 0.01))``; shapes as in :func:`mse`."""
    _check_pair(pred, ref, mask)
    return pooled_mean(_relmse_update(pred, ref, mask))


def psnr(
    pred: torch.Tensor,
    ref: torch.Tensor,
    data_range: float | None = None,
    mask: torch.Tensor | None = None,
) -> float:
    """Peak signal-to-noise ratio in dB, ``10 log10(peak^2 / mse)``; ``inf`` for a perfect match.

    ``peak`` is ``data_range`` if given, else ``ref.max() - ref.min()`` (HDR images have no fixed
    peak; the reference's range is torchmetrics' default too). Shapes as in :func:`mse`.
    """
    _check_pair(pred, ref, mask)
    if data_range is not None:
        check_range(data_range, "data_range", 1e-12, math.inf)
    return _psnr_value(_mse_update(pred, ref, mask), ref, data_range)


def ssim(pred: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor | None = None) -> float:
    """Structural similarity (Wang et al. 2004) as scikit-image computes it, channels averaged.

    ``data_range`` is the reference's ``max - min``; 7x7 uniform window, so H and W must be >= 7.
    With a mask, the SSIM map is averaged over the selected pixels (away from the 3-pixel border
    that scikit-image excludes too). Runs on the CPU in float64 whatever the inputs' device.
    """
    _check_pair(pred, ref, mask)
    return _ssim_value(pred, ref, mask)


def blurred_mse(
    pred: torch.Tensor, ref: torch.Tensor, sigma: float, mask: torch.Tensor | None = None
) -> torch.Tensor:
    """MSE of the error after a Gaussian blur of ``sigma`` px: ``mean(G_sigma * (pred - ref))^2``.

    Kernel ``2 ceil(3 sigma) + 1`` taps, reflect border (H and W must exceed half the kernel).
    Shapes and return as in :func:`mse`.
    """
    size = _check_pair(pred, ref, mask)
    kernel = _check_blur_size(size, sigma)
    return pooled_mean(_blurred_mse_update(pred, ref, float(sigma), kernel, mask))


def flip_available() -> bool:
    """Whether the optional package ``flip-evaluator`` (for :func:`flip`) is installed."""
    return importlib.util.find_spec("flip_evaluator") is not None


def flip(pred: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor | None = None) -> float:
    """Mean HDR-FLIP error (Andersson et al. 2021) of ``pred [3, H, W]`` against ``ref [3, H, W]``.

    Linear RGB, negative values clamped to 0 (HDR-FLIP's input domain), default viewing conditions
    (67 pixels per degree) and exposure range chosen by FLIP from the reference. Raises
    ``ImportError`` with the install command when ``flip-evaluator`` is missing. About 0.5 s for
    256x256 on one core: not for tight loops.
    """
    _check_pair(pred, ref, mask)
    return _flip_value(pred, ref, mask)


def lowfreq(pred: torch.Tensor, ref: torch.Tensor, tile: int = 64, cutoff: float = 0.125) -> float:
    """Fraction of the error's power below ``cutoff`` cycles/pixel on ``tile x tile`` tiles.

    :func:`bnerr.metrics.spectrum.low_frequency_fraction` of ``pred - ref``: about 0.047 (64x64
    tiles) for white noise, near 0 for blue noise. Shapes as in :func:`mse`; no mask (a spectrum
    needs whole tiles).
    """
    _check_pair(pred, ref)
    return low_frequency_fraction(
        pred.to(torch.float64) - ref.to(torch.float64), tile=tile, cutoff=cutoff
    )


def edge_mask(object_id: torch.Tensor, radius: int = 1) -> torch.Tensor:
    """Pixels within ``radius`` pixels (Chebyshev) of an object-id discontinuity: ``[H, W]`` bool.

    A pixel is on an edge when its 4-neighbour has a different object id; the edge set is then
    dilated by ``radius``. This is where the temporal method is expected to fail (a seed's value
    does not carry to a pixel on another object), so the stability suite measures error there.

    Args:
        object_id: ``[1, H, W]`` (a Frame's ``object_id``) or ``[H, W]``, any dtype.
        radius: dilation radius in pixels, >= 0.
    """
    check_tensor(object_id, "object_id")
    ids = object_id[0] if object_id.ndim == 3 and object_id.shape[0] == 1 else object_id
    check_shape(ids, "H W", "object_id")
    check_positive_int(radius, "radius", minimum=0)
    edge = torch.zeros(ids.shape, dtype=torch.bool, device=ids.device)
    dy = ids[1:, :] != ids[:-1, :]
    dx = ids[:, 1:] != ids[:, :-1]
    edge[1:, :] |= dy
    edge[:-1, :] |= dy
    edge[:, 1:] |= dx
    edge[:, :-1] |= dx
    return _grown(edge, radius)


def _grown(mask: torch.Tensor, radius: int) -> torch.Tensor:
    """``mask [H, W]`` bool dilated by ``radius`` pixels (Chebyshev: a square window)."""
    if radius == 0 or not bool(mask.any()):
        return mask
    size = 2 * radius + 1
    grown = torch.nn.functional.max_pool2d(mask[None, None].float(), size, stride=1, padding=radius)
    return grown[0, 0] > 0


def temporal_correlation(
    err: torch.Tensor, prev: torch.Tensor, motion: torch.Tensor | None = None
) -> float:
    """Pearson correlation of a frame's error with the previous frame's error at the same surface.

    What temporal accumulation (TAA, SVGF) depends on: it averages a pixel's error with the
    history fetched at ``p - motion(p)``, and errors that repeat from frame to frame average out
    less than independent ones (docs/METHODS.md, section 9). The previous error is fetched at the
    nearest pixel to ``p - motion(p)`` (no bilinear mixing, which would itself lower the
    correlation); pixels whose source lies off screen are left out. All channels pool into one
    coefficient, computed in float64: about 0 for fresh white noise every frame, 1 for an error
    that does not change.

    Args:
        err: ``[C, H, W]`` error of frame t (``pred - ref``).
        prev: ``[C, H, W]`` error of frame t-1, same shape, dtype and device.
        motion: ``[2, H, W]`` screen-space motion in pixels from t-1 to t (a Frame's ``motion``),
            or None for a static camera.

    Returns:
        The coefficient in [-1, 1]; 0.0 when either error is constant over the pixels compared.
    """
    _check_pair(err, prev)
    _, h, w = err.shape
    if motion is None:
        now, then = err.to(torch.float64), prev.to(torch.float64)
    else:
        check_shape(motion, f"2 {h} {w}", "motion")
        dev = err.device
        sy = torch.arange(h, device=dev, dtype=torch.float64)[:, None] - motion[1].double()
        sx = torch.arange(w, device=dev, dtype=torch.float64)[None, :] - motion[0].double()
        iy, ix = torch.round(sy).long(), torch.round(sx).long()
        inside = (iy >= 0) & (iy < h) & (ix >= 0) & (ix < w)
        then = prev.to(torch.float64)[:, iy.clamp(0, h - 1), ix.clamp(0, w - 1)][:, inside]
        now = err.to(torch.float64)[:, inside]
    a, b = now.reshape(-1), then.reshape(-1)
    if a.numel() < 2:
        return 0.0
    a, b = a - fixed_sum(a) / a.numel(), b - fixed_sum(b) / b.numel()
    denom = math.sqrt(float(fixed_sum(a * a)) * float(fixed_sum(b * b)))
    return float(fixed_sum(a * b)) / denom if denom > 0 else 0.0


def light_mask(
    object_id: torch.Tensor, lights: tuple[int, ...] | list[int], radius: int = 1
) -> torch.Tensor:
    """Pixels within ``radius`` pixels (Chebyshev) of one whose first hit is a light: ``[H, W]``
    bool.

    A light the camera sees is an edge of very high radiance (the Cornell box's, 18.6 against a
    0.5 ceiling): the share of it a pixel covers is decided by the pixel jitter alone, and under
    HDR MSE those few pixels outweigh the rest of the image (docs/FINDINGS.md). The suites'
    ``unlit`` region is every pixel but these.

    Args:
        object_id: ``[1, H, W]`` (a Frame's ``object_id``, the object index as a float) or
            ``[H, W]``.
        lights: the object indices of the lights (:attr:`renderers.Scene.lights`); none: no pixel.
        radius: dilation radius in pixels, >= 0.
    """
    check_tensor(object_id, "object_id")
    ids = object_id[0] if object_id.ndim == 3 and object_id.shape[0] == 1 else object_id
    check_shape(ids, "H W", "object_id")
    check_positive_int(radius, "radius", minimum=0)
    rounded = ids.round().long()
    hit = torch.zeros(ids.shape, dtype=torch.bool, device=ids.device)
    for light in lights:
        hit |= rounded == int(light)
    return _grown(hit, radius)


#: Scene-linear white over mid-grey of Blender's Filmic and AgX view transforms (16.29 / 0.18):
#: exposed so that the frame's mean sits at mid-grey, a pixel this many times brighter than the
#: mean is clipped to the display's white.
DISPLAY_WHITE_OVER_MEAN = 16.29 / 0.18


def highlight_mask(
    reference: torch.Tensor, over_mean: float = DISPLAY_WHITE_OVER_MEAN, radius: int = 1
) -> torch.Tensor:
    """Pixels within ``radius`` pixels (Chebyshev) of one that a display clips: ``[H, W]`` bool.

    A pixel is a highlight when its reference luminance exceeds ``over_mean`` times the frame's
    mean luminance (default :data:`DISPLAY_WHITE_OVER_MEAN`: brighter than Filmic's or AgX's
    white with the mean exposed as mid-grey). A mirror image of a small light or a caustic is
    such a pixel: whether a path finds it is a rare event, its error is a firefly, and under HDR
    MSE a handful of them can hold nearly all of a frame's error although the display shows
    each as plain white (docs/FINDINGS.md, Cycles' product shot).

    Args:
        reference: ``[3, H, W]`` linear RGB (or ``[1, H, W]`` / ``[H, W]`` luminance).
        over_mean: the threshold as a multiple of the mean luminance, > 0.
        radius: dilation radius in pixels, >= 0.
    """
    check_tensor(reference, "reference")
    check_positive_int(radius, "radius", minimum=0)
    if not math.isfinite(over_mean) or over_mean <= 0:
        raise ValueRangeError(f"over_mean: expected a finite number > 0, got {over_mean!r}")
    lum = luminance(reference, dtype=torch.float64)
    return _grown(lum > over_mean * lum.mean(), radius)
