"""LDBN strategies: one shared padded Owen-Sobol sequence read through per-pixel ranking and
scrambling keys optimized offline (:class:`bnerr.sequences.LDBNSampler`, :mod:`bnerr.ldbn`).

- ``ldbn``: the screen-space key set (``ldbn_screen_64``): frame t reads the tiles at the R2
  offset of frame t plus a per-seed-set offset, so frames are independent draws of one blue
  pattern (as the engines that shift the tile per frame do);
- ``ldbn_st``: the spatiotemporal key set (``ldbn_st_64x<F>``): frame t reads slice ``t mod F``,
  whose keys are blue in space and make each pixel's errors differ from frame to frame, at one
  offset per seed set, for temporal accumulation;
- ``ldbn_fast``: the key set optimized against the Gaussian denoiser's kernel (``ldbn_fast_64``,
  sigma 0.75, the tuned sigma at 4 spp), read like ``ldbn``;
- ``ldbn_atrous``: the key set optimized against the a-trous filter's kernel as measured on the
  scenes' own buffers at 4 spp (``ldbn_atrous_64``; ``benchmarks.kernels``,
  ``python -m bnerr.ldbn.matched``), read like ``ldbn``.

All four need ``spp`` (the level of the tiles: the smallest tile for at least spp samples) and
give fresh per-pixel seeds every frame for the dimensions past the optimized ones (the pixel's own
Owen-Sobol sequence there). They dictate their own sampler (``ldbn``).
"""

from __future__ import annotations

from typing import ClassVar

import torch

from bnerr.errors import ValueRangeError, check_positive_int
from bnerr.frame import Frame
from bnerr.hashing import lowbias32_host
from bnerr.ldbn.keys import load_ldbn_keys
from bnerr.masks import frame_offset
from bnerr.sequences import LDBNKeys, LDBNSampler
from bnerr.strategies.base import BuildOptions, RenderFn, Strategy, pixel_seeds, stream_key
from bnerr.strategies.variants import TemporalOptions

__all__ = ["LDBN_SETS", "LDBNATrousStrategy", "LDBNFastStrategy", "LDBNSTStrategy", "LDBNStrategy"]

#: Strategy -> the shipped key set it reads: ``(kind, frames, levels)``
#: (:func:`bnerr.ldbn.load_ldbn_keys`; tiles for 1 .. 2^(levels - 1) spp).
LDBN_SETS: dict[str, tuple[str, int, int]] = {
    "ldbn": ("screen", 1, 5),
    "ldbn_fast": ("fast", 1, 5),
    "ldbn_atrous": ("atrous", 1, 5),
    "ldbn_st": ("st", 4, 3),
}


class LDBNStrategy(Strategy):
    """``ldbn``: the screen-space keys, shifted per frame by the R2 step (module docstring).

    Args:
        keys: one :class:`LDBNKeys` per frame slice (one for a screen tile).
        spp: the samples per pixel the renders take (selects the tiles' level).
    """

    name = "ldbn"
    own_sampler = "ldbn"
    stream = 20
    family = "ldbn"
    rank = 60
    color = "#6a3d9a"
    #: whether frame t reads slice t mod F unshifted (True) or shifts slice 0 per frame
    per_frame_slices: ClassVar[bool] = False

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        keys: list[LDBNKeys],
        spp: int,
        device: torch.device | str = "cpu",
    ) -> None:
        if spp is None:
            raise ValueRangeError(f"spp: expected the samples per pixel for {self.name}, got None")
        self.spp = check_positive_int(spp, "spp")
        super().__init__(height, width, seed=seed, device=device)
        if not keys or not all(isinstance(k, LDBNKeys) for k in keys):
            raise ValueRangeError("keys: expected a non-empty list of LDBNKeys")
        self.keys = keys
        self.size = keys[0].size
        key = stream_key(self.seed, 0, self.stream)
        self.shift = (key % self.size, lowbias32_host(key) % self.size)

    @classmethod
    def create(
        cls, height: int, width: int, build: BuildOptions, options: TemporalOptions
    ) -> Strategy:
        kind, frames, levels = LDBN_SETS[cls.name]
        keys = load_ldbn_keys(kind, build.mask_size, frames, levels)
        return cls(height, width, keys=keys, spp=build.spp, **build.common)  # type: ignore[arg-type]

    def sampler(self, t: int) -> LDBNSampler:
        """Frame ``t``'s sampler: its keys and its offset (module docstring)."""
        if self.per_frame_slices:
            keys, (dy, dx) = self.keys[t % len(self.keys)], (0, 0)
        else:
            keys, (dy, dx) = self.keys[0], frame_offset(t, self.size)
        return LDBNSampler(keys, spp=self.spp, offset=(self.shift[0] + dy, self.shift[1] + dx))

    def seeds(self, t: int) -> torch.Tensor:
        """Frame ``t``'s fresh per-pixel seeds (read past the optimized dimensions)."""
        key = stream_key(self.seed, t, self.stream)
        return pixel_seeds(self.height, self.width, key, self.device)

    def _frame(self, t: int, render: RenderFn) -> Frame:
        return render(self.seeds(t), self.sampler(t))


class LDBNSTStrategy(LDBNStrategy):
    """``ldbn_st``: the spatiotemporal keys, slice ``t mod F`` in frame t, one offset per seed
    set (module docstring)."""

    name = "ldbn_st"
    stream = 21
    per_frame_slices = True
    rank = 70
    color = "#9467bd"


class LDBNFastStrategy(LDBNStrategy):
    """``ldbn_fast``: the keys optimized for the tuned Gaussian denoiser (module docstring)."""

    name = "ldbn_fast"
    stream = 22
    rank = 80
    color = "#c5b0d5"


class LDBNATrousStrategy(LDBNStrategy):
    """``ldbn_atrous``: the keys optimized for the a-trous filter's measured kernel (module
    docstring)."""

    name = "ldbn_atrous"
    stream = 28
    rank = 82
    color = "#8c6bb1"
