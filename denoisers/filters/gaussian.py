"""The Gaussian blur: :func:`gaussian_filter` (kornia's ``gaussian_blur2d``) and its class.

The linear low-pass of the benchmark. Not for: edges (it blurs across them; the feature-guided
filters of this package keep them).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import ClassVar

import torch

from bnerr.frame import Frame
from denoisers.base import Denoiser
from denoisers.filters.common import _BORDER, _number, _odd

__all__ = ["Gaussian", "gaussian_filter"]


def gaussian_filter(color: torch.Tensor, sigma: float) -> torch.Tensor:
    """Isotropic Gaussian blur of ``color [3, H, W]``, truncated at 3 sigma.

    The linear low-pass the project's claim is about: it removes the high frequencies where a
    blue-noise error lives. Blurs across edges, so it also biases the image.
    """
    import kornia.filters as KF  # 0.8 s (all of kornia): only where one runs

    k = _odd(3.0 * sigma)
    return KF.gaussian_blur2d(color[None], (k, k), (sigma, sigma), border_type=_BORDER)[0]


class Gaussian(Denoiser):
    """Gaussian blur of ``sigma`` pixels; see :func:`gaussian_filter`. Reads color only."""

    name = "gaussian"
    grid: ClassVar[Mapping[str, Sequence[object]]] = {"sigma": (0.5, 0.75, 1.0, 1.5, 2.0, 3.0)}

    def __init__(self, sigma: float = 1.0) -> None:
        self.sigma = _number(sigma, "gaussian: sigma", 0.1, 16.0)

    def denoise(self, frame: Frame) -> torch.Tensor:
        return gaussian_filter(frame.color, self.sigma)

    def params(self) -> dict[str, float | int | str]:
        return {"sigma": self.sigma}
