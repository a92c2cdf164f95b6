"""The per-channel median filter: :func:`median_filter` (kornia's ``median_blur``), its memory
estimate and its class.

Not for: unbiased denoising (the median of skewed Monte Carlo noise sits below its mean).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import ClassVar

import torch

from bnerr.errors import ValueRangeError, check_memory, check_positive_int
from bnerr.frame import Frame
from denoisers.base import Denoiser
from denoisers.filters.common import _BORDER

__all__ = ["Median", "median_bytes", "median_filter"]


def median_filter(color: torch.Tensor, kernel_size: int) -> torch.Tensor:
    """Per-channel median over a ``kernel_size`` square window of ``color [3, H, W]``.

    Removes isolated fireflies well; on skewed Monte Carlo noise the median of a window is below
    its mean, so it darkens (biases) the image. That trade-off is what the tuning measures.
    """
    import kornia.filters as KF  # 0.8 s (all of kornia): only where one runs

    return KF.median_blur(color[None], (kernel_size, kernel_size), border_type=_BORDER)[0]


def median_bytes(height: int, width: int, kernel_size: int) -> int:
    """Rough peak memory of :func:`median_filter` (float32): kornia unfolds every window, ``k^2``
    values per pixel and channel, and sorts them (a second copy)."""
    return 4 * 3 * 2 * kernel_size * kernel_size * height * width


class Median(Denoiser):
    """Per-channel median filter; see :func:`median_filter`. Reads color only."""

    name = "median"
    grid: ClassVar[Mapping[str, Sequence[object]]] = {"kernel_size": (3, 5)}

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

    def params(self) -> dict[str, float | int | str]:
        return {"kernel_size": self.kernel_size}
