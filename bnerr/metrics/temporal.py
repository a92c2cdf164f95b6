"""Metrics of consecutive frames: the flicker a viewer sees, as the updates of the metric table.

A per-frame metric cannot tell a steady error from one that changes every frame: the same error
image shown with alternating sign has the per-frame MSE of a constant one, yet the first flickers
and the second does not. These updates see the current frame of a seed set together with the
frames before it (a :class:`~bnerr.metrics.frames.Metric` whose ``window`` is above 1:
:class:`~bnerr.metrics.frames.FrameMetrics` keeps them) and reduce the window to one
``(numerator, denominator)`` pair, so that pooling, intervals over seed sets and paired ratios to
white come from the same compute step as every other metric (docs/METHODS.md, section 6):

- ``tmse`` (:func:`frame_difference_mse`): ``mean(((p_t - p_{t-1}) - (r_t - r_{t-1}))^2)``, the
  MSE of the frame-to-frame change against the reference's own change, which is ``mean((e_t -
  e_{t-1})^2)`` with ``e = p - r``: Noisebase's temporal metrics (tPSNR, tRMAE) apply a spatial
  metric to the two frame differences in the same way;
- ``trelmse`` (:func:`frame_difference_relmse`): the same divided per pixel by ``r_t^2 + 0.01``,
  as ``relmse`` divides the error, so that flicker in the dark counts as much as in the light;
- ``mse_tavg`` (:func:`window_average_mse`): the MSE of the mean of the last up to
  :data:`TAVG_FRAMES` frames against the mean of their references, what a short temporal filter
  (or the eye) keeps: an error that alternates cancels in it, a steady one stays.

**Screen space.** Differences are taken pixel by pixel on the screen, never along the motion: when
the camera moves, the reference's own difference ``r_t - r_{t-1}`` holds the motion, so the
motion itself is no error; what is left is the change of the error, the flicker.

**Windows.** A window holds the consecutive measured frames of one seed set that end at the
current frame, oldest first. The first frame of a seed set (no frame before it), and a frame
right after one whose region held no pixel, give ``(0, 0)``: nothing measured, no weight in the
pooled mean. With a mask, only the pixels in the region in every frame of the window count.

Not for: motion-compensated (warped) differences, or the raw error's correlation from frame to
frame (:func:`bnerr.metrics.image.temporal_correlation`).
"""

from __future__ import annotations

from collections.abc import Sequence

import torch

from bnerr.errors import ShapeError
from bnerr.metrics.image import ImagePair, masked_sum

__all__ = [
    "TAVG_FRAMES",
    "frame_difference_mse",
    "frame_difference_relmse",
    "window_average_mse",
]

#: The most frames ``mse_tavg`` averages (fewer at the start of a seed set).
TAVG_FRAMES = 4


def _window_mask(pairs: Sequence[ImagePair]) -> torch.Tensor | None:
    """The pixels in the region in every frame of the window (None: every pixel)."""
    masks = [p.mask for p in pairs if p.mask is not None]
    if not masks:
        return None
    mask = masks[0]
    for other in masks[1:]:
        mask = mask & other
    return mask


def _window(pairs: Sequence[ImagePair]) -> tuple[torch.Tensor | None, bool]:
    """The window's mask, and whether it measures anything (two frames or more, one pixel in
    the region in all of them)."""
    if len(pairs) < 2:
        return None, False
    shape = pairs[-1].pred.shape
    for p in pairs[:-1]:
        if p.pred.shape != shape:
            raise ShapeError(
                f"pred: expected every frame of a seed set to have the shape {list(shape)}, "
                f"got {list(p.pred.shape)}"
            )
    mask = _window_mask(pairs)
    return mask, mask is None or bool(mask.any())


def _nothing(pairs: Sequence[ImagePair]) -> torch.Tensor:
    return torch.zeros(2, dtype=torch.float64, device=pairs[-1].pred.device)


def frame_difference_mse(pairs: Sequence[ImagePair]) -> torch.Tensor:
    """``tmse``'s pair: ``(sum ((p_t - p_{t-1}) - (r_t - r_{t-1}))^2, pixel count)`` of the last
    two frames of ``pairs`` (oldest first); ``(0, 0)`` with fewer than two."""
    mask, measured = _window(pairs)
    if not measured:
        return _nothing(pairs)
    change = pairs[-1].err - pairs[-2].err
    return masked_sum(change.square(), mask)


def frame_difference_relmse(pairs: Sequence[ImagePair]) -> torch.Tensor:
    """``trelmse``'s pair: as :func:`frame_difference_mse`, each pixel's squared change divided
    by ``r_t^2 + 0.01`` (the current reference, as ``relmse`` divides the error)."""
    mask, measured = _window(pairs)
    if not measured:
        return _nothing(pairs)
    change = pairs[-1].err - pairs[-2].err
    return masked_sum(change.square() / pairs[-1].ref.relmse_denominator, mask)


def window_average_mse(pairs: Sequence[ImagePair]) -> torch.Tensor:
    """``mse_tavg``'s pair: ``(sum (mean_k p_k - mean_k r_k)^2, pixel count)`` over the last
    :data:`TAVG_FRAMES` frames of ``pairs`` (all of them when fewer); ``(0, 0)`` with fewer than
    two."""
    window = list(pairs)[-TAVG_FRAMES:]
    mask, measured = _window(window)
    if not measured:
        return _nothing(window)
    total = window[0].err
    for p in window[1:]:
        total = total + p.err
    return masked_sum((total / len(window)).square(), mask)
