"""``oracle``: the a-posteriori histogram sampling of Heitz & Belcour 2019, section 3.

K renders with K distinct seed images, per pixel the candidate at rank ``floor(b K)`` of the
candidates' luminance (``b`` the scalar mask at the frame's offset), its buffers assembled into one
frame. K renders per frame: the upper bound that the temporal algorithm approximates.
"""

from __future__ import annotations

import torch

from bnerr.color import luminance
from bnerr.errors import check_positive_int
from bnerr.frame import Frame
from bnerr.masks import frame_offset, load_mask, tile_mask
from bnerr.permutation.permute import histogram_select
from bnerr.strategies.base import (
    FRAME_BYTES,
    BuildOptions,
    RenderFn,
    Strategy,
    per_pixel_sampler,
    pixel_seeds,
    stream_key,
)
from bnerr.strategies.variants import TemporalOptions

__all__ = ["OracleStrategy"]


class OracleStrategy(Strategy):
    """``oracle``: K candidate renders, per pixel the candidate at rank floor(b K) by luminance.

    The K renders go through ``render.batch`` (the tracer's :func:`renderers.tracer.render_batch`
    when the caller offers it: the same frames bit for bit, faster at low spp).

    Every buffer of the chosen candidate is assembled per pixel (color, albedo, normal, ...), so
    the frame is one the renderer could have produced with the per-pixel chosen seed. Memory: the
    K candidate frames and their luminance are held until the selection, then the choice, the
    assembled frame and one temporary of ``torch.where`` per buffer (2 frames) and a seed image
    (:meth:`peak_bytes_per_pixel`; 172 bytes per pixel measured with K = 4).
    """

    name = "oracle"
    stream = 4
    family = "bound"
    rank = 120
    bound_note = "it renders K candidates per frame: an upper bound, not a strategy to adopt"
    color = "#000000"

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        sampler: str = "owen_sobol",
        mask: torch.Tensor,
        K: int = 32,
        device: torch.device | str = "cpu",
    ) -> None:
        self.K = check_positive_int(K, "K")
        super().__init__(height, width, seed=seed, device=device)
        self.sampler = per_pixel_sampler(sampler)
        self.sampler_name = sampler
        self.mask = mask
        self.mask_size = mask.shape[-1]

    @classmethod
    def peak_bytes_per_pixel(cls, K: int = 32, options: TemporalOptions | None = None) -> int:
        candidate = FRAME_BYTES + 4
        return K * candidate + 8 + 2 * FRAME_BYTES + cls.bytes_per_pixel

    def _bytes_per_pixel(self) -> int:
        return self.peak_bytes_per_pixel(self.K)

    @classmethod
    def create(
        cls, height: int, width: int, build: BuildOptions, options: TemporalOptions
    ) -> Strategy:
        scalar = load_mask("scalar", build.mask_size)
        return cls(height, width, sampler=build.sampler, mask=scalar, K=build.K, **build.common)

    def _choose(self, t: int, colors: list[torch.Tensor]) -> torch.Tensor:
        """The candidate of every pixel ``[H, W]``: the histogram sampling of the candidates'
        luminance at the mask's rank (a subclass may choose otherwise:
        :class:`bnerr.strategies.vertical.VerticalStrategy`)."""
        lum = torch.stack([luminance(c) for c in colors])
        device = lum.device
        b = tile_mask(
            self.mask.to(device), self.height, self.width, frame_offset(t, self.mask_size)
        )
        return histogram_select(lum, b)

    def _frame(self, t: int, render: RenderFn) -> Frame:
        seeds = [
            pixel_seeds(
                self.height, self.width, stream_key(self.seed, t, self.stream, k), self.device
            )
            for k in range(self.K)
        ]
        frames = render.batch(torch.stack(seeds), self.sampler)
        device = frames[0].color.device
        choice = self._choose(t, [f.color.to(device) for f in frames])
        buffers = {}
        for name, first in frames[0].buffers().items():
            chosen = first.to(device).clone()
            for k in range(1, self.K):
                buf = getattr(frames[k], name)
                if buf is not None:
                    chosen = torch.where(choice == k, buf.to(device), chosen)
            buffers[name] = chosen
        timings: dict[str, float] = {}
        for f in frames:
            for key, ms in f.timings.items():
                timings[key] = timings.get(key, 0.0) + ms
        return Frame(**buffers, timings=timings, own_denoised={})
